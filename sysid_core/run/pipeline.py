"""The tuning loop of the paper (Section II-D, steps 1-4): identify, tune, verify, repeat.

1. Measure and fit (:mod:`sysid_core.run.protocols`): the experiments of eq. (18) around the
   current bias, checked against the rank condition (6), measured where the protocol says
   (the paper's full sweeps, or the lean protocol's points where the modes are, on a pair of the
   electrodes or all, :mod:`sysid_core.measure.pairing`), and one bias-dependent model fitted.
2. Answer (:mod:`sysid_core.verdict.answer`): the criterion's bias, the DAC code the model predicts
   best, and its confidence region, where the run's measurements support it
   (:mod:`sysid_core.verdict.trust`). A goal unreachable inside the limits ends the run where a
   model identified there says so (:class:`~sysid_core.errors.UnreachableTuningError`).
3. Verify at the new bias (:mod:`sysid_core.measure.verification`): a split counts as measured only
   when the evidence says both modes are in a window that resolves them.
4. Report (:mod:`sysid_core.run.summary`): the iteration's record, ``summary.json`` and plots.

The run converges when a verification is *verified* and every goal of the criterion is met (the
split under ``acceptance_hz``; for ``target``, also the frequency error). Otherwise it goes on until
a verdict stops it (:mod:`sysid_core.verdict.judgement`), the budget (``[tuning]
max_bench_minutes``, :mod:`sysid_core.clock.budget`) is spent or ``max_iterations`` reached.

Everything is checked before the first measurement: the configuration, every plugin (built
here), the device's protocol attributes, the bias limits, the sweeps and the first design. Every
measurement is checked (:mod:`sysid_core.device.measuring`) and written to the run folder
(:mod:`sysid_core.clock.runfolder`) before anything else is done with it (:class:`Bench`). A
stopped run continues with ``resume=True``: every measurement on disk is read, not measured again.
"""

from __future__ import annotations

import itertools
import time
from pathlib import Path

import numpy as np
import xarray as xr

from sysid_core.clock.bench import Bench
from sysid_core.clock.benchtime import tones
from sysid_core.clock.budget import Budget, minutes
from sysid_core.clock.runclock import RunClock
from sysid_core.clock.runfolder import RunFolder
from sysid_core.data.io import write_json
from sysid_core.device.measuring import GuardedDevice, check_bias
from sysid_core.device.protocol import Device, ReportsProgress
from sysid_core.drift.tracker import Tracker
from sysid_core.errors import BudgetSpentError, ConfigError
from sysid_core.identification.objective import Progress
from sysid_core.measure.fitter import Fitter
from sysid_core.measure.previous import check_prior
from sysid_core.measure.verification import Verification
from sysid_core.model.fitted import FittedModel
from sysid_core.plugin.registry import Registry, get_registry
from sysid_core.run.components import build_components
from sysid_core.run.config import PipelineConfig
from sysid_core.run.plots import PLOT_FORMATS, plot_bias_path, plot_iteration
from sysid_core.run.protocols import RunContext, make_protocol
from sysid_core.run.record import IterationRecord, Seen, failed_in_a_row, seen_so_far
from sysid_core.run.summary import RunSummary, summarize
from sysid_core.run.timeline import plot_timeline
from sysid_core.tuning.criteria import BiasSpace, ConfidenceRegion
from sysid_core.verdict.answer import Answer, answer
from sysid_core.verdict.judgement import verdict

__all__ = ["TuningRun"]


