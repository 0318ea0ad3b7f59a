"""Where a lean run measures: frequencies chosen from what is already known.

A mode of quality factor ``Q`` at ``f`` tells its frequency and damping almost only within a
few half-power bandwidths ``bw = f/Q`` of ``f``: the sensitivity of the response to the
mode's frequency, ``|∂G/∂f|``, falls as ``1/Δf²`` away from it, so a point ``k`` bandwidths
away carries about ``1/k⁴`` of the information of a point on the peak (``docs/bench-time.md``
has the numbers). Far points are still needed, a few of them, for what varies slowly with
frequency (the feedthrough polynomial). So a sweep of a lean run is:

* the whole band at the configured resolution, when nothing is known (the run's first sweep);
* a **scout** window around the nearest measured modes, wide enough for an electrode not
  stepped before to move them by about their split (:data:`SCOUT_SPLITS`), at the band's
  resolution: it only has to locate the modes;
* otherwise a **mode grid** (:func:`mode_grid`): around each predicted mode, ``±(2 bw + 2σ)``
  (``σ`` the prediction's uncertainty) at a step of ``bw/2`` or coarser so that no mode gets
  more than ``2·MAX_HALF_POINTS + 1`` points (with ``σ = 0``: 7 points ``2 bw/3`` apart), plus
  :data:`ANCHORS` far points, half on either side. Two modes whose cores overlap (near
  degenerate modes: every verification near the end of a run) share one grid at the finer
  of their steps: two interleaved grids would put pairs of points µHz apart.

A sweep whose evidence (:func:`sysid_core.measure.evidence.assess_window`) does not show both
modes is followed by the whole band at the same bias, so a wrong guess costs points, never a result.

On a bench with a clock the modes move while the run measures them. A verification window
around the predicted modes is centred by the latest located modes moved by the model
(:func:`~sysid_core.measure.motion.recentred`) when the answer's own region knows their mean
less well (a fit of hours of drifting data); a window around modes the sweep before it has
just found is a **fine** grid (``mode_grid(..., fine=True)``: every mode resolved, whatever the
tones) whose uncertainty is their motion since
(:func:`~sysid_core.measure.motion.motion_allowance`).
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass

import numpy as np

from sysid_core.clock.benchtime import acquisitions
from sysid_core.measure.motion import PREDICTION_ERROR
from sysid_core.measure.sweeps import MIN_POINTS, SweepPlan, acquisition_grid

__all__ = [
    "ANCHORS",
    "CORE_BANDWIDTHS",
    "DENSER",
    "FINE_STEP",
    "LOCAL_RADIUS",
    "LOCATE_POINTS",
    "MAX_FINE_HALF_POINTS",
    "MAX_HALF_POINTS",
    "SCOUT_SPLITS",
    "ModeGuess",
    "denser_plan",
    "explained_gap",
    "locate_plan",
    "mode_grid",
    "scout_grid",
    "tone_budget",
]

#: Half-width of a mode's grid, in bandwidths, when its frequency is known exactly.
CORE_BANDWIDTHS = 2.0
#: Points per bandwidth in a mode's grid (its finest step is ``bw / 2``).
POINTS_PER_BANDWIDTH = 2.0
#: At most ``2 * MAX_HALF_POINTS + 1`` points per mode: an uncertain mode gets a coarser step.
MAX_HALF_POINTS = 3
#: A grid resolves a mode when its step there is at most this many bandwidths (the evidence's
#: rule, :mod:`sysid_core.measure.evidence`, with a margin).
RESOLVED_STEP = 0.9
#: A verification's fine window steps this many of the narrowest bandwidths a fit measured:
#: fits scatter by 10-20 % (a step of 0.9 failed on a refit 7 % narrower).
FINE_STEP = 0.75
#: Far points of a mode grid (half on each side), for the slowly varying terms.
ANCHORS = 4
#: The first electrode stepped may move each mode by about this many splits (a miss costs a
#: whole-band sweep).
SCOUT_SPLITS = 0.5
#: ... and by at least this many bandwidths.
SCOUT_BANDWIDTHS = 10.0
#: Most points of a lean run's whole-band sweep (it only locates the modes); ``[experiment]
#: locate_points`` sets it (31: less time, less accurate in the lab:
#: docs/studies/bench-time-lab.md).
LOCATE_POINTS = 61
#: A locating band that does not show both modes is followed by one this many times as dense.
DENSER = 4
#: A fine grid (:func:`mode_grid` with ``fine``) gives each mode at most this many points a side.
MAX_FINE_HALF_POINTS = 12
#: A model explains a verification when its modes miss the measured ones by at most this
#: fraction of the measured split ...
EXPLAIN_FRACTION = 0.25
#: ... plus this much (Hz).
EXPLAIN_FLOOR_HZ = 1e-4
#: Sweeps within this many bias steps (the iteration's step) of the bias count as near it.
LOCAL_RADIUS = 1.5


@dataclass(frozen=True)
class ModeGuess:
    """What is known about the two modes at a bias before measuring there.

    Attributes
    ----------
    frequencies_hz : ndarray
        The two modal frequencies (Hz), ascending.
    bandwidth_hz : ndarray
        Their half-power bandwidths ``f/Q`` (Hz).
    uncertainty_hz : ndarray
        How far each may be from the guess (Hz; 0 for modes just measured there).
    """

    frequencies_hz: np.ndarray
    bandwidth_hz: np.ndarray
    uncertainty_hz: np.ndarray

    @classmethod
    def of(
        cls,
        frequencies_hz: np.ndarray | list[float],
        bandwidth_hz: np.ndarray | list[float],
        uncertainty_hz: np.ndarray | list[float] | float = 0.0,
    ) -> ModeGuess:
        """A guess from array-likes; a scalar uncertainty applies to both modes."""
        f = np.sort(np.asarray(frequencies_hz, dtype=float).reshape(2))
        bw = np.asarray(bandwidth_hz, dtype=float).reshape(2)
        s = np.broadcast_to(np.asarray(uncertainty_hz, dtype=float), (2,)).copy()
        return cls(f, bw, np.abs(s))

    def core_half_widths(self) -> np.ndarray:
        """Half-width of each mode's grid core (Hz): ``CORE_BANDWIDTHS·bw + 2σ``."""
        return CORE_BANDWIDTHS * self.bandwidth_hz + 2.0 * self.uncertainty_hz

    @property
    def split_hz(self) -> float:
        """Distance of the two modes (Hz)."""
        return float(self.frequencies_hz[1] - self.frequencies_hz[0])

    def usable(self) -> bool:
        """Finite frequencies and positive finite bandwidths (a fit can report neither)."""
        return bool(
            np.all(np.isfinite(self.frequencies_hz))
            and np.all(np.isfinite(self.bandwidth_hz) & (self.bandwidth_hz > 0))
            and np.all(np.isfinite(self.uncertainty_hz))
        )

    def moved_from(self, reference: ModeGuess) -> ModeGuess:
        """The same guess with the uncertainty of a predicted move from ``reference``'s modes."""
        move = np.abs(self.frequencies_hz - reference.frequencies_hz)
        return ModeGuess(
            self.frequencies_hz,
            self.bandwidth_hz,
            np.maximum(self.uncertainty_hz, PREDICTION_ERROR * move),
        )


