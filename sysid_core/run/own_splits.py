"""A tracked run's windows, each with its own split: the split they give the anchored model.

Near degenerate modes whose bandwidths are a hundred times the split, what a model's mass,
damping and polynomial miss, the anchor (:func:`sysid_core.identification.anchor.anchor`) can
take for a split; a verification window's own single-bias fit measures the split itself.
:func:`windows_split` gives the anchored model the latest window's own split (and its
orientation) where that move is beyond the window's noise; :func:`windows_line`, once four
windows or more tell the split's drift, the split a line in time through theirs puts at the
next window; :func:`windows_pooled`, where two windows or more were measured within
:data:`POOL_HORIZON_S` of each other, the split they put there together.
:class:`sysid_core.run.tracking.Tracker` applies them.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import xarray as xr

from sysid_core.identification.anchor import Anchor, anchor, split_offset
from sysid_core.model.fitted import FittedModel
from sysid_core.model.modal import mass_roots
from sysid_core.run.clock import stamps
from sysid_core.tuning.confidence import split_interval

__all__ = [
    "LINE_SIGNIFICANCE",
    "LINE_WINDOWS",
    "POOL_HORIZON_S",
    "POOL_RATE_RIDGE_MIN2",
    "SPLIT_SIGNIFICANCE",
    "split_variance",
    "windows_line",
    "windows_pooled",
    "windows_split",
]


def split_variance(own: FittedModel) -> float:
    """The variance (Hz²) of a window's own split: the reach of its 95 % interval above it."""
    interval = split_interval(own)
    reach = 0.0 if interval is None else max(interval[1] - own.split_hz([]), 0.0)
    return (reach / 1.96) ** 2


#: The windows' own splits move the anchored model only when the move is over this many
#: standard deviations of their mean (their noise's, from each window's split interval).
SPLIT_SIGNIFICANCE = 2.0


def windows_split(
    model: FittedModel, found: Anchor, windows: list[tuple[xr.Dataset, FittedModel]]
) -> tuple[np.ndarray, float]:
    """The stiffness offset that gives the anchored model its windows' own split, and its move.

    For each window (sweep and own single-bias model), what the anchored model at the window's
    time misses of the split that window measured
    (:func:`~sysid_core.identification.anchor.split_offset`); their mean, if the split it moves
    (Hz) is over :data:`SPLIT_SIGNIFICANCE` standard deviations of the windows' mean split
    (each window's from its 95 % interval), else zero: where the anchor holds, the windows'
    noise would only move the answer (a clock without drift at 60 dB, random gyros 101-124,
    4 iterations: 20 of 24 within 2 mHz with the anchor alone, 17 with the windows' mean
    always applied, 18 with this test; in the uncontrolled lab, 8 iterations: 15, 19 and 19).

    :meth:`Tracker.now` passes the latest window that gives its own split, alone: the windows
    sit at different biases and times, and the orientations of their own splits differ, so
    that their mean moved random gyro 313 (8.6 kHz, lab) by 1.0-1.4 mHz where its model lacked
    about 3, and the run ended at 4.0 mHz; with the latest window alone it ends at 1.0 mHz.
    The four lab sets (docs/drift.md), 8 iterations, draws 0-2: 253 of 288 within 2 mHz
    against 244 with the mean of up to four windows.
    """
    offsets, variances = [], []
    for sweep, own in windows:
        then = found.model_at(model, float(stamps(sweep).mean()))
        offsets.append(split_offset(then, sweep, own))
        variances.append(split_variance(own))
    mean = np.mean(offsets, axis=0)
    _, inv_root = mass_roots(model.M)
    d = inv_root @ mean @ inv_root  # traceless: [[a, b], [b, -a]]
    # the latest window's own modes: the model may have none at its bias (a local model, and a
    # window at the bias limits: random gyro 112 in the lab)
    f = float(np.mean(windows[-1][1].modal_frequencies_hz([])))
    shift = float(np.hypot(d[0, 0], d[0, 1])) / (4 * np.pi**2 * f)
    sigma = float(np.sqrt(np.sum(variances))) / len(windows)
    if shift <= SPLIT_SIGNIFICANCE * sigma:
        return np.zeros((2, 2)), 0.0
    return mean, shift


#: A line through the near windows' own splits needs this many windows.
LINE_WINDOWS = 4
#: ... and a slope whose Wald statistic (from the windows' noise) exceeds χ²'s 95 % point with
#: 2 degrees of freedom.
LINE_SIGNIFICANCE = 5.99


def windows_line(
    model: FittedModel,
    moved: FittedModel,
    windows: list[tuple[xr.Dataset, FittedModel]],
    at: float,
) -> np.ndarray | None:
    """The offset that gives ``moved`` the split a line in time through the windows' puts at ``at``.

    ``windows``: the run's windows near degenerate modes (sweep and own model), oldest first.
    Each window's own split is taken against ``model`` anchored on the latest window alone
    (no rate), as a vector in the normalised frame (Hz); a line in time through them, weighted
    by each window's noise (from its split interval), is evaluated at ``at``. None with fewer
    than :data:`LINE_WINDOWS` windows or a slope the noise does not tell
    (:data:`LINE_SIGNIFICANCE`). The offset is traceless: ``moved``'s mean frequency stays.

    The windows' own splits carry the split's drift where the model's anchor cannot tell it
    (replayed on the lab runs of docs/drift.md: on gyros under 8 kHz, whose windows are tens of
    minutes apart, such a line misses the split's true drift by 0.03 mHz/min in 0.15, and the
    latest window alone is stale by it). :meth:`Tracker.now` takes the line over the latest
    window's split: the four lab sets in three draws end 262 of 288 runs within 2 mHz against
    257 (gyro 512, 1.8 kHz, draw 1: 1.8 mHz instead of 4.6). Gating it also on the move from
    the latest window to the next being told from the line's own uncertainty (the line then
    served only the slow gyros) left the count at 257.
    """
    if len(windows) < LINE_WINDOWS:
        return None
    frame = _Frame.of(model, windows)
    base, inv_root, scale, t_latest = frame.base, frame.inv_root, frame.scale, frame.t_latest
    rows, times, variances = [], [], []
    for sweep, own in windows:
        rows.append(_vector(split_offset(base, sweep, own), inv_root, scale))
        times.append(float(stamps(sweep).mean()) - t_latest)
        variances.append(max(split_variance(own), 1e-18))
    x = np.c_[np.ones(len(times)), times]
    w = 1.0 / np.asarray(variances)
    cov = np.linalg.inv(x.T @ (x * w[:, None]))
    beta = cov @ (x.T @ (np.asarray(rows) * w[:, None]))
    if float(beta[1] @ beta[1] / cov[1, 1]) <= LINE_SIGNIFICANCE:
        return None
    return _offset_to(base, moved, beta[0] + beta[1] * (at - t_latest), scale)


