"""The tuning loop of the paper (Section II-D, steps 1-4): identify, tune, verify, repeat.

1. Design ``n_t + 1`` experiments around the current bias (eq. 18) and check the rank condition
   (6). The first iteration sweeps the whole band; later ones a window around the modes the
   previous verification measured (:class:`~sysid_core.run.sweeps.SweepPlan`).
2. Fit one bias-dependent model to them.
3. Apply the tuning criterion. If it finds its goal unreachable inside the limits, the run ends
   with :class:`~sysid_core.errors.UnreachableTuningError`, unless iterations remain and the
   best reachable bias is more than ``bias_step`` away (the model extrapolated): then the run
   continues from that bias and a model identified around it decides.
4. Verify at the new bias (:mod:`sysid_core.run.verification`): a window around the predicted modes;
   if it does not show both modes (or the predicted split is wider than the window), the whole
   band, to locate them, then a window around them if they are close. A split counts as
   measured only when the evidence says both modes are in a window that resolves them.

The run converges when a verification is *verified* and every goal of the criterion is met (the
split under ``acceptance_hz``; for ``target``, also the frequency error). Otherwise it goes on
from the new bias, from a whole-band sweep if the modes were not found, until
``max_iterations``.

Everything is checked before the first measurement: the configuration, every plugin (built
here), the device's protocol attributes, the bias limits, the sweeps and the first design. Every
measurement is checked (:mod:`sysid_core.device.measuring`) and written to the run folder
(:mod:`sysid_core.data.runfolder`) before anything else is done with it. A run that stops can be
continued with ``resume=True``: the loop is replayed and every measurement on disk is read
instead of measured again.

Length: a little over the project's 300 lines; it is the loop and its steps, each a short
method, the steps' work being done in their own modules (sweeps, runfolder, fit, verification).
"""

from __future__ import annotations

import dataclasses
import time
from pathlib import Path

import numpy as np
import xarray as xr

from sysid_core.data.io import write_json
from sysid_core.data.runfolder import RunFolder
from sysid_core.data.schema import (
    concat_experiments,
    experiment_from_measurement,
)
from sysid_core.data.validation import check_rank_condition
from sysid_core.device.measuring import GuardedDevice, applied_bias, check_bias
from sysid_core.device.protocol import Device, ReportsProgress
from sysid_core.errors import ConfigError, DeviceError, UnreachableTuningError
from sysid_core.identification.fitting import fit_structure
from sysid_core.identification.objective import Progress
from sysid_core.model.fitted import FittedModel
from sysid_core.model.structures import ModelStructure
from sysid_core.plugin.registry import Registry, get_registry
from sysid_core.run.benchtime import dwell, points_per_frequency
from sysid_core.run.components import build_components
from sysid_core.run.config import PipelineConfig
from sysid_core.run.dac import best_code
from sysid_core.run.evidence import WindowAssessment, assess_window
from sysid_core.run.knowledge import Knowledge
from sysid_core.run.lean import (
    EXPLAIN_FLOOR_HZ,
    LOCAL_RADIUS,
    LOCATE_POINTS,
    ModeGuess,
    explained_gap,
    locate_plan,
    mode_grid,
    predicted_uncertainty,
    scout_grid,
)
from sysid_core.run.plots import PLOT_FORMATS, plot_bias_path, plot_iteration
from sysid_core.run.summary import IterationRecord, RunSummary, status_line
from sysid_core.run.sweeps import SweepPlan, design_experiments
from sysid_core.run.verification import Verification, verify
from sysid_core.tuning.confidence import confidence_region
from sysid_core.tuning.criteria import (
    BiasSpace,
    ConfidenceRegion,
    Goal,
    TuningResult,
    frequencies_from_w,
    solve_criterion,
)

__all__ = ["TuningRun"]