def _clip(points: np.ndarray, band: tuple[float, float]) -> np.ndarray:
    lo, hi = band
    return points[(points >= lo) & (points <= hi)]


def _merge(points: np.ndarray, tol: float) -> np.ndarray:
    """Sorted points with those closer than ``tol`` to the previous kept one dropped."""
    p = np.sort(points)
    keep = [p[0]]
    for x in p[1:]:
        if x - keep[-1] > tol:
            keep.append(x)
    return np.array(keep)


def anchor_reach(bw: np.ndarray, plan: SweepPlan) -> float:
    """How far beyond two modes a grid's far points reach: ``max(refine_span_hz/2, 10 bw)``."""
    return max(plan.refine_span_hz / 2, 10 * float(np.max(bw)))


def following(plan: SweepPlan, guess: ModeGuess) -> SweepPlan:
    """``plan`` with its band widened to hold the grid around ``guess``'s modes.

    The modes are measured where they are (:meth:`~sysid_core.measure.sweeps.SweepPlan.following`):
    their cores and far points, :func:`anchor_reach` beyond the outer modes.
    """
    reach = anchor_reach(guess.bandwidth_hz, plan) + float(np.max(guess.core_half_widths()))
    return plan.following(guess.frequencies_hz, reach)


def anchors(f: np.ndarray, bw: np.ndarray, plan: SweepPlan) -> np.ndarray:
    """:data:`ANCHORS` far points around two modes, inside the band.

    Half on either side at ``reach/2`` and ``reach`` beyond the outer modes, ``reach =
    max(refine_span_hz/2, 10 bw)``, moved inside the band where they would leave it; plus two
    between the modes when they are far apart.
    """
    reach = anchor_reach(bw, plan)
    side = ANCHORS // 2
    out = np.arange(1, side + 1) / side * reach
    points = [f[0] - out, f[1] + out]
    if f[1] - f[0] > 2 * reach:
        points.append(f[0] + (f[1] - f[0]) * np.array([1 / 3, 2 / 3]))
    return np.clip(np.concatenate(points), *plan.band_hz)


