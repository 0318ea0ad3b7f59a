"""What a verification can claim: a split it resolves, and one the drift leaves alone.

A verification measures the split with one window; the split counts as under the acceptance only
when the measurement can tell, and only as long as the drift leaves it there.

On a tracked run (a bench with a clock) one goal says so (:data:`END_GOAL`): the split at the
end of the latest window, as the windows' filter predicts it
(:meth:`~sysid_core.drift.tracker.Tracker.end_split`, docs/drift-model.md), is under the
acceptance (times ``[tuning] aim`` if set) at 95 %: the Rice distribution's 95 % point of the
predicted vector's length. It holds the window's noise, what the model misses and the drift
from the window's middle to its end. Without that forecast (no clock, or a latest window that
gives no split of its own) two goals stand for it, and join the criterion's
(:func:`honest_goals`):

* ``split 95 % upper bound`` <= :data:`RESOLVE_FACTOR` × acceptance: the upper end of the
  split's 95 % interval from the window's fit
  (:func:`~sysid_core.tuning.confidence.split_interval`). Near degenerate modes whose
  bandwidths are a thousand times the acceptance, one window cannot tell 1 mHz from 10 mHz
  (measured on random gyros at 18 kHz: 1.3 mHz measured, 9.4 mHz true, interval 0-21 mHz); the
  run then goes on instead of claiming convergence.
* ``split at the end (drift)`` <= acceptance: when the model carries a stiffness trend in time
  (a tracked run's moved model: the split's rate its windows estimate,
  :func:`sysid_core.drift.forecast.with_split_rate`), the
  measured split plus what the split's drift can add
  between the middle of the window and its end (the run's end). :func:`holds_s` says how long
  the tuning stays under the acceptance at that rate. When that drift alone, over the half
  window, moves the split by the acceptance or more and every other goal is met, no later
  verification on this bench can meet the goal: the run stops there, not converged
  (:func:`outpaced`; a 2.1 kHz gyro in the uncontrolled lab: measured 0.30 mHz, drift term
  2.17 mHz, and the four iterations it went on drifted it to 8.1 mHz).

A tracked run whose last window (the cap's or the budget's) leaves the goal unmet says whether
the bench set a floor (:func:`floored`): when even a perfect answer could not have been shown
under the acceptance by the windows measured, the windows' noise and the drift, not the answer,
limit the run; it says how well each window measures the split, how fast the split moves, and
how many more windows like these would show the acceptance (a 22 kHz gyro of bandwidths 0.37
and 2.2 Hz at 60 dB: each 16-point window measures its split to about ±9 mHz at 95 %).

A third applies on a drifting bench without the forecast: ``split, aiming at X of the
acceptance`` <= ``aim`` × acceptance (:func:`aim_fraction`; ``[tuning] aim``, by default
:data:`DRIFTING_AIM` when the run tracks the drift, else 1). A split measured just under the
acceptance in the uncontrolled lab ends over it: the window's noise and the drift while it is
measured add 0.2-0.9 mHz (six of 72 random gyros converged at 1.1-1.9 mHz and ended at
2.0-2.8 mHz, acceptance 2 mHz); aiming at half the acceptance costs an iteration where it
matters (docs/drift.md).

A fourth joins them when all are met (:func:`twin_goal`): the structure on the other side
(``sen`` for ``act`` and back) fits the converging window. If it fits it
:data:`TWIN_FACTOR` times better, the configured structure misses the gyro's dynamics, and its
split is biased beyond the noise's interval (measured: a gyro with input dynamics, fitted
with ``act`` in a quiet bench: measured 1.96 mHz, upper bound 3.3 mHz, true
split 10.4 mHz; ``sen`` fits that window 16 times better and measures 12.7 mHz); the run then
counts the twin's split, ``split by the sen structure``, against the bound's limit. Both
structures are fitted plainly (not refitted with weights) so that their residuals compare.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np

from sysid_core.drift.tracker import Tracker
from sysid_core.drift.windows import to_end_s
from sysid_core.identification.drift import offset_drift
from sysid_core.measure.fitter import Fitter
from sysid_core.measure.verification import Verification
from sysid_core.model.fitted import FittedModel
from sysid_core.tuning.confidence import split_interval
from sysid_core.tuning.criteria import Goal, TuningCriterion
from sysid_core.verdict.dacfloor import budget_drift_hz, dac_floor, dac_reached, split_estimate

__all__ = [
    "BLIND",
    "DRIFTING_AIM",
    "DRIFT_GOAL",
    "END_GOAL",
    "RESOLVE_FACTOR",
    "TWIN_FACTOR",
    "WINDOWS_SEARCHED",
    "aim_fraction",
    "blind",
    "floored",
    "holds_s",
    "honest_goals",
    "outpaced",
    "split_rate_hz_per_s",
    "sweep_to_end_s",
    "twin_goal",
    "verdict",
]

#: The goal that a drifting split holds until the run's end.
DRIFT_GOAL = "split at the end (drift)"

#: A verified split counts only when its 95 % upper bound is under this many acceptances.
RESOLVE_FACTOR = 2.0
#: How many more windows :func:`floored` looks through for the number that would show a tuning.
WINDOWS_SEARCHED = 10_000
#: Verifications in a row that showed no modes stop a run (:func:`blind`).
BLIND = 2
#: A run that tracks the drift stops at a verified split under this fraction of the acceptance.
DRIFTING_AIM = 0.5
#: The twin structure fits a window this many times better (residual sum of squares): the
#: configured one misses the gyro's dynamics. With each gyro's own structure the two fit
#: within 1.5 times of each other in the uncontrolled lab (120 windows of random gyros
#: 101-124) and within 2.8 times on quiet and good benches (137 windows).
TWIN_FACTOR = 4.0


def split_rate_hz_per_s(model: FittedModel) -> float | None:
    """How fast the split can move (Hz/s) by the model's stiffness trend, or None without one."""
    if model.facts.trend_per_s is None:
        return None
    seen = offset_drift(model)
    return None if seen is None else seen.split_hz_per_h / 3600.0


