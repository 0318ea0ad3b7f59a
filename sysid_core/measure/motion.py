"""Where the modes are now: how far they may have moved since a sweep found them.

A lean run centres its windows on modes it already knows: those a sweep just located, or those
the model predicts at the answer. Neither is exact. A prediction is as sure as the answer's 95 %
region (:func:`predicted_uncertainty`); modes located earlier have moved since, by the model's
predicted move from that sweep's bias to the new one (trusted to :data:`PREDICTION_ERROR` of
it) and, on a bench with a clock, by the drift over the time since (:func:`motion_allowance`,
at ``[experiment] motion_ppm_per_h``). :func:`recentred` takes whichever is surer.
"""

from __future__ import annotations

import numpy as np

from sysid_core.tuning.criteria import TuningResult

__all__ = [
    "MOTION_PPM_PER_H",
    "PREDICTION_ERROR",
    "motion_allowance",
    "predicted_uncertainty",
    "recentred",
]

#: A model's predicted move of the modes is trusted to this fraction of the move.
PREDICTION_ERROR = 0.1
#: How fast the modes may move on a bench with a clock (ppm of their frequency per hour) when
#: ``[experiment] motion_ppm_per_h`` does not say (its default is this one): an uncontrolled
#: lab's 1.5 K/h at -30 ppm/K, plus its random walk over a few minutes.
MOTION_PPM_PER_H = 60.0


def motion_allowance(
    frequency_hz: float,
    times_s: np.ndarray | None,
    settle_s: float,
    ppm_per_h: float = MOTION_PPM_PER_H,
) -> float:
    """How far modes found by a sweep at ``times_s`` may move before a window around them ends.

    ``ppm_per_h`` of ``frequency_hz`` over the sweep's span, the settling and a window
    as long again (Hz); 0 for a sweep without time stamps (a bench without a clock). A 1.5 kHz
    gyro of Q 55 000 moves by about a bandwidth in the ten minutes an 18-point window takes in
    an uncontrolled lab: a window of ``±2`` bandwidths around the modes found just before
    then misses one of them.
    """
    if times_s is None or np.size(times_s) == 0:
        return 0.0
    span_s = 2.0 * float(np.ptp(times_s)) + float(settle_s)
    return ppm_per_h * 1e-6 * abs(float(frequency_hz)) * span_s / 3600.0


def recentred(
    predicted: TuningResult,
    moved_hz: float,
    latest_hz: float,
    age_s: float,
    ppm_per_h: float = MOTION_PPM_PER_H,
) -> tuple[float, float]:
    """Where to centre the window around a prediction, and its uncertainty (Hz).

    The answer's own mean frequency and :func:`predicted_uncertainty`; or, when it is
    smaller, the latest located modes' mean ``latest_hz`` moved by the model's predicted move
    ``moved_hz`` from that sweep's bias to the answer's, uncertain by
    :data:`PREDICTION_ERROR` of the move, the motion a clock's drift allows over ``age_s``
    (``ppm_per_h``) and half the largest split of the answer's region. A fit of
    hours of drifting data knows the modes' mean no better than the drift moved it (on a 1.8
    kHz gyro: ±2 Hz, against bandwidths of 0.025 Hz), while the design measured just
    before knows it to a bandwidth.
    """
    sigma = predicted_uncertainty(predicted)
    region = predicted.confidence
    split = 0.0 if region is None else 0.5 * float(max(region.split_ci_hz))
    center = latest_hz + moved_hz
    fresh = (
        PREDICTION_ERROR * abs(moved_hz)
        + ppm_per_h * 1e-6 * abs(center) * max(age_s, 0.0) / 3600.0
        + (split if np.isfinite(split) else 0.0)
    )
    if np.isfinite(center) and fresh < sigma:
        return float(center), float(fresh)
    return float(predicted.frequency_hz), sigma


def predicted_uncertainty(predicted: TuningResult) -> float:
    """How far the modes at a tuning's bias may be from its prediction (Hz).

    From the answer's confidence region: the half-width of the mean frequency's interval plus
    half the largest split in it; 0 without a region (the window then rests on the modes'
    bandwidths, and the whole band catches a miss).
    """
    region = predicted.confidence
    if region is None:
        return 0.0
    lo, hi = region.frequency_ci_hz
    values = [0.5 * (hi - lo), 0.5 * float(max(region.split_ci_hz))]
    finite = [v for v in values if np.isfinite(v)]
    return float(sum(finite))