def _core_steps(
    guess: ModeGuess, points_per_bw: float, max_half: int
) -> tuple[np.ndarray, list[int]]:
    """Each mode's step ``max(bw / points_per_bw, h / max_half)`` and its points a side."""
    bw, half = guess.bandwidth_hz, guess.core_half_widths()
    steps = np.maximum(bw / points_per_bw, half / max_half)
    return steps, [math.ceil(hi / si - 1e-9) for hi, si in zip(half, steps, strict=True)]


def _mode_points(
    guess: ModeGuess, plan: SweepPlan, points_per_bw: float, max_half: int
) -> np.ndarray:
    """Around each mode ``±h`` at the step ``max(bw / points_per_bw, h / max_half)``.

    Then the anchors; everything inside the band, near-duplicates merged.
    """
    f, bw = guess.frequencies_hz, guess.bandwidth_hz
    steps, counts = _core_steps(guess, points_per_bw, max_half)
    parts = [fi + si * np.arange(-k, k + 1) for fi, si, k in zip(f, steps, counts, strict=True)]
    union = _one_core(f, steps, counts)
    if union is not None:
        parts = [union]
    points = _clip(np.concatenate([*parts, anchors(f, bw, plan)]), plan.band_hz)
    return _merge(points, 1e-3 * float(bw.min()))


def _one_core(f: np.ndarray, steps: np.ndarray, counts: list[int]) -> np.ndarray | None:
    """The two modes' cores as one grid when they overlap, or None when they do not.

    Two overlapping grids of steps ``s0, s1`` interleave: points a fraction of a step apart
    (near degenerate modes: pairs a few µHz apart) resolve nothing the finer grid alone does
    not. One grid over the union of the cores at the finer step, ``min(s0, s1)``, keeps every
    mode's resolution; it is used when it has fewer points than the two grids together.
    """
    lo = np.asarray(f) - np.asarray(steps) * np.asarray(counts)
    hi = np.asarray(f) + np.asarray(steps) * np.asarray(counts)
    step = float(np.min(steps))
    if lo[1] > hi[0] + step or not step > 0:
        return None
    start, stop = float(np.min(lo)), float(np.max(hi))
    n = math.ceil((stop - start) / step - 1e-9)
    if n + 1 >= sum(2 * k + 1 for k in counts):
        return None
    centre = 0.5 * (start + stop)
    return centre + step * (np.arange(n + 1) - n / 2)