def sweep_to_end_s(ver: Verification) -> float:
    """From the time the verification's last sweep measured the split to its end (s), or 0.

    Half the sweep for one measured in frequency order; less for a window measured least
    informative point first (:func:`~sysid_core.drift.windows.to_end_s`).
    """
    return to_end_s(ver.sweep, ver.model)


def holds_s(split_hz: float, acceptance_hz: float, rate_hz_per_s: float | None) -> float | None:
    """Seconds until a split drifting at ``rate`` leaves the acceptance (None: no rate known)."""
    if rate_hz_per_s is None:
        return None
    if rate_hz_per_s <= 0:
        return float("inf")
    return max(acceptance_hz - split_hz, 0.0) / rate_hz_per_s


def aim_fraction(configured: float | None, tracking: bool) -> float:
    """The fraction of the acceptance a verified split must reach before a run stops.

    ``configured`` (``[tuning] aim``) if given, else :data:`DRIFTING_AIM` for a run that tracks
    the drift, else 1.
    """
    if configured is not None:
        return float(configured)
    return DRIFTING_AIM if tracking else 1.0


#: The goal of a tracked run: the split at the end, by the windows' forecast, at 95 %.
END_GOAL = "split at the end, 95 % by the windows' forecast"


def honest_goals(
    ver: Verification,
    model: FittedModel,
    acceptance_hz: float,
    aim: float = 1.0,
    end: tuple[float, float] | None = None,
) -> list[Goal]:
    """The goals that keep a verified split honest (see the module); [] if not verified.

    ``aim`` (:func:`aim_fraction`) below 1 adds the split's goal at ``aim × acceptance_hz``.
    ``end``: the 95 % bound and mean of the split at the end of the window by the tracked
    windows' forecast (:meth:`~sysid_core.drift.tracker.Tracker.end_split`); with it, one goal,
    that bound under ``aim × acceptance_hz``, stands for the aim and the window's own bound.
    """
    if not ver.verified or ver.split_hz is None:
        return []
    goals = []
    if end is not None:
        goals.append(Goal(END_GOAL, end[0], aim * acceptance_hz))
        aim, end_only = 1.0, True
    else:
        end_only = False
    if aim < 1.0:
        goals.append(
            Goal(f"split, aiming at {aim:g} of the acceptance", ver.split_hz, aim * acceptance_hz)
        )
    interval = None if end_only else split_interval(ver.model)
    if interval is not None:
        goals.append(Goal("split 95 % upper bound", interval[1], RESOLVE_FACTOR * acceptance_hz))
    rate = split_rate_hz_per_s(model)
    if rate is not None:
        goals.append(Goal(DRIFT_GOAL, ver.split_hz + rate * sweep_to_end_s(ver), acceptance_hz))
    return goals


