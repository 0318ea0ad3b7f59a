"""A tracked run's windows, each with its own split: the split they predict for the next one.

Each verification window near degenerate modes measures the split twice: its own single-bias fit
(unbiased, noisier where a mode is wide) and the run's model anchored on that window alone
(:func:`sysid_core.identification.anchor.anchor`: the mass, damping and polynomial held, less
noisy, but missing what those miss near degenerate modes). :func:`windows_forecast` takes both
as split vectors against the model anchored on the latest window and filters them in time
(:func:`sysid_core.identification.splittrend.forecast`, the model of
:data:`~sysid_core.identification.splittrend.LAB_TREND`, its windows' variances scaled by what
they scatter: :mod:`sysid_core.identification.trendnoise`); the prediction at the next window
is the split the answer is solved for. :class:`sysid_core.drift.tracker.Tracker` applies it.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
import xarray as xr

from sysid_core.clock.runclock import stamps
from sysid_core.conic.program import SYM_BASIS
from sysid_core.data.schema import requested_bias
from sysid_core.drift.windows import window_time
from sysid_core.identification.anchor import Anchor, anchor, split_offset
from sysid_core.identification.splittrend import LAB_TREND, SplitForecast, TrendModel, forecast
from sysid_core.identification.trendnoise import fitted_trend
from sysid_core.model.fitted import FittedModel
from sysid_core.model.modal import mass_roots
from sysid_core.tuning.confidence import split_interval

__all__ = ["bias_key", "interval_variance", "pooled_by_bias", "split_variance", "windows_forecast"]


def split_variance(own: FittedModel) -> float:
    """The variance (Hz²) of a window's own split: the reach of its 95 % interval above it."""
    return interval_variance(own.split_hz([]), split_interval(own))


def interval_variance(split_hz: float, interval: tuple[float, float] | None) -> float:
    """:func:`split_variance` of a window whose split and 95 % interval are known (Hz²)."""
    reach = 0.0 if interval is None else max(interval[1] - split_hz, 0.0)
    return (reach / 1.96) ** 2


def windows_forecast(
    model: FittedModel,
    moved: FittedModel,
    windows: list[tuple[xr.Dataset, FittedModel]],
    at: float,
    trend: TrendModel = LAB_TREND,
    own_variances: Sequence[float] | None = None,
    times_s: Sequence[float] | None = None,
) -> tuple[np.ndarray, SplitForecast]:
    """The offset that gives ``moved`` the split the windows predict at ``at``, and the forecast.

    ``windows``: sweeps and their own single-bias models, oldest first; ``own_variances``:
    each window's :func:`split_variance` where the caller keeps them (else computed), and
    ``times_s`` each window's :func:`~sysid_core.drift.windows.window_time` (NaN: the mean of
    its stamps; None: computed). Each window measures the split twice, each with its fit's
    variance: its own split (from its split interval) and the run's model anchored on it alone
    (from the anchor's least squares). The filter's model is ``trend`` with the variance scale
    the windows support (:func:`~sysid_core.identification.trendnoise.fitted_trend`). The
    offset is traceless: ``moved``'s mean frequency stays.

    Raises
    ------
    ValueError
        With no window.
    """
    if not windows:
        raise ValueError("windows_forecast needs at least one window")
    frame = _Frame.of(model, windows)
    base, inv_root, scale = frame.base, frame.inv_root, frame.scale
    # the split vector of each of the offset's three entries: the map is linear
    columns = np.array([_vector(basis, inv_root, scale) for basis in SYM_BASIS]).T
    own, anchored, times, variances, anchored_var = [], [], [], [], []
    if own_variances is None:
        own_variances = [split_variance(own_model) for _, own_model in windows]
    own_variances = pooled_by_bias([sweep for sweep, _ in windows], own_variances)
    if times_s is None:
        timed = [window_time(sweep, own_model) for sweep, own_model in windows]
        times_s = [np.nan if when is None else when for when in timed]
    for (sweep, own_model), own_variance, when in zip(windows, own_variances, times_s, strict=True):
        own.append(_vector(split_offset(base, sweep, own_model), inv_root, scale))
        alone = frame.found if sweep is windows[-1][0] else anchor(model, [sweep], rate=False)
        anchored.append(_vector(alone.offset - frame.found.offset, inv_root, scale))
        times.append(float(stamps(sweep).mean()) if np.isnan(when) else float(when))
        variances.append(max(own_variance, _FLOOR_HZ2))
        cov = alone.offset_covariance
        anchored_var.append(
            np.inf if cov is None else max(0.5 * np.trace(columns @ cov @ columns.T), _FLOOR_HZ2)
        )
    measured = (times, np.asarray(own), variances)
    fitted = fitted_trend(*measured, trend, np.asarray(anchored), anchored_var)
    found = forecast(*measured, at, fitted, np.asarray(anchored), anchored_var)
    return _offset_to(base, moved, found.vector_hz, scale), found


def bias_key(sweep: xr.Dataset) -> tuple[float, ...]:
    """The bias a window was requested at, as a key: windows at one DAC code share it."""
    return tuple(np.asarray(requested_bias(sweep), dtype=float).tolist())


