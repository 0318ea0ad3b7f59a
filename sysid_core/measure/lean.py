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
* otherwise a **mode grid** (:mod:`sysid_core.measure.modegrid`): around each predicted mode a
  core of a bandwidth or two widened by the prediction's uncertainty, plus a few far points,
  of the shape whose points tell the most about the split per second of bench clock.

A sweep whose evidence (:func:`sysid_core.measure.evidence.assess_window`) does not show both
modes is followed by the whole band at the same bias, so a wrong guess costs points, never a result.

On a bench with a clock the modes move while the run measures them. A verification window
around the predicted modes is centred by the latest located modes moved by the model
(:func:`~sysid_core.measure.motion.recentred`) when the answer's own region knows their mean
less well (a fit of hours of drifting data); a window around modes the sweep before it has
just found is a fine mode grid whose uncertainty is their motion since.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Callable

import numpy as np

from sysid_core.measure.modegrid import (
    ANCHORS,
    CORE_BANDWIDTHS,
    FINE_STEP,
    MAX_FINE_HALF_POINTS,
    MAX_HALF_POINTS,
    POINTS_PER_BANDWIDTH,
    RESOLVED_STEP,
    ModeGuess,
    anchor_reach,
    following,
    merge,
    mode_grid,
    tone_budget,
)
from sysid_core.measure.sweeps import SweepPlan, acquisition_grid

__all__ = [
    "ANCHORS",
    "CORE_BANDWIDTHS",
    "DENSER",
    "DESIGN_HALF_POINTS",
    "FINE_STEP",
    "LOCAL_RADIUS",
    "LOCATE_POINTS",
    "MAX_FINE_HALF_POINTS",
    "MAX_HALF_POINTS",
    "POINTS_PER_BANDWIDTH",
    "QUIET_SCOUT_POINTS",
    "RESOLVED_STEP",
    "SCOUT_MIN_POINTS",
    "SCOUT_SPLITS",
    "ModeGuess",
    "anchor_reach",
    "denser_plan",
    "explained_gap",
    "following",
    "learning_grids",
    "locate_plan",
    "mode_grid",
    "scout_grid",
    "tone_budget",
]

#: The first electrode stepped may move each mode by about this many splits (a miss costs a
#: whole-band sweep).
SCOUT_SPLITS = 0.5
#: ... and by at least this many bandwidths.
SCOUT_BANDWIDTHS = 10.0
#: Fewest points of a scout. It only has to locate the modes (the evidence a band sweep must
#: show, at the locating step), and its one-bias fit has 25 unknowns in 8 real equations a point;
#: 8 points, one acquisition of an eight-tone lock-in, are what every eight-tone run's scouts
#: have held. With one tone, 8 instead of ``MIN_POINTS`` (11) saves 3 dwells a scout: 12-15 of
#: the median run on our random gyros (docs/studies/information.md, "Scouts of eight points").
SCOUT_MIN_POINTS = 8
#: ... and on a quiet bench (the probe's noise under
#: :data:`~sysid_core.measure.locating.QUIET_NOISE` of its response): 4 points determine the
#: one-bias fit, 6 leave half again as many equations to average the noise, which on a quiet
#: bench is small against the modes' tails that locate them. With one tone that is 2 dwells less
#: a scout; with eight tones a scout is one acquisition either way. On a noisy bench the few
#: extra equations cannot average the noise away, so scouts keep 8 (the measurements, on both
#: benches: docs/studies/dwells.md, "Scouts of six points on a quiet bench").
QUIET_SCOUT_POINTS = 6
#: A design's sweep around modes a law predicts (:func:`learning_grids`) samples each at its
#: centre and its core's edges, denser only to reach the scouts' floor: the fewest points that
#: show an interior peak, all such a sweep needs (docs/studies/dwells.md, "Design sweeps at the
#: scouts' floor").
DESIGN_HALF_POINTS = 1
#: Most points of a lean run's whole-band sweep (it only locates the modes); ``[experiment]
#: locate_points`` sets it (31: less time, less accurate in the lab:
#: docs/studies/bench-time-lab.md).
LOCATE_POINTS = 61
#: A locating band that does not show both modes is followed by one this many times as dense.
DENSER = 4
#: A model explains a verification when its modes miss the measured ones by at most this
#: fraction of the measured split ...
EXPLAIN_FRACTION = 0.25
#: ... plus this much (Hz).
EXPLAIN_FLOOR_HZ = 1e-4
#: Sweeps within this many bias steps (the iteration's step) of the bias count as near it.
LOCAL_RADIUS = 1.5


def scout_grid(guess: ModeGuess, plan: SweepPlan, quiet: bool = False) -> np.ndarray:
    """Windows that locate modes which may have moved since ``guess`` by an unknown amount.

    Around each mode ``± m`` at the band's resolution, inside the band (widened to hold the
    windows, :meth:`~sysid_core.measure.sweeps.SweepPlan.following`; the band itself when
    the windows would cover most of it): ``m = σ + SCOUT_BANDWIDTHS × bw`` when the guess
    carries an uncertainty ``σ`` (the move expected from the electrodes stepped before),
    else ``max(SCOUT_SPLITS × split, SCOUT_BANDWIDTHS × bw)``; in whole acquisitions
    (:func:`~sysid_core.measure.sweeps.acquisition_grid`), at least :data:`SCOUT_MIN_POINTS`
    (:data:`QUIET_SCOUT_POINTS` on a ``quiet`` bench).
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
    fewest = QUIET_SCOUT_POINTS if quiet else SCOUT_MIN_POINTS
    points = acquisition_grid(windows, plan.resolution_hz, plan.tones, fewest=fewest)
    return merge(points, 1e-9 * float(f.max()))


def learning_grids(
    guess: ModeGuess,
    scout: bool,
    plans: tuple[SweepPlan, SweepPlan],
    quiet: bool = False,
    cost_s: Callable[[int], float] | None = None,
) -> tuple[np.ndarray, np.ndarray | None]:
    """What an identification experiment measures first around ``guess``, and then (or None).

    A scout over ``plans[1]`` (:func:`scout_grid`) where the modes may have moved by an amount
    nothing predicts (``scout``). Around modes a law predicts, the mode grid over ``plans[0]``
    (:func:`~sysid_core.measure.modegrid.mode_grid`) with :data:`DESIGN_HALF_POINTS` points
    on either side of each mode, denser only to reach the scouts' floor
    (:data:`SCOUT_MIN_POINTS`; :data:`QUIET_SCOUT_POINTS` on a ``quiet`` bench): it only has to
    show the modes, as a scout does, and a law carried to the answer gains nothing from a split
    known better than the law's own error; then, if it does not show them, the whole mode grid.
    """
    if scout:
        return scout_grid(guess, plans[1], quiet), None
    least = QUIET_SCOUT_POINTS if quiet else SCOUT_MIN_POINTS
    cheap = mode_grid(guess, plans[0], cost_s=cost_s, fewest=(least, DESIGN_HALF_POINTS))
    return cheap, mode_grid(guess, plans[0], cost_s=cost_s)


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
