"""The mode grid: a sweep's points around two modes whose frequencies are (roughly) known.

Around each predicted mode ``±(c·bw + 2σ)`` (``bw = f/Q`` its bandwidth, ``σ`` the prediction's
uncertainty, ``c`` the core's half-width in bandwidths) at a step of ``bw/2`` or coarser so that no
mode gets more than ``2·MAX_HALF_POINTS + 1`` points, plus far points (anchors), half on either
side, for what varies slowly with frequency (the feedthrough). Two modes whose cores overlap
(near degenerate modes: every verification near the end of a run) share one grid, at the finer
of their steps or graded (the finer step over the finer mode's core only, :func:`_one_core`):
two interleaved grids would put pairs of points µHz apart.

**The shape: the cheapest, then by information per second.** Which core, how many anchors and
whether overlapping cores are graded: every shape of :data:`SHAPES` resolves each mode as the
evidence asks, so :func:`mode_grid` measures the one that costs the least bench clock
(settling, and acquisitions with the device's ``tones``) and, of equally cheap ones, the one
whose points tell the most about the split (:mod:`sysid_core.measure.information`). Per point
the information hardly depends on the shape, and a verification's split is known to tenths of
a millihertz where the acceptance is one (fresh random gyros, one tone: a median of 152 dwells
against 155 by information per second alone, ``docs/studies/information.md``). With several
tones the points that fill an acquisition already paid for are free: the most informative win.

A window around modes a sweep has just found is a **fine** grid (``mode_grid(..., fine=True)``:
every mode resolved, whatever the tones) whose uncertainty is their motion since
(:func:`~sysid_core.measure.motion.motion_allowance`).
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from sysid_core.clock.benchtime import acquisitions
from sysid_core.measure.information import split_information, sweep_cost
from sysid_core.measure.motion import PREDICTION_ERROR
from sysid_core.measure.sweeps import MIN_POINTS, SweepPlan, fewest_points

__all__ = [
    "ANCHORS",
    "CORE_BANDWIDTHS",
    "DENSER_STEPS",
    "FINE_STEP",
    "MAX_FINE_HALF_POINTS",
    "MAX_HALF_POINTS",
    "RESOLVED_STEP",
    "SHAPES",
    "GridShape",
    "ModeGuess",
    "anchor_reach",
    "following",
    "merge",
    "mode_grid",
    "shaped_grid",
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
#: A fine grid (:func:`mode_grid` with ``fine``) gives each mode at most this many points a side.
MAX_FINE_HALF_POINTS = 12
#: A grid short of the fewest points is made denser by ``2^(1/4)`` at a time, at most this many
#: times (64 times denser: modes at the band's edge, their far points merged). A quarter
#: octave, not a doubling: a one-tone grid of 9 points for a floor of 11 took 17 when doubled.
DENSER_STEPS = 24


@dataclass(frozen=True)
class GridShape:
    """A mode grid's shape: its cores' half-width in bandwidths and its far points."""

    core: float = CORE_BANDWIDTHS
    anchors: int = ANCHORS
    #: Two overlapping cores of different steps as one graded grid (the finer step only over
    #: the finer mode's core) rather than one even grid at the finer step (:func:`_one_core`).
    graded: bool = False


#: The shapes :func:`mode_grid` chooses from; the first wins a tie. The wider core sees a
#: mode's tails, the narrower spends its points where the information is; two anchors pin the
#: feedthrough's level and slope, four its curvature too. No core is narrower than 1.5
#: bandwidths: the evidence counts a mode resolved when no step that meets its ``±bw`` is over
#: ``bw`` (:func:`~sysid_core.measure.evidence.local_steps`), and the gap from a core's last
#: point to the anchors must stay clear of a fitted mode a quarter of a bandwidth off the
#: guess with a bandwidth a fifth wider (cores of 1 and 0.5 bandwidths failed it: one tone,
#: 413 dwells against 144, ``docs/studies/information.md``).
SHAPES = tuple(
    GridShape(c, a, g) for g in (False, True) for c in (CORE_BANDWIDTHS, 1.5) for a in (ANCHORS, 2)
)


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

    def core_half_widths(self, core: float = CORE_BANDWIDTHS) -> np.ndarray:
        """Half-width of each mode's grid core (Hz): ``core·bw + 2σ``."""
        return core * self.bandwidth_hz + 2.0 * self.uncertainty_hz

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