def outpaced(
    goals: list[Goal], split_hz: float, acceptance_hz: float, half_s: float = 0.0
) -> str | None:
    """Why no later verification can meet the goals on this bench, or None.

    Every goal is met but the drift's (:data:`DRIFT_GOAL`), and the drift alone moves the split
    (measured ``split_hz``) by ``acceptance_hz`` or more over half a window (``half_s``
    seconds, when known, say how long the split stays under the acceptance).
    """
    drift = next((g for g in goals if g.name == DRIFT_GOAL), None)
    others = [g for g in goals if g is not drift and g.name != END_GOAL]  # END holds the drift
    if drift is None or drift.met or any(not g.met for g in others):
        return None
    moves = drift.value_hz - split_hz
    if moves < acceptance_hz:
        return None
    held = holds_s(split_hz, acceptance_hz, moves / half_s) if half_s > 0 else None
    holds = (
        ""
        if held is None
        else f"; it moves {moves / half_s * 6e4:.3g} mHz/min and holds about {held / 60:.2g} min"
    )
    return (
        f"the drift outruns the verification: the split drifts {moves * 1e3:.3g} mHz in half a "
        f"window, more than the acceptance {acceptance_hz * 1e3:.3g} mHz, so no verification on "
        f"this bench can show it holding; the run stops at this bias (measured split "
        f"{split_hz * 1e3:.3g} mHz{holds})"
    )


def floored(
    tracker: Tracker, afford: tuple[int, float], limit_hz: float, end: tuple[float, float]
) -> str | None:
    """Why the run's last window could not show a tuning at any answer, or None.

    ``afford``: how many more windows the budget and the cap leave, and the seconds from one to
    the next; ``limit_hz``: the goal's (the acceptance times the aim); ``end``: the split at the
    end of the latest window by the forecast (its 95 % bound and mean). A reason only at the
    run's last window (none left) whose goal is not met, when even a perfect answer would not
    have met it (:meth:`~sysid_core.drift.tracker.Tracker.floor` over ``limit_hz``): the noise
    of the windows and the drift, not the answer, set the floor. It says how many more windows
    like these would show ``limit_hz`` (:meth:`~sysid_core.drift.tracker.Tracker.windows_to`).
    """
    windows, every_s = afford
    best = tracker.floor(0, every_s)
    found = tracker.at_end
    if windows > 0 or best is None or found is None or best <= limit_hz or end[0] <= limit_hz:
        return None
    window = 1.96 * float(np.sqrt(found.own_variance_hz2))
    moving = float(np.hypot(*found.rate_hz_per_s)) * 6e4
    spread = 1.96 * float(np.sqrt(found.rate_variance)) * 6e4
    needed = tracker.windows_to(limit_hz, every_s, WINDOWS_SEARCHED)
    more = (
        f"no number of windows up to {WINDOWS_SEARCHED} would show it under {limit_hz * 1e3:.3g} "
        "mHz"
        if needed is None
        else f"about {needed} more windows like these ({needed * every_s / 60:.3g} min of bench "
        f"time) would show it under {limit_hz * 1e3:.3g} mHz"
    )
    return (
        f"the bench sets a floor: each window measures the split to ±{window * 1e3:.2g} mHz "
        f"(95 %) and the windows see it moving {moving:.2g} ± {spread:.2g} mHz/min, so even a "
        f"perfect answer could be shown at best under {best * 1e3:.3g} mHz at 95 %; {more} "
        f"(the split at the end is {end[1] * 1e3:.3g} mHz by the forecast)"
    )