class TuningRun:
    """One run of the tuning loop, writing everything into ``out``.

    Building the run checks everything that can be checked without measuring (and writes
    nothing): the configuration's plugins are created, the device's protocol attributes, the
    start bias, the sweeps and the first experiment design are checked, and ``out`` must be
    usable (empty for a new run; holding this run for ``resume``).

    Parameters
    ----------
    config : PipelineConfig
        Validated configuration.
    out : path
        Output directory.
    resume : bool
        Continue the run in ``out``: measurements on disk are read, not measured again.
    progress : callable, optional
        Receives one-line progress messages.
    device : Device, optional
        Use this device object instead of creating ``config.device`` from the registry.
    registry : Registry, optional
        Where plugins are looked up (default: the process-wide registry).
    plots : bool
        Write the plots (default true).
    plot_format : str
        Their format: ``png`` (default), ``pdf`` or ``svg``.
    """

    def __init__(
        self,
        config: PipelineConfig,
        out: str | Path,
        resume: bool = False,
        progress: Progress | None = None,
        device: Device | None = None,
        registry: Registry | None = None,
        plots: bool = True,
        plot_format: str = "png",
    ) -> None:
        self.config = config
        self.out = Path(out)
        self.resume = resume
        self.say = progress or (lambda _m: None)
        self.registry = registry or get_registry()
        self.plots = plots
        if plot_format not in PLOT_FORMATS:
            raise ConfigError(
                f"plot format {plot_format!r} is not one of {', '.join(PLOT_FORMATS)}"
            )
        self.plot_format = plot_format
        # Every component is built now, from this run's registry, so that a bad option fails
        # before anything is measured; the fits and the criterion use these very objects.
        parts = build_components(config, self.registry, device)
        self.owns_device = device is None
        self.structure, self.objective = parts.structure, parts.objective
        self.solver, self.criterion = parts.solver, parts.criterion
        self.device = GuardedDevice(parts.device, config.device.name, config.experiment.timeout_s)
        if isinstance(parts.device, ReportsProgress):
            parts.device.set_progress(self.say)
        dev = parts.device
        self.electrodes = [str(e) for e in dev.electrodes]
        start = config.tuning.start_bias
        self.space = BiasSpace(
            electrodes=self.electrodes,
            tuned=list(config.tuning.electrodes or self.electrodes),
            start_bias=np.asarray(start if start is not None else [0.0] * len(self.electrodes)),
            limits=(float(dev.bias_limits[0]), float(dev.bias_limits[1])),
            structure_potential=float(dev.structure_potential),
        )
        check_bias(dev, self.space.start_bias)
        self.plan = SweepPlan.from_config(config.experiment, dev.band_hz)
        self._design(self.space.start_bias)  # the first design: limits and rank condition
        self.folder = RunFolder(self.out, config.digest())
        self.folder.check(resume)
        self.measurements = 0
        self.points = 0
        self.lean = config.experiment.protocol == "lean"
        self.known = Knowledge(self.space.tuned, self.space.structure_potential)
        self.last_verified: tuple[np.ndarray, np.ndarray] | None = None
        self.moved = False  # the last answer was a move to the best reachable bias
        self.local = False  # a lean run that fits only the sweeps near its bias
        # the union's fit made to judge the last verification, reused as the iteration's fit
        self._prefit: tuple[xr.Dataset, FittedModel, list[str]] | None = None
        self.last_region: ConfidenceRegion | None = None
        self.locate_plan = locate_plan(self.plan)
        self.notes: list[str] = []

    # ------------------------------------------------------------------ measuring
    def _step(self, it: int) -> float:
        exp = self.config.experiment
        return exp.bias_step if it == 1 or exp.refine_bias_step is None else exp.refine_bias_step

    def _design(self, bias: np.ndarray, it: int = 1) -> np.ndarray:
        exp = self.config.experiment
        step = self._step(it)
        law = self.config.model.stiffness
        quadratic = law == "quadratic"
        two_sided = exp.design == "two-sided" or (exp.design is None and law != "linear")
        design = design_experiments(
            bias, self.space.index, step, self.space.limits, two_sided=two_sided
        )
        check_rank_condition(
            design[:, self.space.index],
            self.space.structure_potential,
            self.space.tuned,
            quadratic=quadratic,
        )
        return design

    def _measure(self, bias: np.ndarray, freqs: np.ndarray, path: Path) -> xr.Dataset:
        """Read ``path`` if it holds this measurement (resume), else measure and save it first."""

        def measure() -> xr.Dataset:
            self.say(
                f"measuring at [{', '.join(f'{b:.4f}' for b in bias)}] V, "
                f"{freqs[0]:.3f}-{freqs[-1]:.3f} Hz, {freqs.size} points"
            )
            da = self.device.measure(bias, freqs)
            return experiment_from_measurement(
                da, bias, self.electrodes, self.space.structure_potential, self.config.device.name
            )

        ds, was_read = self.folder.read_or_measure(path, bias, freqs, measure)
        if was_read:
            self.say(f"read {path.relative_to(self.out)} (measured earlier)")
        self.measurements += 1
        self.points += int(freqs.size) * points_per_frequency(self.device.device)
        return ds

    def _fit(
        self, ds: xr.Dataset, structure: ModelStructure | None = None
    ) -> tuple[FittedModel, list[str]]:
        """Fit ``ds``; the model and the notes of the fit (reasons to distrust it)."""
        return fit_structure(ds, structure or self.structure, self.objective, self.solver)

    # ------------------------------------------------------------------ steps
    def _identify(
        self, it: int, bias: np.ndarray, folder: Path, center_hz: float | None, split_hz: float
    ) -> tuple[xr.Dataset, FittedModel]:
        if self.lean:
            ds = self._lean_data(it, bias, folder)
        else:
            design = self._design(bias, it)
            freqs = self.plan.refine(center_hz, split_hz)
            parts = [self._measure(b, freqs, folder / f"exp{j}.nc") for j, b in enumerate(design)]
            ds = concat_experiments(parts).sel(electrode=self.space.tuned)
            self.say(
                f"iteration {it}: fitting {self.structure.name} model to {len(design)} experiments"
            )
        pre, self._prefit = self._prefit, None
        model, caught = pre[1:] if pre is not None and pre[0] is ds else self._fit_recorded(ds)
        for note in caught:  # notes of this run, not user warnings
            self.notes.append(f"iteration {it}: {note}")
            self.say(f"iteration {it}: note: {note}")
        law = model.meta.get("stiffness_law")
        if law is not None:
            stat, limit = model.meta.get("law_statistic"), model.meta.get("law_threshold")
            test = (
                f" (test of the L_p terms {stat:.3g} {'>' if law == 'quadratic' else '<='} "
                f"{limit:.3g})"
                if stat is not None and limit is not None
                else f" ({model.meta.get('law_test')})"
            )
            self.say(f"iteration {it}: stiffness law {law}{test}")
        model.save(folder / "model.nc")
        return ds, model

    def _prediction_missed(self) -> str | None:
        """Why the last prediction does not stand (the law holds only locally), or None."""
        if self.last_verified is None:
            return None
        vb, vf = self.last_verified
        split = float(vf[1] - vf[0])
        region = self.last_region
        if region is not None and split > region.split_ci_hz[1] + EXPLAIN_FLOOR_HZ:
            lo, hi = region.split_ci_hz
            return (
                f"the verified split {split * 1e3:.3g} mHz is outside the predicted 95 % range "
                f"{lo * 1e3:.3g}-{hi * 1e3:.3g} mHz"
            )
        union = self.known.union()
        model, caught = self._fit_recorded(union)
        self._prefit = (union, model, caught)  # the iteration's fit, if the union stands
        gap = explained_gap(model.modal(vb[self.space.index]).frequencies_hz, vf)
        if gap is None:
            return None
        self._prefit = None
        n = len(self.known)
        return f"a model of all {n} sweeps misses the verified modes by {gap * 1e3:.3g} mHz"

    def _fit_recorded(self, ds: xr.Dataset) -> tuple[FittedModel, list[str]]:
        """Fit ``ds``; return the model and the notes of the fit (kept, not shown)."""
        return self._fit(ds)

    def _quiet_fit(self, ds: xr.Dataset, structure: ModelStructure | None = None) -> FittedModel:
        return self._fit(ds, structure)[0]

    def _lean_data(self, it: int, bias: np.ndarray, folder: Path) -> xr.Dataset:
        """The data a lean run fits in iteration ``it`` (see :mod:`sysid_core.run.knowledge`).

        Iteration 1 measures the design of eq. (18) where the modes should be. Later ones fit
        every sweep so far while the last verification agrees with the model: its split inside
        the predicted 95 % range, and the model of all sweeps reproducing the verified modes
        (:func:`~sysid_core.run.lean.explained_gap`). Once it does not (a stiffness law that holds
        only locally), the run fits the sweeps near the bias from then on, measuring the local
        design wherever they do not meet the rank condition.
        """
        if it > 1 and self.moved:
            self.local = True
            self.say(
                f"iteration {it}: the run moved to the best reachable bias; measuring the local "
                "design there"
            )
        elif it > 1 and not self.local:
            why = self._prediction_missed()
            if why is None:
                self.say(f"iteration {it}: fitting all {len(self.known)} sweeps so far")
                return self._prefit[0] if self._prefit is not None else self.known.union()
            self.local = True
            self.say(f"iteration {it}: {why}; fitting the sweeps near the bias from now on")
        radius = LOCAL_RADIUS * self._step(it)
        if it == 1 or not self.known.meets_rank(bias, radius, self.config.model.stiffness):
            for j, b in enumerate(self._design(bias, it)):
                if not self.known.has(b):
                    self._learn(b, folder / f"exp{j}.nc")
        if it == 1:
            self.say(
                f"iteration {it}: fitting {self.structure.name} model to {len(self.known)} sweeps"
            )
            return self.known.union()
        return self.known.near(bias, radius)

    def _sweep(
        self, bias: np.ndarray, freqs: np.ndarray, path: Path, band: bool
    ) -> tuple[xr.Dataset, FittedModel, WindowAssessment]:
        sweep = self._measure(bias, freqs, path)
        # A window without both modes is expected here: the evidence says so, not the fit's notes.
        vmodel, _ = self._fit(sweep.isel(electrode=[]))
        evidence = assess_window(sweep, vmodel, band=band)
        if self.lean:
            self.known.add(sweep, evidence)
        return sweep, vmodel, evidence

    def _learn(self, bias: np.ndarray, path: Path) -> None:
        """Measure one identification experiment of a lean run where its modes should be.

        The whole band if nothing is known; a scout window if the bias steps an electrode not
        varied before; else a mode grid around the modes predicted from every sweep so far
        (:mod:`sysid_core.run.lean`). A sweep that does not show both modes is followed, at the
        same bias, by the locating band sweep, one four times as dense, then the band at
        ``resolution_hz``, until one shows them (or none is left).
        """
        guess, scout = self.known.guess(bias, self.structure, self._quiet_fit)
        locate = self.locate_plan.band()
        if guess is None:
            first = locate
        elif scout:
            grid = scout_grid(guess, self.locate_plan)
            first = locate if grid.size >= locate.size else grid
        else:
            first = mode_grid(guess, self.plan)
        denser = locate_plan(self.plan, 4 * (LOCATE_POINTS - 1) + 1).band()
        tries = [
            ("", first),
            ("-locate", locate),
            ("-locate4", denser),
            ("-band", self.plan.band()),
        ]
        done: list[np.ndarray] = []
        for suffix, freqs in tries:
            if any(d.size == freqs.size and np.allclose(d, freqs) for d in done):
                continue
            name = f"{path.stem}{suffix}.nc"
            _, _, evidence = self._sweep(bias, freqs, path.with_name(name), True)
            if evidence.ok:
                return
            done.append(freqs)
            self.say(
                f"{path.parent.name}/{name}: the sweep does not show both modes "
                f"({evidence.failures()})"
            )

    def _verify(
        self, bias: np.ndarray, predicted: TuningResult, model: FittedModel, folder: Path
    ) -> Verification:
        """Step 4 with evidence (:func:`sysid_core.run.verification.verify`)."""

        def sweep(
            freqs: np.ndarray, name: str, band: bool
        ) -> tuple[xr.Dataset, FittedModel, WindowAssessment]:
            return self._sweep(bias, freqs, folder / name, band)

        modes = model.modal(bias[self.space.index])
        if not self.lean:
            return verify(modes, predicted, self.plan, sweep, self.say)
        with np.errstate(divide="ignore", invalid="ignore"):
            bw = np.asarray(modes.frequencies_hz) / np.asarray(modes.q)
        if not np.all(np.isfinite(bw) & (bw > 0)):
            bw = np.full(2, self.plan.verify_resolution_hz)
        sigma = predicted_uncertainty(predicted)

        def window(center: float, split: float, around_prediction: bool) -> np.ndarray:
            guess = ModeGuess.of(
                [center - split / 2, center + split / 2],
                bw,
                sigma if around_prediction else 0.0,
            )
            return mode_grid(guess, self.plan)

        return verify(modes, predicted, self.locate_plan, sweep, self.say, lean=window)

    def _best_effort(
        self, exc: UnreachableTuningError, model: FittedModel, space: BiasSpace, it: int
    ) -> TuningResult:
        """Continue from the best reachable bias, or re-raise ``exc`` if that cannot help.

        A model identified around the current bias extrapolates to a far bias, so its verdict
        "unreachable" may be wrong there (measured: the cloverleaf's 4435 Hz target, B1 near
        9.2 V, 0.02-0.4 Hz "short" after the first iteration for some noise draws). If
        iterations remain and the best reachable bias lies more than ``bias_step`` from the
        current one, the run moves there (it is inside the limits) and identifies a model
        around it; the verdict of a model identified there, or of the last iteration, stands.
        """
        best = exc.best_bias
        step = self.config.experiment.bias_step
        if (
            best is None
            or it >= self.config.tuning.max_iterations
            or float(np.max(np.abs(np.asarray(best, dtype=float) - space.start_bias))) <= step
        ):
            raise exc
        bias = check_bias(self.device.device, best)
        w = (space.structure_potential - bias[space.index]) ** 2
        f = frequencies_from_w(model, w)
        self.say(
            f"iteration {it}: {exc} -- the model was identified more than {step} V away; "
            "continuing from that bias"
        )
        return TuningResult(
            bias=bias,
            w=w,
            frequencies_hz=f,
            split_hz=float(f[1] - f[0]),
            criterion=self.criterion.name,
            value=float(exc.best_value) if exc.best_value is not None else float("nan"),
            info={"unreachable": str(exc)},
        )

    def _apply_best_code(self, model: FittedModel, result: TuningResult, space: BiasSpace) -> None:
        """Move the answer to the DAC code the model predicts best (:mod:`sysid_core.run.dac`)."""
        code = best_code(model, result, space, self.device)
        if code is None or np.array_equal(code, result.bias):
            return
        rounded = applied_bias(self.device.device, np.asarray(result.bias, dtype=float))
        w = (space.structure_potential - code[space.index]) ** 2
        f = frequencies_from_w(model, w)
        before = (
            None
            if rounded is None
            else frequencies_from_w(model, (space.structure_potential - rounded[space.index]) ** 2)
        )
        result.info["dac_code"] = {
            "answer": [float(b) for b in result.bias],
            "predicted_split_hz_rounded": None if before is None else float(before[1] - before[0]),
            "predicted_split_hz_chosen": float(f[1] - f[0]),
        }
        result.bias, result.w = code, w
        result.frequencies_hz, result.split_hz = f, float(f[1] - f[0])

    # ------------------------------------------------------------------ the loop
    def run(self) -> RunSummary:
        """Run (or resume) the loop; returns the summary (also written to ``summary.json``).

        Raises
        ------
        RunLockedError
            If another process works in the same folder.
        """
        self.folder.acquire(self.resume, self.config.model_dump(mode="json"))
        try:
            summary = self._loop()
        except BaseException:  # a failure or Ctrl-C: the bench is made safe, the error stands
            self._close_device(failing=True)
            raise
        finally:
            self.folder.release()
        self._close_device(failing=False)
        return summary

    def _close_device(self, failing: bool) -> None:
        """Call the device's optional ``close()`` when the run ends (made safe, released).

        Only a device the run built from the configuration is closed (one passed in as
        ``device`` belongs to the caller). When the run is failing anyway, a failed close is
        a progress note and the run's own error is what is raised; when the run succeeded, a
        failed close is a :class:`~sysid_core.errors.DeviceError`: the bench may not be safe.
        """
        close = getattr(self.device.device, "close", None)
        if not self.owns_device or not callable(close):
            return
        try:
            close()
        except Exception as exc:
            message = (
                f"device {self.config.device.name!r} could not be closed (made safe): "
                f"{type(exc).__name__}: {exc}"
            )
            if failing:
                self.say(f"note: {message}")
                return
            raise DeviceError(message) from exc

    def _loop(self) -> RunSummary:
        cfg = self.config.tuning
        bias = np.array(self.space.start_bias, dtype=float)
        history: list[IterationRecord] = []
        path = [bias.tolist()]
        summary = RunSummary(
            device=self.config.device.name,
            bias=bias.tolist(),
            split_hz=None,
            frequency_hz=None,
            iterations=0,
            experiments=0,
            converged=False,
            verified=False,
            status="not started",
            goals=[],
            electrodes=self.electrodes,
            tuned=list(self.space.tuned),
            out=str(self.out),
        )
        center: float | None = None
        split = 0.0
        regions: list[ConfidenceRegion | None] = []
        for it in range(1, cfg.max_iterations + 1):
            folder = self.out / f"iter{it:02d}"
            t0 = time.perf_counter()
            space = BiasSpace(
                self.electrodes,
                self.space.tuned,
                bias,
                self.space.limits,
                self.space.structure_potential,
            )
            ds, model = self._identify(it, bias, folder, center, split)
            fit_time = time.perf_counter() - t0
            local = model
            try:
                result, local = solve_criterion(self.criterion, model, space)
            except UnreachableTuningError as exc:
                result = self._best_effort(exc, model, space, it)
            self.moved = "unreachable" in result.info
            answer = dataclasses.replace(result)  # the criterion's, before the DAC code
            self._apply_best_code(model, result, space)
            new_bias = check_bias(self.device.device, result.bias)
            # the region is about the answer (where the truth is); its split range is at the
            # voltages that will really be applied
            result.confidence = confidence_region(
                local.linearized(answer.w),
                answer,
                space,
                applied_bias=applied_bias(self.device.device, new_bias),
            )
            regions.append(result.confidence)
            write_json(folder / "tuning.json", result.as_dict())
            sure = (
                ""
                if result.confidence is None
                else f"; {result.confidence.describe(self.space.index)}"
            )
            self.say(
                f"iteration {it}: {self.criterion.name} bias "
                f"[{', '.join(f'{b:.4f}' for b in new_bias)}] V, predicted modes "
                f"{result.frequencies_hz[0]:.3f} / {result.frequencies_hz[1]:.3f} Hz{sure}"
            )
            ver = self._verify(new_bias, result, model, folder)
            ver.model.save(folder / "verify-model.nc")
            goals: list[Goal] = (
                self.criterion.goals(ver.frequencies_hz, cfg.acceptance_hz)
                if ver.verified and ver.frequencies_hz is not None
                else []
            )
            converged = ver.verified and all(g.met for g in goals)
            if self.plots:
                plot_iteration(
                    it,
                    ds,
                    model,
                    ver,
                    new_bias[self.space.index],
                    folder,
                    self.plot_format,
                    result.confidence,
                )
            bias = new_bias
            path.append(bias.tolist())
            history.append(
                IterationRecord(
                    iteration=it,
                    experiments=ds["bias"].values.tolist(),
                    tuning=result.as_dict(),
                    verified_bias=bias.tolist(),
                    verification=ver.status,
                    measured_split_hz=ver.split_hz,
                    measured_frequency_hz=ver.frequency_hz,
                    measured_frequencies_hz=None
                    if ver.frequencies_hz is None
                    else [float(x) for x in ver.frequencies_hz],
                    goals=[g.as_dict() for g in goals],
                    evidence=[w.as_dict() for w in ver.windows],
                    gamma=model.gamma,
                    fit_time_s=float(model.meta["fit_time_s"]),
                    points=self.points,
                )
            )
            summary.bias = bias.tolist()
            summary.split_hz, summary.frequency_hz = ver.split_hz, ver.frequency_hz
            summary.iterations, summary.experiments = it, self.measurements
            summary.points = self.points
            summary.dwell_s, summary.dwell_source = dwell(
                self.device.device, cfg_dwell=self.config.experiment.dwell_s, model=model
            )
            summary.bench_time_s = (
                None if summary.dwell_s is None else self.points * summary.dwell_s
            )
            summary.converged, summary.verified = converged, ver.verified
            summary.goals = [g.as_dict() for g in goals]
            summary.confidence = None if result.confidence is None else result.confidence.as_dict()
            summary.status = status_line(it, ver, goals, converged)
            summary.history = history
            summary.notes = list(self.notes)
            write_json(self.out / "summary.json", summary.as_dict())
            self.say(f"iteration {it}: {ver.describe()} ({fit_time:.2f} s to identify)")
            if self.plots:
                plot_bias_path(
                    path,
                    [h.measured_split_hz for h in history],
                    self.electrodes,
                    self.out / f"bias_path.{self.plot_format}",
                    self.space.limits,
                    acceptance_hz=cfg.acceptance_hz,
                    regions=regions,
                )
            if converged:
                break
            # The next identification starts from what was measured: around the modes if
            # they were found, over the whole band if not.
            if ver.verified and ver.frequencies_hz is not None:
                self.last_verified = (bias.copy(), np.asarray(ver.frequencies_hz, dtype=float))
                self.last_region = result.confidence
            if ver.frequencies_hz is not None:
                center, split = ver.frequency_hz, float(ver.split_hz or 0.0)
            else:
                center, split = None, 0.0
        return summary