def mode_grid(
    guess: ModeGuess,
    plan: SweepPlan,
    resolve: bool = False,
    fine: bool = False,
    finest_hz: float | None = None,
) -> np.ndarray:
    """The points of a sweep around two modes whose frequencies are (roughly) known.

    Around each mode ``±h`` with ``h = CORE_BANDWIDTHS·bw + 2σ``, at a step of
    ``bw / POINTS_PER_BANDWIDTH`` or ``h / MAX_HALF_POINTS``, whichever is coarser; then the
    :data:`ANCHORS` far points of :func:`anchors`. Everything inside the plan's band, widened
    to hold the modes and their far points where they lie outside it
    (:meth:`~sysid_core.measure.sweeps.SweepPlan.following`); never
    fewer than :data:`~sysid_core.measure.sweeps.MIN_POINTS` points (the step is halved and the
    points per mode doubled until there are: modes at the band's edge, far points merged).

    With a device that measures several tones per acquisition (``plan.tones > 1``) the grid
    is fitted to whole acquisitions: when a few points (at most ``ANCHORS / 2``) would spill
    into one more acquisition, as many of the nearer anchors are dropped; and with ``resolve``
    (a verification, which must resolve the modes) an uncertain mode's coarse step is refined
    to :data:`RESOLVED_STEP` bandwidths when that costs at most one acquisition more
    (:func:`tone_budget`): one grid then does what a coarse sweep and a fine one would.

    With ``fine`` (the window around modes a sweep has just found, whose uncertainty is their
    motion since, :func:`~sysid_core.measure.motion.motion_allowance`) the step is refined to
    :data:`RESOLVED_STEP` bandwidths, and to at most ``finest_hz`` when given (a verification's:
    :data:`FINE_STEP` of the narrowest bandwidth a fit measured), whatever the tones, with at most
    :data:`MAX_FINE_HALF_POINTS` points on either side of a mode: the window is there to
    resolve them.
    """
    plan = following(plan, guess)
    points_per_bw, max_half = POINTS_PER_BANDWIDTH, MAX_HALF_POINTS
    points = np.linspace(*plan.band_hz, MIN_POINTS)
    for _ in range(6):
        candidate = _mode_points(guess, plan, points_per_bw, max_half)
        if candidate.size >= MIN_POINTS:
            points = candidate
            break
        points_per_bw, max_half = 2 * points_per_bw, 2 * max_half
    else:
        return points
    bw, half = guess.bandwidth_hz, guess.core_half_widths()
    step = np.maximum(bw / points_per_bw, half / max_half)
    target = np.minimum(RESOLVED_STEP * bw, np.inf if finest_hz is None else finest_hz)
    if fine and np.any(step > target):
        needed = math.ceil(float(np.max(half / target)) - 1e-9)
        per_bw = max(points_per_bw, float(np.max(bw / target)))
        return _mode_points(guess, plan, per_bw, min(needed, MAX_FINE_HALF_POINTS))
    if plan.tones <= 1:
        return points
    if resolve and np.any(step > RESOLVED_STEP * bw):
        # too coarse to resolve the modes: a finer grid if one more acquisition pays for it
        needed = math.ceil(float(np.max(half / (RESOLVED_STEP * bw))) - 1e-9)
        budget = tone_budget(points.size, plan.tones, extra=1)
        # counted before they are made: a model's mode of a far too narrow bandwidth would
        # ask for hundreds of millions (seen: 5e8 points of a 2 kHz gyro's window)
        if 2 * max(_core_steps(guess, points_per_bw, needed)[1]) + 1 > budget:
            return points
        finer = _mode_points(guess, plan, points_per_bw, needed)
        return finer if finer.size <= budget else points
    spill = points.size % plan.tones
    if points.size - spill >= MIN_POINTS and 0 < spill <= ANCHORS // 2:
        # a few points spill into one more acquisition: drop that many of the nearer anchors
        near = _nearer_anchors(points, guess, plan)[:spill]
        points = np.setdiff1d(points, near)
    return points


def _nearer_anchors(points: np.ndarray, guess: ModeGuess, plan: SweepPlan) -> np.ndarray:
    """The anchors of ``points`` (those outside the modes' cores), nearest to a mode first."""
    f, half = guess.frequencies_hz, guess.core_half_widths()
    distance = np.min(np.abs(points[:, None] - f[None, :]) - half[None, :], axis=1)
    outside = distance > 1e-9
    order = np.argsort(distance[outside])
    return points[outside][order]