class TuningRun:
    """One run of the tuning loop, writing everything into ``out``.

    Building the run checks, without measuring or writing anything: the configuration's
    plugins (created), the device's protocol attributes, the start bias, the sweeps, the first
    design, and ``out`` (empty for a new run; holding this run for ``resume``).

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
        ``png`` (default), ``pdf`` or ``svg``.
    from_model : FittedModel, optional
        A previous model of the same gyro (``--from-model``): no locating sweep and no design
        while its answers, anchored on the latest sweeps, bring the split down.
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
        from_model: FittedModel | None = None,
    ) -> None:
        self.config = config
        self.out = Path(out)
        self.resume = resume
        self.say = progress or (lambda _m: None)
        self.plots = plots
        if plot_format not in PLOT_FORMATS:
            raise ConfigError(
                f"plot format {plot_format!r} is not one of {', '.join(PLOT_FORMATS)}"
            )
        self.plot_format = plot_format
        # Every component is built now, so that a bad option fails before any measurement.
        parts = build_components(config, registry or get_registry(), device)
        self.structure, self.objective = parts.structure, parts.objective
        self.solver, self.criterion = parts.solver, parts.criterion
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
        folder = RunFolder(self.out, config.digest())
        guarded = GuardedDevice(dev, config.device.name, config.experiment.timeout_s)
        #: Frequencies per acquisition: the device's, else the configuration's, else 1.
        acquisition_tones = tones(guarded.capabilities, config.experiment.tones)
        self.bench = Bench(
            guarded,
            folder,
            self.electrodes,
            self.space.structure_potential,
            config.device.name,
            self.say,
            owns_device=device is None,
            tones=acquisition_tones,
            guard=lambda n, changes: self.clock.guard(n, changes),
        )
        #: The bench clock: what the measurements cost, what the run spent and may spend.
        self.clock = RunClock(
            self.bench,
            (config.experiment.dwell_s, config.experiment.settle_s),
            Budget(config.tuning.max_bench_minutes, config.tuning.max_iterations),
        )
        self.fitter = Fitter(
            self.structure,
            self.objective,
            self.solver,
            parts.twin,
            tracked=config.model.policy.may_track,
        )
        #: The verified windows and the model moved ahead (``drift = "track"`` or ``"auto"``).
        self.tracker = Tracker.of(
            config.model.policy, config.tuning.acceptance_hz, settling=self.clock.settle_s
        )
        plan = config.experiment.sweep_plan(dev.band_hz, tones=acquisition_tones)
        context = RunContext(
            config,
            self.space,
            plan,
            self.bench,
            self.fitter,
            self.say,
            afford=self.clock.left,
            cost_s=self.clock.sweep_s,
        )
        context.design(self.space.start_bias)  # the first design: limits and rank condition
        if from_model is not None:
            check_prior(from_model, self.space.tuned)
        self.protocol = make_protocol(context, from_model)
        folder.check(resume)
        self.notes: list[str] = []
        #: The common drift the fits found and the split's the tracking found (Hz per hour).
        self.drift_hz_per_h: float | None = None
        self.drift_split_hz_per_h: float | None = None

    @property
    def device(self) -> GuardedDevice:
        """The run's device, with the core's checks around it (``.device`` is the plugin's)."""
        return self.bench.device

    @property
    def measurements(self) -> int:
        """Measurements made (or read, on resume) so far."""
        return self.bench.measurements

    def run(self) -> RunSummary:
        """Run (or resume) the loop; returns the summary (also written to ``summary.json``).

        Raises
        ------
        RunLockedError
            If another process works in the same folder.
        """
        self.bench.folder.acquire(self.resume, self.config.model_dump(mode="json"))
        try:
            summary = self._loop()
        except BaseException:  # a failure or Ctrl-C: the bench is made safe, the error stands
            self.bench.close(failing=True)
            raise
        finally:
            self.bench.folder.release()
        self.bench.close(failing=False)
        return summary

    def _loop(self) -> RunSummary:
        cfg = self.config.tuning
        bias = np.array(self.space.start_bias, dtype=float)
        summary = RunSummary.start(self.config.device.name, bias, self.space, str(self.out))
        history: list[IterationRecord] = []
        path, regions, split, seen = [bias.tolist()], [], 0.0, set[tuple[float, ...]]()
        center: float | None = None
        # up to [tuning] max_iterations, or its default (which may change once the clock shows)
        for it in itertools.takewhile(lambda k: k <= self.clock.cap, itertools.count(1)):
            folder = self.out / f"iter{it:02d}"
            try:
                t0 = time.perf_counter()
                ds, model = self._identify(it, bias, folder, center, split)
                fit_time = time.perf_counter() - t0
                now = self._track(it, model, ds) if self.tracking else model
                step = self._answer(it, now, bias, folder, seen_so_far(history))
                # the fit of every sweep, if the local one fell short
                now = step.model if step.model is not None else now
                ver = self.protocol.verify(step.bias, step.result, now, folder)
            except BudgetSpentError as exc:
                return self._budget_spent(it, exc, summary)
            regions.append(step.result.confidence)
            ver.model.save(folder / "verify-model.nc")
            if self.tracking and self.tracker is not None:
                self.tracker.learned(ver)
            goals, converged, stop = verdict(
                *(ver, now, self.criterion, self.fitter, cfg.acceptance_hz, cfg.aim, self.tracker),
                self.clock.afford(int(ver.sweep.sizes["frequency"])),
                failed_in_a_row(history),
                (history[-1].verified_bias if history else None, step.bias, step.result.info),
            )
            if stop is not None:
                self.notes.append(f"iteration {it}: {stop}")
            bias = step.bias
            path.append(bias.tolist())
            spent = self.clock.spent_s()
            self.clock.budget.ended(spent)
            counts = (self.bench.points, spent)
            record = IterationRecord.of(it, ds, model, step.result, bias, ver, goals, counts, seen)
            history.append(record)
            summary = summarize(
                *(summary, history, ver, goals, converged),
                bench=self.bench,
                rates=self.clock.rates(model),
                confidence=step.result.confidence,
                notes=self.notes,
                drift=(self.drift_hz_per_h, self.drift_split_hz_per_h),
                budget_s=self.clock.limit_s,
                tuned=self.space.tuned,
            )
            if stop is not None:  # a verdict's reason to stop, like the budget's
                summary = summary.stopped_by(stop, self.notes, spent, self.bench)
            summary.save(self.out / "summary.json")
            self.say(f"iteration {it}: {ver.describe()} ({fit_time:.2f} s to identify)")
            self.say(f"iteration {it}: {self.clock.describe(spent)}")
            self._plot(it, ds, model, ver, step, folder, path, history, regions)
            if stop is not None:
                self.say(f"iteration {it}: {stop}")
            if converged or stop is not None:
                break
            self.protocol.learned(step.moved, bias, ver, step.result.info)
            # the next identification: around the modes if they were found, else the band
            found = ver.frequencies_hz is not None
            center, split = (ver.frequency_hz, float(ver.split_hz or 0.0)) if found else (None, 0.0)
        return summary

    def _budget_spent(self, it: int, exc: BudgetSpentError, summary: RunSummary) -> RunSummary:
        """End at iteration ``it`` with the last verified answer (re-raise ``exc`` if none)."""
        if not summary.iterations:
            raise BudgetSpentError(
                f"{exc}, before a first answer was verified; raise [tuning] max_bench_minutes "
                "or measure fewer points (docs/bench-time.md)"
            ) from None
        self.notes.append(f"iteration {it}: stopped: {exc}; the run ends at its last answer")
        self.say(self.notes[-1])
        why = f"the bench-time budget of {minutes(self.clock.limit_s)} min is spent"
        ended = summary.stopped_by(why, self.notes, self.clock.spent_s(), self.bench)
        ended.save(self.out / "summary.json")
        return ended

    # ------------------------------------------------------------------ steps
    def _identify(
        self, it: int, bias: np.ndarray, folder: Path, center_hz: float | None, split_hz: float
    ) -> tuple[xr.Dataset, FittedModel]:
        """Steps 1-2: the protocol's data, its model (saved) and the fit's notes (kept)."""
        ds, prefit = self.protocol.data(it, bias, folder, center_hz, split_hz)
        self.space = self.protocol.ctx.space  # the protocol may tune a pair of the electrodes
        model, notes = prefit[1:] if prefit is not None else self.fitter.fit(ds)
        for note in notes:  # notes of this run, not user warnings
            self.notes.append(f"iteration {it}: {note}")
            self.say(f"iteration {it}: note: {note}")
        for line in self.fitter.found(model):
            self.say(f"iteration {it}: {line}")
        model.save(folder / "model.nc")
        self.clock.saw(model)
        return ds, model

    @property
    def tracking(self) -> bool:
        """``drift = "track"``, or ``"auto"`` once every measurement carried time stamps."""
        clock = self.bench.clock_span_s is not None
        return self.tracker is not None and self.config.model.policy.tracking(clock)

    def _track(self, it: int, model: FittedModel, ds: xr.Dataset) -> FittedModel:
        """The model moved to the next verification's time (:attr:`tracking`)."""
        assert self.tracker is not None
        self.tracker.refresh(ds, self.protocol.sweep, self.out / f"iter{it:02d}", self.say, it)
        now = self.tracker.now(model, ds, self.say, it)
        if (seen := self.tracker.rates) is not None:
            self.drift_hz_per_h = seen.common_hz_per_h if self.tracker.common_measured else None
            self.drift_split_hz_per_h = seen.split_hz_per_h
        if now is not model:
            now.save(self.out / f"iter{it:02d}" / "model-now.nc")
        return now

    def _answer(
        self, it: int, model: FittedModel, bias: np.ndarray, folder: Path, seen: Seen
    ) -> Answer:
        """Step 3 at ``bias``, told what the run verified so far (``seen``)."""
        sp = self.space
        space = BiasSpace(self.electrodes, sp.tuned, bias, sp.limits, sp.structure_potential)

        def every_sweep() -> FittedModel | None:
            ds = self.protocol.every_sweep(it, bias)
            return None if ds is None else self.fitter.fit(ds)[0]

        step = answer(
            self.criterion,
            model,
            space,
            self.bench.device,
            it,
            bias_step=self.config.experiment.bias_step,
            local_step=self.config.experiment.refine_bias_step or self.config.experiment.bias_step,
            last_iteration=self.clock.left() < 2,
            say=self.say,
            every_sweep=every_sweep,
            acceptance_hz=self.config.tuning.acceptance_hz,
            **seen,
            local_fit=self.protocol.local,
            reoffer=self.protocol.offered is not None,
        )
        result = step.result
        write_json(folder / "tuning.json", result.as_dict())
        sure = "" if result.confidence is None else f"; {result.confidence.describe(space.index)}"
        self.say(
            f"iteration {it}: {self.criterion.name} bias "
            f"[{', '.join(f'{b:.4f}' for b in step.bias)}] V, predicted modes "
            f"{result.frequencies_hz[0]:.3f} / {result.frequencies_hz[1]:.3f} Hz{sure}"
        )
        return step

    def _plot(
        self,
        it: int,
        ds: xr.Dataset,
        model: FittedModel,
        ver: Verification,
        step: Answer,
        folder: Path,
        path: list[list[float]],
        history: list[IterationRecord],
        regions: list[ConfidenceRegion | None],
    ) -> None:
        """The iteration's plots and the run's bias path, unless plots are off."""
        if not self.plots:
            return
        index = self.space.index
        plot_iteration(
            it, ds, model, ver, step.bias[index], folder, self.plot_format, step.result.confidence
        )
        plot_bias_path(
            path,
            [h.measured_split_hz for h in history],
            self.electrodes,
            self.out / f"bias_path.{self.plot_format}",
            self.space.limits,
            acceptance_hz=self.config.tuning.acceptance_hz,
            regions=regions,
        )
        if self.bench.clock_span_s is not None:  # a bench with a clock: the split in time
            limits = (self.config.tuning.acceptance_hz, self.clock.limit_s)
            plot_timeline(history, self.out / f"drift.{self.plot_format}", *limits)