def verdict(
    ver: Verification,
    model: FittedModel,
    criterion: TuningCriterion,
    fitter: Fitter,
    acceptance_hz: float,
    aim: float | None = None,
    tracker: Tracker | None = None,
    afford: tuple[int, float] | None = None,
    failed_before: int = 0,
    dac: tuple[Sequence[float] | None, np.ndarray, Mapping[str, Any]] | None = None,
) -> tuple[list[Goal], bool, str | None]:
    """A verification's goals, whether the run converged, and why it stops unconverged (or None).

    The criterion's goals and :func:`honest_goals` for ``model``, the iteration's: with the
    ``tracker``'s forecast of the split at the window's end, when it has one, that forecast at
    ``aim`` (``[tuning] aim``, 1 unset) times the acceptance; else the window's own goals at
    :func:`aim_fraction`. If they are all met, the :func:`twin_goal` too; if only the drift's
    is not, :func:`outpaced`; with the forecast and ``afford`` (the windows the run can still
    measure and the seconds between them), :func:`floored`. A verification that showed no modes
    stops the run when the ``failed_before`` ones just before it showed none either
    (:func:`blind`). ``dac``: the bias verified just before (None: none), this one and its
    answer's ``info``: a run whose answer is the code it verified just before, where the DAC
    limits it (:func:`~sysid_core.verdict.dacfloor.dac_floor`) short of the goal, stops there
    (:func:`dac_reached`).
    """
    if not ver.verified or ver.frequencies_hz is None or ver.split_hz is None:
        return [], False, blind(ver, failed_before)
    goals = criterion.goals(ver.frequencies_hz, acceptance_hz)
    end = None if tracker is None else tracker.end_split(model, ver.sweep)
    tracking = tracker is not None and bool(tracker.windows)
    fraction = (1.0 if aim is None else float(aim)) if end else aim_fraction(aim, tracking)
    goals += honest_goals(ver, model, acceptance_hz, fraction, end)
    converged = all(g.met for g in goals)
    if converged and (twin := twin_goal(ver, fitter, acceptance_hz)):
        goals.append(twin)
        converged = twin.met
    stop = None if converged else outpaced(goals, ver.split_hz, acceptance_hz, sweep_to_end_s(ver))
    if not converged and stop is None and dac is not None:
        previous, bias, info = dac
        again = previous is not None and np.array_equal(np.asarray(previous), bias)
        floor = dac_floor(info, acceptance_hz) if again else None
        if floor is not None:  # the windows' estimate and the drift only where they can decide
            split, moves = split_estimate(ver, end, tracker), budget_drift_hz(tracker, end, afford)
            stop = dac_reached(again, floor, fraction * acceptance_hz, split, moves)
    if not converged and stop is None and end is not None and tracker and afford is not None:
        stop = floored(tracker, afford, fraction * acceptance_hz, end)
    return goals, converged, stop


def blind(ver: Verification, failed_before: int) -> str | None:
    """Why the run stops when its verifications keep showing no modes, else None.

    A verification that finds no modes (the window, then the band located down to its
    resolution where the run locates: :func:`~sysid_core.measure.verification.verify`) adds no
    modes to the model, so the next answer lands where this one did, and its verification
    fails alike. The second failure in a row shows it: the run stops there instead of
    repeating it until its budget is spent. One failure alone does not stop a run: on a
    drifting bench the next answer may land where the modes show again
    (docs/studies/dwells.md, "A verification that sees no modes").
    """
    if ver.status != "failed" or failed_before + 1 < BLIND:
        return None
    return (
        f"{failed_before + 1} verifications in a row showed no modes "
        f"({ver.windows[-1].failures()}): the model's answers land where this bench does not "
        "show the modes, and the next would land there again; the run stops at its last "
        "answer. Start at a bias where the modes were seen ([tuning] start_bias), or measure "
        "with more signal (a larger drive, more averaging)"
    )


def twin_goal(ver: Verification, fitter: Fitter, acceptance_hz: float) -> Goal | None:
    """The twin structure's split of a verified window, if the twin fits it much better.

    None when the run has no twin structure, the window is not verified, or the twin fits
    it less than :data:`TWIN_FACTOR` times better (module docstring).
    """
    if not ver.verified:
        return None
    found = fitter.twin(ver.sweep)
    if found is None or found[0] < TWIN_FACTOR:
        return None
    assert fitter.twin_structure is not None  # found implies a twin
    better, split = found
    name = (
        f"split by the {fitter.twin_structure.name} structure, which fits the window "
        f"{better:.3g} times better"
    )
    return Goal(name, split, RESOLVE_FACTOR * acceptance_hz)