def tone_budget(n_points: int, tones: int, extra: int = 0) -> int:
    """The points ``n_points`` take in whole acquisitions of ``tones``, plus ``extra`` more.

    What a sweep may use at the same (or a little more) bench time.
    """
    return (acquisitions(n_points, tones) + int(extra)) * max(int(tones), 1)


def scout_grid(guess: ModeGuess, plan: SweepPlan) -> np.ndarray:
    """Windows that locate modes which may have moved since ``guess`` by an unknown amount.

    Around each mode ``± m`` at the band's resolution, inside the band (widened to hold the
    windows, :meth:`~sysid_core.measure.sweeps.SweepPlan.following`; the band itself when
    the windows would cover most of it): ``m = σ + SCOUT_BANDWIDTHS × bw`` when the guess
    carries an uncertainty ``σ`` (the move expected from the electrodes stepped before),
    else ``max(SCOUT_SPLITS × split, SCOUT_BANDWIDTHS × bw)``; in whole acquisitions
    (:func:`~sysid_core.measure.sweeps.acquisition_grid`).
    """
    f, bw = guess.frequencies_hz, guess.bandwidth_hz
    sigma = float(guess.uncertainty_hz.max())
    wide = SCOUT_BANDWIDTHS * float(bw.max())
    m = sigma + wide if sigma > 0 else max(SCOUT_SPLITS * guess.split_hz, wide)
    plan = plan.following(f, m)
    blo, bhi = plan.band_hz
    windows = [(max(blo, float(fi) - m), min(bhi, float(fi) + m)) for fi in f]
    if windows[1][0] <= windows[0][1]:  # overlapping: one window
        windows = [(windows[0][0], windows[1][1])]
    if sum(hi - lo for lo, hi in windows) >= 0.8 * (bhi - blo):
        windows = [(blo, bhi)]
    points = acquisition_grid(windows, plan.resolution_hz, plan.tones)
    return _merge(points, 1e-9 * float(f.max()))


def locate_plan(plan: SweepPlan, points: int = LOCATE_POINTS) -> SweepPlan:
    """``plan`` with a whole-band sweep of at most ``points`` points.

    A lean run sweeps the whole band only to locate the modes (the mode grids measure them),
    so its step is ``resolution_hz`` or ``band / (points - 1)``, whichever is coarser; a sweep
    that does not locate them is followed by one four times as dense, then by the band at
    ``resolution_hz`` (each only if it has fewer points than the next). Its points do not
    depend on the device's tones.
    """
    lo, hi = plan.band_hz
    step = max(plan.resolution_hz, (hi - lo) / (points - 1))
    return dataclasses.replace(plan, resolution_hz=step)


def denser_plan(plan: SweepPlan, finest_hz: float) -> SweepPlan:
    """``plan``'s band :data:`DENSER` times as dense, never finer than ``finest_hz``.

    What follows a locating band that did not show both modes (then the band at ``finest_hz``,
    the run's ``resolution_hz``).
    """
    return dataclasses.replace(plan, resolution_hz=max(finest_hz, plan.resolution_hz / DENSER))


def explained_gap(predicted_hz: np.ndarray, measured_hz: np.ndarray) -> float | None:
    """How far a model's modes miss measured ones (Hz), or None if the model explains them.

    A model explains a verification when each of its two modes is within
    ``EXPLAIN_FRACTION × split + EXPLAIN_FLOOR_HZ`` of the measured one: it then also predicts
    the next small correction; otherwise its stiffness law does not hold over all the data.
    """
    p = np.sort(np.asarray(predicted_hz, dtype=float))
    m = np.sort(np.asarray(measured_hz, dtype=float))
    gap = float(np.max(np.abs(p - m)))
    allowed = EXPLAIN_FRACTION * float(m[1] - m[0]) + EXPLAIN_FLOOR_HZ
    return None if gap <= allowed else gap