@dataclass(frozen=True)
class _Frame:
    """What the windows' splits are taken against: the model anchored on the latest window.

    ``base`` is that model (no rate), ``offset`` its anchor's offset, ``inv_root`` ``M^{-1/2}``,
    ``scale`` the (rad/s)² of the normalised deviation per Hz of split at the latest window's
    own mean frequency, ``t_latest`` the middle of the latest window (seconds).
    """

    base: FittedModel
    offset: np.ndarray
    inv_root: np.ndarray
    scale: float
    t_latest: float

    @classmethod
    def of(cls, model: FittedModel, windows: list[tuple[xr.Dataset, FittedModel]]) -> _Frame:
        """The frame of ``windows`` (oldest first) for ``model``."""
        latest = windows[-1][0]
        found = anchor(model, [latest], rate=False)
        _, inv_root = mass_roots(model.M)
        f = float(np.mean(windows[-1][1].modal_frequencies_hz([])))
        return cls(
            base=found.model_at(model, float(stamps(latest).max())),
            offset=found.offset,
            inv_root=inv_root,
            scale=4 * np.pi**2 * f,
            t_latest=float(stamps(latest).mean()),
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


#: The windows pooled are those measured within this many seconds (the middle of each) of the
#: latest: over minutes the split's drift is a line and what the model misses stays the same.
POOL_HORIZON_S = 600.0
#: The prior on the pooled line's slope, as a ridge in min² on windows of unit weight: the split
#: drifts by about ``1 / sqrt(0.25) = 2`` windows' noise per minute (the lab's fast gyros: a
#: window reads the split to 0.4-1.2 mHz, charging moves it 0.3-3 mHz a minute).
POOL_RATE_RIDGE_MIN2 = 0.25


def windows_pooled(
    model: FittedModel,
    moved: FittedModel,
    windows: list[tuple[xr.Dataset, FittedModel]],
    at: float,
) -> tuple[np.ndarray, int] | None:
    """The offset that gives ``moved`` the split the latest windows put at ``at`` together.

    ``windows``: the run's windows near degenerate modes (sweep and own model), oldest first;
    those within :data:`POOL_HORIZON_S` of the latest are pooled, and with fewer than two the
    answer is None. Each window gives two estimates of the split at its bias and time: the
    model anchored on it alone (:func:`~sysid_core.identification.anchor.anchor`: the mass,
    damping and polynomial held, so that it is near what the window can tell at best, but
    biased by what those miss near degenerate modes, 1-3 mHz on some gyros), and the window's
    own fit (unbiased, two or three times noisier where a mode is wide). The anchored
    estimates, moved by the mean of their difference from the own ones, lie on a line in time
    whose slope has the prior :data:`POOL_RATE_RIDGE_MIN2`; the line at ``at`` is the split the
    moved model is given (a traceless offset: its mean frequency stays). With the count of
    windows pooled.

    Measured (docs/drift.md, "Pooled windows"): replayed on the lab's runs of 24 iterations
    made before it, the pooled split at the next window of gyros at 8 kHz or more is within
    2 mHz of the truth in 81 % of 321 predictions against 63 % for the tracker's rule then
    (root mean square 2.0 against 3.3 mHz); a slow gyro's windows are rarely two within the
    horizon, and :meth:`Tracker.now` keeps the line or the latest window's split there.
    """
    t_last = float(stamps(windows[-1][0]).mean()) if windows else 0.0
    windows = [w for w in windows if t_last - float(stamps(w[0]).mean()) <= POOL_HORIZON_S]
    if len(windows) < 2:
        return None
    frame = _Frame.of(model, windows)
    base, inv_root, scale = frame.base, frame.inv_root, frame.scale
    own, anchored, minutes = [], [], []
    for sweep, own_model in windows:
        own.append(_vector(split_offset(base, sweep, own_model), inv_root, scale))
        alone = anchor(model, [sweep], rate=False).offset - frame.offset
        anchored.append(_vector(alone, inv_root, scale))
        minutes.append((float(stamps(sweep).mean()) - t_last) / 60.0)
    own_v, anchored_v, tau = np.asarray(own), np.asarray(anchored), np.asarray(minutes)
    y = anchored_v + np.mean(own_v - anchored_v, axis=0)
    x = np.c_[np.ones_like(tau), tau]
    beta = np.linalg.solve(x.T @ x + np.diag([0.0, POOL_RATE_RIDGE_MIN2]), x.T @ y)
    there = beta[0] + beta[1] * (at - t_last) / 60.0
    return _offset_to(base, moved, there, scale), len(windows)
