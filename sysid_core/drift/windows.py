"""What one verification window can say of the split, before any filter reads it.

Two judgements of a window kept by :class:`sysid_core.drift.tracker.Tracker`: whether its own
fit put a mode where none of its points came near (:func:`blind`: that split is not the
window's to give), and the least split its fit allows at 95 % (:func:`least_split`: a window
whose noise spans the split cannot be told from one near degenerate modes). And when it
measured the split (:func:`window_time`): the time of the split its fit gives, which the
filter reads it at, and from which the drift to the window's end is counted (:func:`to_end_s`).
"""

from __future__ import annotations

import numpy as np
import xarray as xr

from sysid_core.clock.runclock import stamps
from sysid_core.data.schema import point_times
from sysid_core.errors import ModelError
from sysid_core.measure.evidence import WindowAssessment
from sysid_core.measure.information import split_weights
from sysid_core.model.fitted import FittedModel
from sysid_core.tuning.confidence import split_interval

__all__ = ["SAMPLED_WITHIN", "blind", "least_of", "least_split", "to_end_s", "window_time"]


def least_split(split_hz: float, own: FittedModel | None) -> float:
    """The least split a window's own fit allows at 95 %: its interval's lower end.

    ``split_hz`` where the fit states no interval (or there is no fit). What decides whether a
    window is near degenerate modes (:attr:`Tracker.near_hz`): a window whose noise spans the
    split cannot be told from one that is.
    """
    return least_of(split_hz, None if own is None else split_interval(own))


def least_of(split_hz: float, interval: tuple[float, float] | None) -> float:
    """:func:`least_split` of a window whose 95 % interval is known (None: none stated)."""
    return split_hz if interval is None else min(split_hz, float(interval[0]))


#: A fitted mode is measured by a window only if one of its points lies within this many of the
#: mode's bandwidths (at 3, the mode's own response there is 16 % of its peak).
SAMPLED_WITHIN = 3.0


def blind(sweep: xr.Dataset, evidence: WindowAssessment) -> bool:
    """Whether a fitted mode lies over :data:`SAMPLED_WITHIN` bandwidths from every point.

    A window that stood too coarse (its split far over the acceptance) may have one of two
    modes between its points: a window with a step of 2.3-2.6 Hz held one of two modes 16 Hz
    apart (a 25.8 kHz gyro), and its fit added a mode 4.6 Hz away, 6.7 of its bandwidths from
    the nearest point. A window that resolves its modes has a point within half a bandwidth of
    each; on a 1.0 kHz gyro a window that stood with a step of 0.09 Hz had a point within 1.7
    bandwidths of each mode, and its split (36 mHz) was right.
    """
    f = np.asarray(sweep["frequency"].values, dtype=float)
    modes = np.asarray(evidence.frequencies_hz, dtype=float)
    bw = np.asarray(evidence.bandwidth_hz, dtype=float)
    if not f.size or modes.size != bw.size:
        return False
    near = np.min(np.abs(f[None, :] - modes[:, None]), axis=1)
    return bool(np.any(near > SAMPLED_WITHIN * np.where(np.isfinite(bw), bw, np.inf)))


def window_time(sweep: xr.Dataset, own: FittedModel | None) -> float | None:
    """When a window measured the split (seconds): ``Σ a_i t_i``, or None without time stamps.

    A split that moves during the window at a steady rate is fitted as the split at the time
    ``Σ a_i t_i``, ``a_i`` each point's share of the estimate by the modes of its own fit
    (:func:`~sysid_core.measure.information.split_weights`), within the window's stamps. The
    mean of its stamps where those shares are not known (no fit, no modes, too few points).
    A window measured least informative point first
    (:func:`~sysid_core.measure.information.measuring_order`) measures the split near its end.
    """
    t = stamps(sweep)
    if not t.size:
        return None
    at = point_times(sweep, 0) if "experiment" in sweep["time_s"].dims else None
    weights = None if at is None else _shares(sweep, own, at)
    if at is None or weights is None:
        return float(t.mean())
    return float(np.clip(weights @ at, t.min(), t.max()))


def _shares(sweep: xr.Dataset, own: FittedModel | None, at: np.ndarray) -> np.ndarray | None:
    """Each point's share of the window's split by its own fit's modes, or None.

    ``at``: the window's time stamps, one per point measured.
    """
    if own is None or at.size != sweep.sizes["frequency"]:
        return None
    try:
        modes = own.modal()
    except ModelError:
        return None
    bw = modes.bandwidth_hz
    if not np.all(np.isfinite(bw) & (bw > 0)):
        return None
    f = np.asarray(sweep["frequency"].values, dtype=float)
    weights = split_weights(f, modes.frequencies_hz, bw)
    return weights if weights is not None and np.all(np.isfinite(weights)) else None


def to_end_s(sweep: xr.Dataset, own: FittedModel | None) -> float:
    """From a window's :func:`window_time` to its last time stamp (seconds; 0 without stamps).

    The drift a run that stops after this window carries past what the window measured.
    """
    when, t = window_time(sweep, own), stamps(sweep)
    return 0.0 if when is None else float(t.max()) - when