def merge(points: np.ndarray, tol: float) -> np.ndarray:
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


def following(plan: SweepPlan, guess: ModeGuess, core: float = CORE_BANDWIDTHS) -> SweepPlan:
    """``plan`` with its band widened to hold the grid around ``guess``'s modes.

    The modes are measured where they are (:meth:`~sysid_core.measure.sweeps.SweepPlan.following`):
    their cores (``core`` bandwidths) and far points, :func:`anchor_reach` beyond the outer modes.
    """
    reach = anchor_reach(guess.bandwidth_hz, plan) + float(np.max(guess.core_half_widths(core)))
    return plan.following(guess.frequencies_hz, reach)


def anchors(f: np.ndarray, bw: np.ndarray, plan: SweepPlan, count: int = ANCHORS) -> np.ndarray:
    """``count`` far points around two modes, inside the band.

    Half on either side, evenly out to ``reach`` beyond the outer modes (``reach =
    max(refine_span_hz/2, 10 bw)``), moved inside the band where they would leave it; plus two
    between the modes when they are far apart.
    """
    reach = anchor_reach(bw, plan)
    side = count // 2
    out = np.arange(1, side + 1) / side * reach
    points = [f[0] - out, f[1] + out]
    if f[1] - f[0] > 2 * reach:
        points.append(f[0] + (f[1] - f[0]) * np.array([1 / 3, 2 / 3]))
    return np.clip(np.concatenate(points), *plan.band_hz)


def _core_steps(
    guess: ModeGuess, points_per_bw: float, max_half: float, core: float = CORE_BANDWIDTHS
) -> tuple[np.ndarray, list[int]]:
    """Each mode's step ``max(bw / points_per_bw, h / max_half)`` and its points a side."""
    bw, half = guess.bandwidth_hz, guess.core_half_widths(core)
    steps = np.maximum(bw / points_per_bw, half / max_half)
    return steps, [math.ceil(hi / si - 1e-9) for hi, si in zip(half, steps, strict=True)]


def _mode_points(
    guess: ModeGuess,
    plan: SweepPlan,
    points_per_bw: float,
    max_half: float,
    shape: GridShape = GridShape(),
) -> np.ndarray:
    """Around each mode ``±h`` at the step ``max(bw / points_per_bw, h / max_half)``.

    Then the anchors; everything inside the band, near-duplicates merged.
    """
    f, bw = guess.frequencies_hz, guess.bandwidth_hz
    steps, counts = _core_steps(guess, points_per_bw, max_half, shape.core)
    parts = [fi + si * np.arange(-k, k + 1) for fi, si, k in zip(f, steps, counts, strict=True)]
    union = _one_core(f, steps, counts, shape.graded)
    if union is not None:
        parts = [union]
    points = _clip(np.concatenate([*parts, anchors(f, bw, plan, shape.anchors)]), plan.band_hz)
    return merge(points, 1e-3 * float(bw.min()))