def pooled_by_bias(sweeps: Sequence[xr.Dataset], variances: Sequence[float]) -> list[float]:
    """Each window's variance, the median of those of the windows at its bias.

    A window's variance comes from its own fit's split interval, linearised at the split the
    window measured; near degenerate modes that interval shrinks with the split it is taken
    at, so a window that reads the split low states a small variance too, and a filter that
    weights each window by its own variance leans on the low readings. Windows measured at one
    bias (one DAC code verified again) measure one split with one design: their noise is one,
    and its estimate the median of theirs (robust to the few windows whose fit went astray).
    docs/studies/repeated-looks.md measures both on a run's windows. A window averaged over
    ``n`` passes (its ``passes`` attribute, :mod:`sysid_core.measure.passes`) holds that noise
    over ``n``: the median is taken per pass.
    """
    keys = [bias_key(sweep) for sweep in sweeps]
    passes = [max(int(sweep.attrs.get("passes", 1)), 1) for sweep in sweeps]
    groups: dict[tuple[float, ...], list[float]] = {}
    for key, variance, n in zip(keys, variances, passes, strict=True):
        groups.setdefault(key, []).append(float(variance) * n)
    return [float(np.median(groups[key])) / n for key, n in zip(keys, passes, strict=True)]


def with_split_rate(moved: FittedModel, found: SplitForecast, span_s: float) -> FittedModel:
    """``moved`` whose stiffness trend (``meta["drift_trend"]``) has the forecast's split rate.

    The trend's common part (the anchor's, if any) stays; its traceless part, the split's rate,
    becomes the filter's (``found.rate_hz_per_s``, Hz/s in the frame of ``moved``'s mean
    frequency), so that every reader of the moved model's trend (the verdict's drift goal, the
    reports) sees the one estimate. ``span_s``: the time the windows span.
    """
    root, inv_root = mass_roots(moved.M)
    trend = moved.facts.trend_per_s
    a = np.zeros((2, 2)) if trend is None else inv_root @ trend @ inv_root
    common = 0.25 * np.trace(a + a.T) * np.eye(2)
    r = np.asarray(found.rate_hz_per_s, dtype=float) * moved.omega_center * 2 * np.pi
    rate = root @ (common + np.array([[r[0], r[1]], [r[1], -r[0]]])) @ root
    meta = dict(moved.meta, drift_trend=rate.tolist(), drift_trend_span_s=float(span_s))
    return dataclasses.replace(moved, meta=meta)


#: A variance of zero (a fit without residuals) stands for this: a hundredth of a mHz, squared.
_FLOOR_HZ2 = 1e-10


@dataclass(frozen=True)
class _Frame:
    """What the windows' splits are taken against: the model anchored on the latest window.

    ``base`` is that model (no rate), ``found`` its anchor, ``inv_root`` ``M^{-1/2}``, ``scale``
    the (rad/s)² of the normalised deviation per Hz of split at the latest window's own mean
    frequency.
    """

    base: FittedModel
    found: Anchor
    inv_root: np.ndarray
    scale: float

    @classmethod
    def of(cls, model: FittedModel, windows: list[tuple[xr.Dataset, FittedModel]]) -> _Frame:
        """The frame of ``windows`` (oldest first) for ``model``."""
        latest = windows[-1][0]
        found = anchor(model, [latest], rate=False)
        _, inv_root = mass_roots(model.M)
        f = float(np.mean(windows[-1][1].modal_frequencies_hz([])))
        return cls(
            base=found.model_at(model, float(stamps(latest).max())),
            found=found,
            inv_root=inv_root,
            scale=4 * np.pi**2 * f,
        )


def _offset_to(
    base: FittedModel, moved: FittedModel, there: np.ndarray, scale: float
) -> np.ndarray:
    """The traceless offset that gives ``moved`` the split vector ``base`` misses by ``there``.

    ``there`` (Hz, the normalised frame: :func:`_vector`) is added to ``base``'s stiffness; the
    offset is that stiffness less ``moved``'s, without its trace (the mean frequency stays).
    """
    root, inv_root = mass_roots(base.M)
    t = np.asarray(there, dtype=float) * scale
    target = np.array([[t[0], t[1]], [t[1], -t[0]]])
    delta = (
        inv_root @ (np.asarray(base.K0) + root @ target @ root - np.asarray(moved.K0)) @ inv_root
    )
    delta = 0.5 * (delta + delta.T)
    delta -= 0.5 * np.trace(delta) * np.eye(2)
    return root @ delta @ root


def _vector(offset: np.ndarray, inv_root: np.ndarray, scale: float) -> np.ndarray:
    """A stiffness offset's traceless part in the normalised frame, as a split vector (Hz).

    ``inv_root`` is ``M^{-1/2}``, ``scale`` the (rad/s)² of the deviation per Hz of split
    (``4π² f``); the vector's length is the split the offset adds near degenerate modes.
    """
    d = inv_root @ offset @ inv_root
    d = 0.5 * (d + d.T)
    d -= 0.5 * np.trace(d) * np.eye(2)
    return np.array([d[0, 0], d[0, 1]]) / scale
