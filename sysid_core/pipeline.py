"""The tuning loop of the paper (Section II-D, steps 1-4), with safe measuring and resume.

1. Design ``n_t + 1`` experiments around the current bias (eq. 18: one electrode stepped at a
   time, stepping down where up would leave the limits); check the rank condition (6) first.
   The first iteration sweeps the whole band; later ones a narrower span around the last
   measured modal frequency (``refine_span_hz``, see :class:`~sysid_core.config.ExperimentConfig`).
2. Fit one bias-dependent model to them.
3. Apply the tuning criterion. If it finds the goal unreachable inside the limits, the run
   ends with :class:`~sysid_core.errors.UnreachableTuningError`, unless iterations remain and
   the best reachable bias is more than ``bias_step`` away (the model extrapolated): then the
   run continues from that bias and a model identified around it decides.
4. Verify with a dense sweep around the predicted frequency (10 mHz over ±0.5 Hz by default,
   widened when the modes fall outside) and a single-bias fit of it: the measured split.

Repeat from the new bias until the split is under ``acceptance_hz`` or ``max_iterations``.

Every measurement is written to the output directory (netCDF, atomically) as soon as it
arrives, before anything else is done with it. A run that stops (device error, timeout,
interrupt) can be continued with ``resume=True``: the loop is replayed, and every measurement
already on disk is read instead of measured again.
"""

from __future__ import annotations

import concurrent.futures
import json
import math
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
import xarray as xr

from sysid_core.config import PipelineConfig
from sysid_core.data import (
    check_rank_condition,
    concat_experiments,
    experiment_from_measurement,
    load_dataset,
    save_dataset,
)
from sysid_core.errors import (
    BiasLimitError,
    ConfigError,
    DeviceError,
    SysidError,
    UnreachableTuningError,
)
from sysid_core.fit import fit
from sysid_core.interfaces import Device
from sysid_core.io import write_json
from sysid_core.model import FittedModel
from sysid_core.registry import Registry, get_registry
from sysid_core.tuning import BiasSpace, TuningResult, frequencies_from_w

__all__ = ["RunSummary", "TuningRun", "check_bias", "design_experiments", "measure_safely"]

Progress = Callable[[str], None]


def check_bias(device: Device, bias: Sequence[float]) -> np.ndarray:
    """The core's safety check: ``bias`` has one finite value per electrode, inside the limits.

    Raises
    ------
    BiasLimitError
        Before anything is applied to the device.
    """
    b = np.asarray(bias, dtype=float)
    n_e = len(device.electrodes)
    if b.shape != (n_e,):
        raise BiasLimitError(f"bias has {b.size} value(s); the device has {n_e} electrodes")
    low, high = device.bias_limits
    bad = [p for p in range(n_e) if not (np.isfinite(b[p]) and low <= b[p] <= high)]
    if bad:
        p = bad[0]
        raise BiasLimitError(
            f"refusing to apply {b[p]} V to electrode {device.electrodes[p]}: outside the "
            f"device's limits [{low}, {high}] V"
        )
    return b


def measure_safely(
    device: Device,
    bias: Sequence[float],
    frequencies_hz: np.ndarray,
    timeout_s: float | None = None,
) -> xr.DataArray:
    """Check ``bias``, measure, and check the answer; device failures become DeviceError."""
    b = check_bias(device, bias)
    f = np.asarray(frequencies_hz, dtype=float)
    try:
        if timeout_s is None:
            result = device.measure(b.tolist(), f)
        else:
            pool = concurrent.futures.ThreadPoolExecutor(max_workers=1)
            try:
                result = pool.submit(device.measure, b.tolist(), f).result(timeout=timeout_s)
            finally:
                pool.shutdown(wait=False, cancel_futures=True)
    except concurrent.futures.TimeoutError:
        raise DeviceError(
            f"the device did not answer within {timeout_s} s (measuring at {b.tolist()} V)"
        ) from None
    except SysidError:
        raise
    except Exception as exc:
        raise DeviceError(
            f"the device failed while measuring at {b.tolist()} V: {type(exc).__name__}: {exc}"
        ) from exc
    if not isinstance(result, xr.DataArray) or tuple(result.dims) != (
        "frequency",
        "output",
        "input",
    ):
        raise DeviceError(
            "the device returned something other than a DataArray with dims "
            "('frequency', 'output', 'input')"
        )
    if result.sizes["frequency"] != f.size or not np.all(np.isfinite(result.values)):
        raise DeviceError("the device returned a wrong-sized or non-finite measurement")
    return result


