"""The floor a DAC sets: said at an answer, and where a run stops at the code it verified again.

A DAC applies a bias only to within its step, so near degenerate modes the codes around an
answer may all leave more than the acceptance (:func:`dac_floor` says so). A run whose answer
is the code it has just verified, where the model and the windows' estimate agree that the
split is over the goal, can only measure that code again, and no number of windows is expected
to show the goal there: :func:`dac_reached` stops it, unless the split may drift by the floor's
size in the time the run has left.
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

import numpy as np
from scipy.stats import rice

from sysid_core.drift.looks import rayleigh_point
from sysid_core.drift.tracker import Tracker
from sysid_core.measure.verification import Verification
from sysid_core.tuning.confidence import split_interval

__all__ = [
    "DAC_FLOOR_SHARE",
    "beyond_reach",
    "budget_drift_hz",
    "dac_floor",
    "dac_reached",
    "least_split",
    "split_estimate",
]

#: The DAC's floor is said when its best code near an answer is predicted to leave at least this
#: share of the acceptance.
DAC_FLOOR_SHARE = 0.5


def dac_floor(info: Mapping[str, Any], acceptance_hz: float | None) -> float | None:
    """The split the model predicts at an answer's DAC code, if the DAC limits it, else None.

    ``info``: the answer's ``TuningResult.info`` (or its ``tuning.json``). The DAC limits it
    when the answer was moved to a DAC code (``"dac_code"``), its goal was reachable, and the
    code leaves at least :data:`DAC_FLOOR_SHARE` of ``acceptance_hz``: the codes around the
    answer are too coarse for the acceptance (a 22 kHz gyro, 16 bits: 0.70 mHz
    predicted at the best code, 1.1-1.3 mHz measured, acceptance 1 mHz).
    """
    code = info.get("dac_code")
    if acceptance_hz is None or not code or "unreachable" in info:
        return None
    split = float(code["predicted_split_hz_chosen"])
    return split if split >= DAC_FLOOR_SHARE * acceptance_hz else None


def beyond_reach(info: Mapping[str, Any], acceptance_hz: float | None) -> str | None:
    """Why the answer's model finds the goal beyond what its electrodes can do, or None.

    ``info``: the answer's ``TuningResult.info``. Out of reach inside the limits
    (``"unreachable"``), or the DAC's best code near the answer is predicted to leave more than
    ``acceptance_hz`` (:func:`dac_floor`): two electrodes offer the DAC's codes on a lattice of
    two dimensions, more electrodes a finer one. A run that tunes a pair of its electrodes
    tunes every one from then on (:mod:`sysid_core.measure.pairing`). A code that leaves half
    the acceptance or more (where the run says the DAC limits the answer) is not enough: in an
    uncontrolled lab two 20 kHz gyros whose pair gave way there hovered for 300 iterations
    (docs/studies/dwells.md, "When the pair falls short").
    """
    if "unreachable" in info:
        return "its model finds the goal out of reach inside the limits"
    floor = dac_floor(info, acceptance_hz)
    if floor is None or acceptance_hz is None or floor <= acceptance_hz:
        return None
    return (
        f"its DAC's best code near the answer is predicted to leave {floor * 1e3:.3g} mHz, over "
        f"the acceptance of {acceptance_hz * 1e3:.3g} mHz"
    )


def least_split(
    ver: Verification, end: tuple[float, float] | None, tracker: Tracker | None
) -> float | None:
    """The least split the windows allow at the verified bias, at 95 % (Hz), or None.

    On a tracked run the 5 % point of the forecast's split at the window's end (``end``, its
    bound and mean, with the filter's standard deviation: a Rice distribution); otherwise the
    lower end of the window's own split interval. None where neither is known.
    """
    found = None if tracker is None else tracker.at_end
    if end is not None and found is not None:
        sigma = found.sigma_hz
        return float(rice.ppf(0.05, end[1] / sigma, scale=sigma)) if sigma > 0 else end[1]
    interval = split_interval(ver.model)
    return None if interval is None else float(interval[0])


def split_estimate(
    ver: Verification, end: tuple[float, float] | None, tracker: Tracker | None
) -> float | None:
    """The windows' estimate of the split at the verified bias (Hz), or None.

    On a tracked run the length of the forecast's split vector at the window's end (``end``'s
    mean), less its noise: the filter estimates each component with standard deviation
    ``sigma``, so the squared length of its estimate exceeds the true one's by ``2 sigma**2`` on
    average, and ``sqrt(max(mean**2 - 2 sigma**2, 0))`` is the estimate (0 where the windows
    cannot tell the split from nothing). Otherwise, where windows are judged one by one, the
    lower end of the window's own 95 % split interval (:func:`least_split`).
    """
    found = None if tracker is None else tracker.at_end
    if end is not None and found is not None:
        return float(np.sqrt(max(end[1] ** 2 - 2.0 * found.sigma_hz**2, 0.0)))
    return least_split(ver, end, None)


def budget_drift_hz(
    tracker: Tracker | None, end: tuple[float, float] | None, afford: tuple[int, float] | None
) -> float:
    """How far the split may drift in the time the run has left (Hz); 0 where unknown or unseen.

    The filter's rate at the latest window (its length plus 1.96 standard deviations of a
    component) over the windows ``afford`` leaves (how many, seconds apart), where the windows
    see the split moving: the rate's length over the 95 % point of a rate of nothing
    (:func:`~sysid_core.drift.looks.rayleigh_point`, 2.45 standard deviations of a component).
    A rate the windows cannot tell from none is no reason to wait for the drift: a good lab's
    22 kHz gyro at its floor, its rate 0.28 ± 0.98 mHz/min after five windows, would otherwise
    wait for a drift of 50 mHz in the hour left, and looked at one code 26 times before the
    rate's spread fell under its floor. 0 without a forecast (``end``) or without ``afford``: a
    bench without a clock states no drift.
    """
    found = None if tracker is None or end is None else tracker.at_end
    if found is None or afford is None:
        return 0.0
    windows, every_s = afford
    moving, spread = float(np.hypot(*found.rate_hz_per_s)), float(np.sqrt(found.rate_variance))
    if moving <= rayleigh_point(1) * spread:
        return 0.0
    return (moving + 1.96 * spread) * max(windows, 0) * every_s


def dac_reached(
    repeated: bool,
    floor_hz: float | None,
    limit_hz: float,
    split_hz: float | None,
    drift_hz: float = 0.0,
) -> str | None:
    """Why the run stops at the floor its DAC sets, or None.

    ``repeated``: the answer is the DAC code verified just before, so the model, fitted with that
    window too, still finds no better code, and any later window measures this code again. The
    model predicts that it leaves ``floor_hz`` (:func:`dac_floor`), over the goal's
    ``limit_hz``, and the windows' estimate of the split there (``split_hz``,
    :func:`split_estimate`) is over it too. The run's verdict at this code waits for a bound under
    the goal, and a split over the goal keeps its bound over it however many windows pool: no
    number of them is expected to show the goal, so the run stops instead of looking until a
    window's noise falls low or the budget ends (gyros at 22 kHz with four electrodes, 1.08 mHz
    predicted, acceptance 1 mHz: 26 to 47 looks, 500-900 dwells). Where the windows' estimate is
    under the goal (a fast gyro at 60 dB whose windows cannot tell its split from nothing), the
    run goes on: more windows may show the goal met. So does a run whose split may drift by the
    floor or more in the time it has left (``drift_hz``, :func:`budget_drift_hz`): the best code
    is the one whose split is least, and a drift of the floor's size moves the gyro to another
    code, which may meet the goal (an uncontrolled lab's 27.7 kHz gyro, its split drifting 4
    mHz/min: at one code for a while, 2.6 mHz predicted, it reached 1.6 mHz at another later).
    """
    if not repeated or floor_hz is None or split_hz is None:
        return None
    if floor_hz <= limit_hz or split_hz <= limit_hz or drift_hz >= floor_hz:
        return None
    return (
        f"the DAC sets the floor: the model's best code is the one just verified again, where "
        f"it predicts {floor_hz * 1e3:.3g} mHz and the windows estimate {split_hz * 1e3:.3g} mHz, "
        f"both over the goal of {limit_hz * 1e3:.3g} mHz, so no number of windows is expected "
        "to show the goal there; the run stops at that code"
    )
