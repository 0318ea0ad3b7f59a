"""Whether an answer may be applied: what the run's own measurements support.

A model answers anywhere inside the limits, but its bias law is only measured near the biases
the run swept. Three rules keep the run from stepping where its data do not reach:

* :func:`beyond_tuning` (any criterion): an answer whose model puts a mode more than
  :data:`TUNING_REACH` times outside the band the device states for its modes is the law
  carried where no sweep measured it; the run takes the step the law linearised at the
  iteration's bias asks, no longer than the local design's step.
* :func:`worse_than_measured` (degenerate modes): an answer whose own model predicts, at the
  DAC code that will be applied, a split over :data:`WORSE` times the least one a verification
  of the run measured and over :data:`WORSE_ACCEPTANCES` acceptances is an extrapolation the
  model itself does not believe; the run goes back to that verification's bias and measures
  the local design.
* :func:`untrusted_step` (degenerate modes): once a verification measured a split near
  degenerate modes (under :data:`~sysid_core.drift.tracker.NEAR_ACCEPTANCES` acceptances), or
  one the answer's own 95 % region does not promise to beat (its upper end over the split
  measured), or whenever the model was fitted to the sweeps near the verified bias only (a
  local fit, whose law and region hold only there), the model's law, linearised at the
  verified bias, says how far to go (the Gauss-Newton step: the split vector is smooth in the
  bias there). An answer further than twice that step, and further than the local design
  reaches (``[experiment] bias_step``), is not that correction: another root of the law,
  another point of a whole set of degenerate biases (more electrodes than the two goals
  need), or the law carried where no sweep measured it. The run takes the linearised step
  instead (no longer than ``bias_step``), which the data around the verified bias support,
  and measures the local design there, unless that step itself would cut the split by less
  than :data:`DISAGREED` of it (the linearised law has no way down there: a step that keeps the
  split where it is would be taken again and again). How far it goes is a trust region
  (:func:`trust_radius`): the local design's step at first, twice the last radius after a step
  to its edge whose measured split fell by at least three quarters of what the model predicted
  there, and the local design's step again after one whose split fell by less than a quarter.

And one rule for a model's verdict that the modes cannot meet: :func:`unsure_unreachable`, the
least split the model's 95 % region holds at its best reachable bias. A verdict whose region
reaches under the acceptance is the noise's, not the gyro's: the run measures there.
"""

from __future__ import annotations

import numpy as np

from sysid_core.model.fitted import FittedModel
from sysid_core.model.modal import split_vector_hz
from sysid_core.tuning.confidence import confidence_region
from sysid_core.tuning.criteria import BiasSpace, TuningResult

__all__ = [
    "BEYOND_LINEAR",
    "TUNING_REACH",
    "WORSE",
    "WORSE_ACCEPTANCES",
    "beyond_tuning",
    "linearised_step",
    "trust_radius",
    "unsure_unreachable",
    "untrusted_step",
    "worse_than_measured",
]

#: An answer whose own model predicts at its DAC code more than this many times the least split
#: a verification of the run measured (and more than :data:`WORSE_ACCEPTANCES` acceptances) is
#: not applied: the run goes back to that verification's bias (:func:`worse_than_measured`).
WORSE = 2.0
#: ... and more than this many acceptances.
WORSE_ACCEPTANCES = 10.0
#: No bias moves a mode by this factor of frequency (stiffness by its square): a parallel-plate
#: electrode's negative stiffness reaches 8/27 of the mechanical stiffness at pull-in, which
#: lowers a mode by 16 %, and electrostatic stiffening is of that order or less. A model that
#: puts a mode outside ``[low / TUNING_REACH, high * TUNING_REACH]`` of the device's band
#: (``band_hz``, where the modes lie at the start) has left what any tuning reaches
#: (:func:`beyond_tuning`).
TUNING_REACH = 2.0
#: An answer further from a near verified bias than this many times the linearised step is not
#: the local correction (its curvature term would be as large as the step itself).
BEYOND_LINEAR = 2.0
#: The trust region of the linearised step (:func:`trust_radius`) grows by this factor after a
#: step to its edge whose split fell by at least :data:`AGREED` of the fall its model predicted,
#: and returns to the local design's step after one whose split fell by less than
#: :data:`DISAGREED` of it: the textbook trust-region update (Nocedal & Wright, *Numerical
#: Optimization*, 2nd ed., Algorithm 4.1, with its factors 2, 3/4 and 1/4).
GROW = 2.0
AGREED = 0.75
DISAGREED = 0.25
#: A step whose largest change is this share of the radius or more went to its edge: the DAC
#: code a step is applied at moves it by up to a code (under a tenth of the first radius, 0.25 V,
#: for a DAC of 9 bits or more on ±10 V; with coarser codes the radius may not grow).
EDGE = 0.9