def design_experiments(
    start: np.ndarray, tuned_index: Sequence[int], step: float, limits: tuple[float, float]
) -> np.ndarray:
    """Eq. (18): the start bias and one electrode stepped at a time (down if up would leave)."""
    low, high = limits
    design = [np.array(start, dtype=float)]
    for p in tuned_index:
        b = np.array(start, dtype=float)
        if b[p] + step <= high:
            b[p] += step
        elif b[p] - step >= low:
            b[p] -= step
        else:
            raise ConfigError(f"bias_step {step} V does not fit inside the limits {limits}")
        design.append(b)
    return np.array(design)


@dataclass
class IterationRecord:
    """What one iteration did."""

    iteration: int
    experiments: list[list[float]]
    tuning: dict[str, Any]
    verified_bias: list[float]
    measured_split_hz: float
    measured_frequency_hz: float
    gamma: float
    fit_time_s: float


@dataclass
class RunSummary:
    """The result of a tuning run (what ``summary.json`` and ``--json`` report)."""

    device: str
    bias: list[float]
    split_hz: float
    frequency_hz: float
    iterations: int
    experiments: int
    converged: bool
    electrodes: list[str]
    tuned: list[str]
    history: list[IterationRecord] = field(default_factory=list)
    out: str = ""

    def as_dict(self) -> dict[str, Any]:
        """JSON-friendly form."""
        return {
            "device": self.device,
            "bias": self.bias,
            "split_hz": self.split_hz,
            "frequency_hz": self.frequency_hz,
            "iterations": self.iterations,
            "experiments": self.experiments,
            "converged": self.converged,
            "electrodes": self.electrodes,
            "tuned": self.tuned,
            "out": self.out,
            "history": [r.__dict__ for r in self.history],
        }


