"""Averaging a verification window over repeated passes when its noise hides the split.

A window's single-bias fit says how well it measured the split: the 95 % interval of
:func:`~sysid_core.tuning.confidence.split_interval`. When the interval reaches further above the
measured split than the run can use, the noise hides what the run needs, and measuring the same
frequencies again at the same bias is the cheapest information there is: no bias change, so no
settling, and every pass divides the noise's variance. :func:`passes_needed` says how many passes
bring the interval's reach down to :func:`target_reach_hz` (the reach falls as ``1/√passes``),
within ``max_passes`` and :data:`MAX_REPEAT_S` of bench time; :func:`average_passes` averages the
passes point by point into the sweep the run then fits, as a longer integration per point would.

Why a window: a verification window decides convergence and anchors the next answer (``drift =
"track"``), so its noise sets how close the next answer can land. At 60 dB SNR a 17-point window
on a 28 kHz gyro measured a split of 5.9 mHz with a 95 % interval reaching 5 mHz above it; the
next answer, one millivolt away, left 4.0 mHz. A pass of that window takes 20 s of bench time.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from pathlib import Path

import numpy as np
import xarray as xr

from sysid_core.clock.bench import Bench
from sysid_core.clock.benchtime import dwell
from sysid_core.clock.runclock import stamps_span_s
from sysid_core.errors import DataError
from sysid_core.measure.evidence import WindowAssessment
from sysid_core.measure.fitter import Fitter
from sysid_core.model.fitted import FittedModel
from sysid_core.tuning.confidence import split_interval

__all__ = [
    "MAX_REPEAT_S",
    "RELATIVE_REACH",
    "average_passes",
    "pass_duration_s",
    "passes_needed",
    "repeat_window",
    "target_reach_hz",
]

#: The repeated passes of one window may take at most this much bench time (seconds): a slow
#: gyro's pass takes minutes, in which a drifting bench would blur the average.
MAX_REPEAT_S = 600.0
#: Far from a tuning, the reach only needs to be this fraction of the measured split.
RELATIVE_REACH = 0.25


def target_reach_hz(split_hz: float, acceptance_hz: float) -> float:
    """How far above the measured split its 95 % interval may reach (Hz).

    One acceptance near a tuning: a split under the acceptance is then resolved under twice
    it, the run's own test (:data:`~sysid_core.verdict.judgement.RESOLVE_FACTOR`). Far from one,
    a quarter of the split: the next answer's error is then set by the model's bias law, not by
    the window's noise.
    """
    return max(float(acceptance_hz), RELATIVE_REACH * abs(float(split_hz)))


def pass_duration_s(sweep: xr.Dataset, dwell_s: float | None) -> float | None:
    """One pass's bench time: its time stamps' span plus one acquisition, or None if untimed."""
    span = stamps_span_s(sweep)
    return None if span is None else span + float(dwell_s or 0.0)


def passes_needed(
    model: FittedModel,
    split_hz: float,
    acceptance_hz: float,
    max_passes: int,
    pass_s: float | None = None,
) -> int:
    """Passes of a window (the one measured included) that resolve its split well enough.

    Parameters
    ----------
    model : FittedModel
        The window's single-bias model (its covariance gives the split's interval).
    split_hz : float
        The split the window measured.
    acceptance_hz : float
        The run's acceptance.
    max_passes : int
        At most this many passes (``[experiment] max_passes``; 1 never repeats).
    pass_s : float, optional
        One pass's bench time; the repeats then stay within :data:`MAX_REPEAT_S`.

    Returns
    -------
    int
        ``ceil((reach / target)²)``, bounded: 1 when the interval already reaches no further
        than :func:`target_reach_hz`, or when the fit has no covariance.
    """
    if max_passes <= 1:
        return 1
    interval = split_interval(model)
    if interval is None or not np.isfinite(interval[1]):
        return 1
    reach = interval[1] - split_hz
    target = target_reach_hz(split_hz, acceptance_hz)
    if reach <= target:
        return 1
    n = min(int(max_passes), math.ceil((reach / target) ** 2))
    if pass_s is not None and pass_s > 0:
        n = min(n, 1 + int(MAX_REPEAT_S // pass_s))
    return max(n, 1)


def average_passes(passes: list[xr.Dataset]) -> xr.Dataset:
    """The passes of one window averaged point by point (response, time stamps, noise).

    Every pass must be the same frequencies at the same bias. The noise variance of the
    average is the passes' mean variance over their number; the result's ``passes``
    attribute says how many were averaged.

    Raises
    ------
    DataError
        If the passes do not share their frequencies and bias.
    """
    first = passes[0]
    for other in passes[1:]:
        if not (
            np.array_equal(first["frequency"].values, other["frequency"].values)
            and np.array_equal(first["bias"].values, other["bias"].values)
        ):
            raise DataError(
                "the passes of a window must share their frequencies and bias: average only "
                "repeated measurements of one window"
            )
    n = len(passes)
    out = first.copy()
    for name, var in first.data_vars.items():
        if name == "noise_var" or "frequency" not in var.dims:
            continue  # the response in memory ("response") or on file (real, imag); time_s
        out[name] = var.copy(data=sum(np.asarray(p[name].values) for p in passes) / n)
    if "noise_var" in first and all("noise_var" in p for p in passes):
        total = sum(np.asarray(p["noise_var"].values) for p in passes)
        out["noise_var"] = first["noise_var"].copy(data=total / n**2)
    elif "noise_var" in out:
        out = out.drop_vars("noise_var")
    out.attrs["passes"] = n
    return out


def repeat_window(
    bench: Bench,
    fitter: Fitter,
    limits: tuple[float, int, float | None],
    say: Callable[[str], None],
    bias: np.ndarray,
    freqs: np.ndarray,
    path: Path,
    first: tuple[xr.Dataset, FittedModel, WindowAssessment],
) -> tuple[xr.Dataset, FittedModel, WindowAssessment]:
    """A narrow window that showed both modes, averaged over the passes its noise calls for.

    ``first`` is the window measured at ``bias`` and saved at ``path``: its sweep, single-bias
    model and evidence. ``limits``: the configuration's ``[tuning] acceptance_hz``,
    ``[experiment] max_passes`` and ``dwell_s`` (None: not set). When :func:`passes_needed`
    asks for more than one pass, the same
    frequencies are measured again by ``bench`` (each pass saved first, as
    ``<stem>-pass2.nc``, ...), averaged (:func:`average_passes`) and fitted again by
    ``fitter``; otherwise ``first`` is returned as it is.
    """
    sweep, model, evidence = first
    acceptance_hz, max_passes, dwell_s = limits
    n = passes_needed(
        model,
        evidence.split_hz,
        acceptance_hz,
        max_passes,
        pass_duration_s(sweep, dwell(bench.device.capabilities, dwell_s, model)[0]),
    )
    if n <= 1:
        return first
    reach = (split_interval(model) or (0.0, float("nan")))[1]
    say(
        f"{path.name}: split {evidence.split_hz * 1e3:.3g} mHz, its 95 % interval reaches "
        f"{reach * 1e3:.3g} mHz; averaging {n} passes"
    )
    passes = [sweep] + [
        bench.measure(bias, freqs, path.with_name(f"{path.stem}-pass{k}{path.suffix}"))
        for k in range(2, n + 1)
    ]
    averaged = average_passes(passes)
    model, evidence = fitter.window(averaged, False)
    return averaged, model, evidence