def worse_than_measured(
    result: TuningResult,
    criterion_name: str,
    least_measured: tuple[float, np.ndarray] | None,
    acceptance_hz: float | None,
) -> tuple[float, np.ndarray] | None:
    """The least measured split and its bias if ``result`` is predicted worse, else None.

    Degenerate modes only (see the module). An anchored quadratic law can send an answer
    4.7 V beyond any sweep and predict 17.8 Hz there after a verification measured 9.7 mHz.
    """
    if criterion_name != "degenerate" or least_measured is None or acceptance_hz is None:
        return None
    measured, where = least_measured
    predicted = float(result.split_hz)
    if predicted > max(WORSE * measured, WORSE_ACCEPTANCES * acceptance_hz):
        return measured, np.asarray(where, dtype=float)
    return None


def untrusted_step(
    model: FittedModel,
    answer: np.ndarray,
    latest: tuple[float, np.ndarray] | None,
    tuned: list[int],
    acceptance_hz: float,
    bias_step: float,
    near_acceptances: float,
    region_upper_hz: float | None = None,
    local: bool = False,
) -> np.ndarray | None:
    """The linearised step's bias (every electrode), if ``answer`` goes beyond it; else None.

    Parameters
    ----------
    model : FittedModel
        The answer's model (its electrodes are ``tuned``).
    answer : ndarray
        The answer's bias, every electrode.
    latest : (float, ndarray) or None
        The latest verification's measured split (Hz) and its bias (every electrode).
    tuned : list of int
        The positions of the model's electrodes among all.
    acceptance_hz, bias_step, near_acceptances : float
        The acceptance, how far the step may go (V: the trust region's radius,
        :func:`trust_radius`, at first the local design's step) and how many acceptances count
        as near.
    region_upper_hz : float, optional
        The upper end of the split over the answer's 95 % region: over the latest measured
        split, the answer does not promise to improve on it.
    local : bool
        The model was fitted to the sweeps near the latest bias only (the local design): its
        law, and its region, are measured there and nowhere else, so the rule applies at any
        split.
    """
    if latest is None:
        return None
    near = latest[0] <= near_acceptances * acceptance_hz
    unpromising = region_upper_hz is not None and region_upper_hz > latest[0]
    if not (near or unpromising or local):
        return None
    where = np.asarray(latest[1], dtype=float)
    b0 = where[tuned]
    jump = float(np.max(np.abs(np.asarray(answer, dtype=float)[tuned] - b0)))
    if jump <= bias_step:
        return None
    step = linearised_step(model, b0, 1e-3 * bias_step)
    if not np.all(np.isfinite(step)) or jump <= BEYOND_LINEAR * float(np.max(np.abs(step))):
        return None
    now, after = (np.hypot(*split_vector_hz(model.M, model.stiffness(b))) for b in (b0, b0 + step))
    if now - after < DISAGREED * now:  # no way down the law linearised here: no correction
        return None
    # no further than the local design reached
    step *= min(1.0, bias_step / max(float(np.max(np.abs(step))), 1e-300))
    out = where.copy()
    out[tuned] = b0 + step
    return out


def linearised_step(model: FittedModel, b0: np.ndarray, h: float) -> np.ndarray:
    """The Gauss-Newton step (V, the model's electrodes) from ``b0`` toward degenerate modes.

    The split vector's Jacobian by central differences of ``h`` volts; the step is its
    least-squares solution (NaN where the model has no modes near ``b0``).
    """
    s0 = split_vector_hz(model.M, model.stiffness(b0))
    jac = np.empty((2, b0.size))
    for k in range(b0.size):
        e = np.zeros(b0.size)
        e[k] = h
        jac[:, k] = (
            split_vector_hz(model.M, model.stiffness(b0 + e))
            - split_vector_hz(model.M, model.stiffness(b0 - e))
        ) / (2 * h)
    return np.asarray(-np.linalg.lstsq(jac, s0, rcond=None)[0], dtype=float)