class TuningRun:
    """One run of the tuning loop, writing everything into ``out``.

    Parameters
    ----------
    config : PipelineConfig
        Validated configuration.
    out : path
        Output directory. Must be empty (or absent) unless ``resume``.
    resume : bool
        Continue a run in ``out``: measurements on disk are read, not measured again.
    progress : callable, optional
        Receives one-line progress messages.
    device : Device, optional
        Use this device object instead of creating ``config.device`` from the registry.
    plots : bool
        Write the PNG report (default true).
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
    ) -> None:
        self.config = config
        self.out = Path(out)
        self.resume = resume
        self.say = progress or (lambda _m: None)
        self.registry = registry or get_registry()
        self.plots = plots
        self.device = (
            device
            if device is not None
            else self.registry.create("device", config.device.name, **config.device.options)
        )
        if not isinstance(self.device, Device):
            raise ConfigError(
                f"device {config.device.name!r} does not follow the Device protocol "
                "(electrodes, bias_limits, structure_potential, band_hz, measure)"
            )
        self.electrodes = [str(e) for e in self.device.electrodes]
        tuned = config.tuning.electrodes or self.electrodes
        start = config.tuning.start_bias
        if start is None:
            start = [0.0] * len(self.electrodes)
        self.space = BiasSpace(
            electrodes=self.electrodes,
            tuned=list(tuned),
            start_bias=np.asarray(start, dtype=float),
            limits=tuple(float(x) for x in self.device.bias_limits),  # type: ignore[arg-type]
            structure_potential=float(self.device.structure_potential),
        )
        check_bias(self.device, self.space.start_bias)
        crit_opts: dict[str, Any] = {"solver": config.solver.name}
        if config.tuning.target_hz is not None:
            crit_opts["target_hz"] = config.tuning.target_hz
        if config.tuning.tolerance_hz is not None:
            crit_opts["tolerance_hz"] = config.tuning.tolerance_hz
        self.criterion = self.registry.create(
            "tuning criterion", config.tuning.criterion, **crit_opts
        )
        # The model, objective and solver settings are used only at the first fit: check them
        # now, before anything is measured.
        m = config.model
        self.registry.create("model structure", m.structure, order=m.order)
        self.registry.create("objective", m.objective, **m.objective_options)
        self.registry.create("solver", config.solver.name, **config.solver.options)
        self.measurements = 0

    # ------------------------------------------------------------------ bookkeeping
    def _prepare_out(self) -> None:
        cfg_path = self.out / "config.json"
        if self.out.exists() and any(self.out.iterdir()):
            if not self.resume:
                raise ConfigError(
                    f"{self.out} already holds a run; pass --resume to continue it or choose "
                    "another --out"
                )
            if cfg_path.exists():
                old = json.loads(cfg_path.read_text()).get("digest")
                if old != self.config.digest():
                    raise ConfigError(
                        f"{self.out} holds a run with a different configuration; resume it with "
                        "the same configuration file or choose another --out"
                    )
        self.out.mkdir(parents=True, exist_ok=True)
        write_json(
            cfg_path,
            {"digest": self.config.digest(), "config": self.config.model_dump(mode="json")},
        )

    def _measure(self, bias: np.ndarray, freqs: np.ndarray, path: Path) -> xr.Dataset:
        """Read ``path`` if it holds this measurement (resume), else measure and save it first."""
        if path.exists():
            ds = load_dataset(path)
            same_grid = ds.sizes["frequency"] == freqs.size and np.allclose(
                ds["frequency"].values, freqs, rtol=0, atol=1e-9
            )
            if same_grid and np.allclose(ds["bias"].values[0], bias, rtol=0, atol=1e-12):
                self.say(f"read {path.name} (measured earlier)")
                self.measurements += 1
                return ds
            raise ConfigError(
                f"{path} holds a measurement at another bias or grid than this run needs; "
                "the run cannot be resumed"
            )
        self.say(
            f"measuring at [{', '.join(f'{b:.4f}' for b in bias)}] V, "
            f"{freqs[0]:.3f}-{freqs[-1]:.3f} Hz, {freqs.size} points"
        )
        da = measure_safely(self.device, bias, freqs, self.config.experiment.timeout_s)
        ds = experiment_from_measurement(
            da,
            bias,
            self.electrodes,
            self.space.structure_potential,
            device=self.config.device.name,
        )
        save_dataset(ds, path)  # saved before it is processed
        self.measurements += 1
        return ds

    def _fit(self, ds: xr.Dataset) -> FittedModel:
        m = self.config.model
        return fit(
            ds,
            m.structure,
            m.order,
            m.objective,
            self.config.solver.name,
            objective_options=m.objective_options,
            solver_options=self.config.solver.options,
        )

    def _band(self, center_hz: float | None = None, split_hz: float = 0.0) -> np.ndarray:
        exp = self.config.experiment
        lo, hi = exp.band_hz or self.device.band_hz
        res = exp.resolution_hz
        if center_hz is not None and exp.refine_span_hz > 0:
            # wide enough for both measured modes, with a margin, even if they are far apart
            half = max(exp.refine_span_hz / 2, 1.5 * split_hz)
            lo, hi = max(lo, center_hz - half), min(hi, center_hz + half)
            res = exp.refine_resolution_hz
        n = math.floor((hi - lo) / res + 1e-9) + 1
        return lo + res * np.arange(n)

    # ------------------------------------------------------------------ steps
    def _identify(
        self,
        it: int,
        bias: np.ndarray,
        folder: Path,
        center_hz: float | None,
        split_hz: float = 0.0,
    ) -> tuple[xr.Dataset, FittedModel]:
        design = design_experiments(
            bias, self.space.index, self.config.experiment.bias_step, self.space.limits
        )
        check_rank_condition(
            design[:, self.space.index], self.space.structure_potential, self.space.tuned
        )
        freqs = self._band(center_hz, split_hz)
        parts = [self._measure(b, freqs, folder / f"exp{j}.nc") for j, b in enumerate(design)]
        ds = concat_experiments(parts).sel(electrode=self.space.tuned)
        held = {
            e: float(bias[i]) for i, e in enumerate(self.electrodes) if e not in self.space.tuned
        }
        ds.attrs["held_bias"] = json.dumps(held)
        self.say(
            f"iteration {it}: fitting {self.config.model.structure} model to "
            f"{len(design)} experiments"
        )
        model = self._fit(ds)
        model.save(folder / "model.nc")
        return ds, model

    def _verify(
        self, bias: np.ndarray, center_hz: float, folder: Path
    ) -> tuple[xr.Dataset, FittedModel]:
        exp = self.config.experiment
        span, res = exp.verify_span_hz, exp.verify_resolution_hz
        band_lo, band_hi = self.config.experiment.band_hz or self.device.band_hz
        for attempt in range(4):
            lo, hi = max(center_hz - span / 2, band_lo), min(center_hz + span / 2, band_hi)
            n = max(round((hi - lo) / res) + 1, 21)
            freqs = np.linspace(lo, hi, n)
            name = "verify.nc" if attempt == 0 else f"verify-{attempt + 1}.nc"
            sweep = self._measure(bias, freqs, folder / name)
            vmodel = self._fit(sweep.isel(electrode=[]))
            f_modes = vmodel.modal([]).frequencies_hz
            margin = 0.1 * (hi - lo)
            inside = f_modes.min() > lo + margin and f_modes.max() < hi - margin
            if inside or (lo <= band_lo and hi >= band_hi):
                return sweep, vmodel
            # The modes are not both well inside the sweep: widen it around them.
            center_hz = float(f_modes.mean()) if lo < f_modes.mean() < hi else center_hz
            span = max(4 * span, 3 * float(np.ptp(f_modes)))
            res = max(res, span / 400)
            self.say(f"verification: modes near the sweep's edge; widening to {span:.2f} Hz")
        return sweep, vmodel

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
        bias = check_bias(self.device, best)
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

    # ------------------------------------------------------------------ the loop
    def run(self) -> RunSummary:
        """Run (or resume) the loop; returns the summary (also written to ``summary.json``)."""
        self._prepare_out()
        cfg = self.config.tuning
        bias = np.array(self.space.start_bias, dtype=float)
        history: list[IterationRecord] = []
        path = [bias.tolist()]
        summary = RunSummary(
            device=self.config.device.name,
            bias=bias.tolist(),
            split_hz=float("nan"),
            frequency_hz=float("nan"),
            iterations=0,
            experiments=0,
            converged=False,
            electrodes=self.electrodes,
            tuned=list(self.space.tuned),
            out=str(self.out),
        )
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
            center = history[-1].measured_frequency_hz if history else None
            split = history[-1].measured_split_hz if history else 0.0
            ds, model = self._identify(it, bias, folder, center, split)
            fit_time = time.perf_counter() - t0
            try:
                result: TuningResult = self.criterion.solve(model, space)
            except UnreachableTuningError as exc:
                result = self._best_effort(exc, model, space, it)
            new_bias = check_bias(self.device, result.bias)
            write_json(folder / "tuning.json", result.as_dict())
            self.say(
                f"iteration {it}: {self.criterion.name} bias "
                f"[{', '.join(f'{b:.4f}' for b in new_bias)}] V, predicted modes "
                f"{result.frequencies_hz[0]:.3f} / {result.frequencies_hz[1]:.3f} Hz"
            )
            sweep, vmodel = self._verify(new_bias, result.frequency_hz, folder)
            rep = vmodel.modal([])
            vmodel.save(folder / "verify-model.nc")
            if self.plots:
                from sysid_core.report import plot_fit, plot_verification

                plot_fit(
                    ds,
                    model,
                    folder / "fit.png",
                    title=f"iteration {it}: {model.structure.name} model, "
                    f"gamma = {model.gamma:.3g}",
                )
                plot_verification(
                    sweep.isel(electrode=[]),
                    model,
                    new_bias[self.space.index],
                    vmodel,
                    folder / "verify.png",
                )
            bias = new_bias
            path.append(bias.tolist())
            history.append(
                IterationRecord(
                    iteration=it,
                    experiments=ds["bias"].values.tolist(),
                    tuning=result.as_dict(),
                    verified_bias=bias.tolist(),
                    measured_split_hz=rep.split_hz,
                    measured_frequency_hz=float(rep.frequencies_hz.mean()),
                    gamma=model.gamma,
                    fit_time_s=float(model.meta["fit_time_s"]),
                )
            )
            summary.bias, summary.split_hz = bias.tolist(), rep.split_hz
            summary.frequency_hz = float(rep.frequencies_hz.mean())
            summary.iterations, summary.experiments = it, self.measurements
            summary.converged = rep.split_hz < cfg.acceptance_hz
            summary.history = history
            write_json(self.out / "summary.json", summary.as_dict())
            self.say(
                f"iteration {it}: measured split {rep.split_hz * 1e3:.2f} mHz at "
                f"{summary.frequency_hz:.3f} Hz ({fit_time:.2f} s to identify)"
            )
            if self.plots:
                from sysid_core.report import plot_bias_path

                plot_bias_path(
                    [p for p in path],
                    [h.measured_split_hz for h in history],
                    self.electrodes,
                    self.out / "bias_path.png",
                    self.space.limits,
                )
            if summary.converged:
                break
        return summary