def _one_core(
    f: np.ndarray, steps: np.ndarray, counts: list[int], graded: bool = False
) -> np.ndarray | None:
    """The two modes' cores as one grid when they overlap, or None when they do not.

    Two overlapping grids of steps ``s0, s1`` interleave: points a fraction of a step apart
    (near degenerate modes: pairs a few µHz apart) resolve nothing the finer grid alone does
    not. One grid keeps every mode's own step with fewer points, of two kinds:

    * **even**: the union of the cores at the finer step, ``min(s0, s1)``;
    * **graded**: the finer mode's core at its step, continued at the coarser mode's step as
      far as that mode's core reaches (a random gyro's Q of 8 000 and 17 000: 11 core points
      where the even grid takes 13). With ``graded``, when it has fewer points than the even.

    Either is used only when it has fewer points than the two grids together. Each mode's step
    within its core is never coarser than its own grid's: in the graded grid the coarser mode
    sees the finer step inside the finer core and its own outside it.
    """
    f, steps = np.asarray(f, dtype=float), np.asarray(steps, dtype=float)
    lo, hi = f - steps * np.asarray(counts), f + steps * np.asarray(counts)
    step = float(np.min(steps))
    if lo[1] > hi[0] + step or not step > 0:
        return None
    start, stop = float(np.min(lo)), float(np.max(hi))
    n = math.ceil((stop - start) / step - 1e-9)
    centre = 0.5 * (start + stop)
    best = centre + step * (np.arange(n + 1) - n / 2)
    fine = int(np.argmin(steps))
    coarse = float(steps[1 - fine])
    below = math.ceil((lo[fine] - start) / coarse - 1e-9)
    above = math.ceil((stop - hi[fine]) / coarse - 1e-9)
    if graded and below + above + 2 * counts[fine] + 1 < best.size:
        inner = f[fine] + step * np.arange(-counts[fine], counts[fine] + 1)
        outer = [
            lo[fine] - coarse * np.arange(below, 0, -1),
            hi[fine] + coarse * np.arange(1, above + 1),
        ]
        best = np.concatenate([outer[0], inner, outer[1]])
    if best.size >= sum(2 * k + 1 for k in counts):
        return None
    return best


def mode_grid(
    guess: ModeGuess,
    plan: SweepPlan,
    resolve: bool = False,
    fine: bool = False,
    finest_hz: float | None = None,
    cost_s: Callable[[int], float] | None = None,
    fewest: tuple[int, float] = (MIN_POINTS, MAX_HALF_POINTS),
) -> np.ndarray:
    """The points of a sweep around two modes whose frequencies are (roughly) known.

    Of the grids of the shapes of :data:`SHAPES` (:func:`shaped_grid`), each of which resolves
    every mode as the evidence asks, the cheapest on the bench clock (``cost_s(points)``; without
    it, its acquisitions with ``plan.tones``); of equally cheap ones, the one whose points tell
    the most about the split per second (:func:`~sysid_core.measure.information.split_information`;
    the first of :data:`SHAPES` on a tie). ``fewest``: the floor of points, the most a mode's side.
    """
    grids = [shaped_grid(guess, plan, resolve, fine, finest_hz, shape, fewest) for shape in SHAPES]
    costs = [sweep_cost(g.size, plan.tones, cost_s) for g in grids]
    cheapest: list[np.ndarray] = []  # the cheapest grids, each once, in the order of SHAPES
    for g, cost in zip(grids, costs, strict=True):
        if cost == min(costs) and not any(np.array_equal(g, c) for c in cheapest):
            cheapest.append(g)
    if len(cheapest) == 1:
        return cheapest[0]
    f, bw, sigma = guess.frequencies_hz, guess.bandwidth_hz, guess.uncertainty_hz
    info = [split_information(g, f, bw, sigma) for g in cheapest]
    return cheapest[int(np.argmax(info))]  # equal cost: the most per second; the first on a tie