def trust_radius(last: dict[str, float] | None, measured_hz: float | None, start: float) -> float:
    """The radius (V) of the next linearised step, from the last one the run took.

    Parameters
    ----------
    last : dict or None
        The ``trust_region`` entry of the latest linearised step's answer: ``radius_v`` (the
        radius it was taken with), ``length_v`` (its largest change), ``from_split_hz`` (the
        split verified where it started) and ``predicted_split_hz`` (its model's split where it
        ended). None: no linearised step yet.
    measured_hz : float or None
        The split then verified where it ended (None: not verified).
    start : float
        The local design's step (V): the first radius, and the radius after a step whose split
        did not fall as predicted.

    Returns
    -------
    float
        ``GROW × radius_v`` after a step to the edge (:data:`EDGE`) whose split fell by at least
        :data:`AGREED` of the predicted fall; ``start`` after one that fell by less than
        :data:`DISAGREED` of it (or rose, or was not verified); else ``radius_v`` (either never
        under ``start``). A run whose model predicts each step well then crosses volts in a few
        steps instead of a quarter volt at a time.
    """
    if last is None:
        return start
    if measured_hz is None or not np.isfinite(measured_hz):
        return start
    promised = last["from_split_hz"] - last["predicted_split_hz"]
    if promised <= 0:
        return start
    ratio = (last["from_split_hz"] - measured_hz) / promised
    if ratio < DISAGREED:
        return start
    grown = ratio >= AGREED and last["length_v"] >= EDGE * last["radius_v"]
    return max(GROW * last["radius_v"] if grown else last["radius_v"], start)


def beyond_tuning(
    model: FittedModel,
    predicted_hz: np.ndarray,
    start: np.ndarray,
    tuned: list[int],
    band_hz: tuple[float, float] | None,
    bias_step: float,
) -> np.ndarray | None:
    """The bias to apply instead of an answer whose modes no tuning reaches.

    The device states the band its modes lie in at the start (``band_hz``); a tuning moves
    them, but by far less than :data:`TUNING_REACH` times in frequency. An answer whose model
    predicts a mode beyond that (or none) carried the law where no sweep measured it: a
    quadratic law chosen on a ±0.25 V design, carried 5 V, can put the modes 70 times higher
    than any sweep measured them. The run takes the step the law linearised at ``start``
    (every electrode) asks instead, no longer than ``bias_step``; if that step is not finite,
    it stays at ``start``. None when the answer's modes are within reach (or the device
    states no band).
    """
    f = np.asarray(predicted_hz, dtype=float)
    if band_hz is None:
        return None
    lo, hi = band_hz[0] / TUNING_REACH, band_hz[1] * TUNING_REACH
    if np.all(np.isfinite(f)) and lo <= f.min() <= f.max() <= hi:
        return None
    out = np.asarray(start, dtype=float).copy()
    step = linearised_step(model, out[tuned], 1e-3 * bias_step)
    if np.all(np.isfinite(step)):
        out[tuned] += step * min(1.0, bias_step / max(float(np.max(np.abs(step))), 1e-300))
    return out


def unsure_unreachable(
    model: FittedModel, best: TuningResult, space: BiasSpace, acceptance_hz: float
) -> float | None:
    """The least split (Hz) of ``model``'s 95 % region at ``best``, if under ``acceptance_hz``.

    ``best`` is the model's answer "go to the best reachable bias" of a degenerate criterion it
    found unreachable. None when the region's least split is over the acceptance (the verdict
    stands at 95 %) or for a model without a covariance. The region
    reaches down to 0 when the ellipse of the normalised stiffness's deviation holds a
    degenerate model (:func:`~sysid_core.tuning.confidence.confidence_region`): then the law's
    uncertainty, not the gyro, keeps the modes apart. A ``quadratic`` law's region is its
    tangent's at ``best`` (:meth:`~sysid_core.model.fitted.FittedModel.linearized`), as an
    answer's is.
    """
    region = confidence_region(model.linearized(best.w), best, space)
    if region is None:
        return None
    least = float(region.split_ci_hz[0])
    return least if least <= acceptance_hz else None