def shaped_grid(
    guess: ModeGuess,
    plan: SweepPlan,
    resolve: bool = False,
    fine: bool = False,
    finest_hz: float | None = None,
    shape: GridShape = GridShape(),
    fewest: tuple[int, float] = (MIN_POINTS, MAX_HALF_POINTS),
) -> np.ndarray:
    """The mode grid of one shape (``fewest``: as :func:`mode_grid`).

    Around each mode ``±h`` with ``h = shape.core·bw + 2σ``, at a step of
    ``bw / POINTS_PER_BANDWIDTH`` or ``h / MAX_HALF_POINTS``, whichever is coarser; then the
    ``shape.anchors`` far points of :func:`anchors`. Everything inside the plan's band, widened
    to hold the modes and their far points where they lie outside it
    (:meth:`~sysid_core.measure.sweeps.SweepPlan.following`); never fewer than ``MIN_POINTS``,
    or :func:`~sysid_core.measure.sweeps.fewest_points` where whole acquisitions hold fewer (8
    with eight tones; the grid is made denser by a quarter octave at a time until there are,
    :data:`DENSER_STEPS`: modes at the band's edge, far points merged).

    With a device that measures several tones per acquisition (``plan.tones > 1``) the grid
    is fitted to whole acquisitions: when a few points (at most half the anchors) would spill
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
    plan = following(plan, guess, shape.core)
    # the floor, or fewer where whole acquisitions hold fewer (8 with eight tones); never more:
    # a grid one point short of two tones' 12 would be made denser for a point that is free
    fewest_n = min(fewest[0], fewest_points(plan.tones, fewest[0]))
    points = np.linspace(*plan.band_hz, fewest_n)
    for k in range(DENSER_STEPS + 1):  # denser by 2^(1/4) at a time, at most 64 times
        dense = 2.0 ** (k / 4)
        points_per_bw, max_half = POINTS_PER_BANDWIDTH * dense, fewest[1] * dense
        candidate = _mode_points(guess, plan, points_per_bw, max_half, shape)
        if candidate.size >= fewest_n:
            points = candidate
            break
    else:
        return points
    bw, half = guess.bandwidth_hz, guess.core_half_widths(shape.core)
    step = np.maximum(bw / points_per_bw, half / max_half)
    target = np.minimum(RESOLVED_STEP * bw, np.inf if finest_hz is None else finest_hz)
    if fine and np.any(step > target):
        needed = math.ceil(float(np.max(half / target)) - 1e-9)
        per_bw = max(points_per_bw, float(np.max(bw / target)))
        return _mode_points(guess, plan, per_bw, min(needed, MAX_FINE_HALF_POINTS), shape)
    if plan.tones <= 1:
        return points
    if resolve and np.any(step > RESOLVED_STEP * bw):
        # too coarse to resolve the modes: a finer grid if one more acquisition pays for it
        needed = math.ceil(float(np.max(half / (RESOLVED_STEP * bw))) - 1e-9)
        budget = tone_budget(points.size, plan.tones, extra=1)
        # counted before they are made: a model's mode of a far too narrow bandwidth would
        # ask for hundreds of millions (seen: 5e8 points of a 2 kHz gyro's window)
        if 2 * max(_core_steps(guess, points_per_bw, needed, shape.core)[1]) + 1 > budget:
            return points
        finer = _mode_points(guess, plan, points_per_bw, needed, shape)
        return finer if finer.size <= budget else points
    spill = points.size % plan.tones
    if points.size - spill >= fewest_n and 0 < spill <= shape.anchors // 2:
        # a few points spill into one more acquisition: drop that many of the nearer anchors
        near = _nearer_anchors(points, guess, shape.core)[:spill]
        points = np.setdiff1d(points, near)
    return points


def _nearer_anchors(points: np.ndarray, guess: ModeGuess, core: float) -> np.ndarray:
    """The anchors of ``points`` (those outside the modes' cores), nearest to a mode first."""
    f, half = guess.frequencies_hz, guess.core_half_widths(core)
    distance = np.min(np.abs(points[:, None] - f[None, :]) - half[None, :], axis=1)
    outside = distance > 1e-9
    order = np.argsort(distance[outside])
    return points[outside][order]


def tone_budget(n_points: int, tones: int, extra: int = 0) -> int:
    """The points ``n_points`` take in whole acquisitions of ``tones``, plus ``extra`` more.

    What a sweep may use at the same (or a little more) bench time.
    """
    return (acquisitions(n_points, tones) + int(extra)) * max(int(tones), 1)
