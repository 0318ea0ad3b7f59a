"""Windows around the modes that a failed whole-band sweep placed roughly.

A lean run locates the modes with one whole-band sweep of at most ``locate_points`` points.
Narrow modes sit between its points: a 1.49 kHz gyro (bandwidths 0.045 and 0.075 Hz,
60 dB SNR) on a 100 Hz band has a point every 1.66 Hz, 37 bandwidths. The sweep's fit
then fails the evidence (relative response error 1.0, limit 0.35), although its modes are
within half a step of the truth (1485.95 and 1490.25 Hz; true 1485.99 and 1490.74), and the
band swept four times as densely (200 points there) failed too (0.8): an equation-error fit of
points that only see the modes' tails does not reproduce them.

So a whole-band sweep that fails is followed first by :func:`zoom_grid`: around each mode it
fitted, ``± (half its step + 2 bandwidths)`` at most
:data:`~sysid_core.measure.lean.MAX_FINE_HALF_POINTS` points on either side
(:func:`~sysid_core.measure.lean.mode_grid` with ``fine``), where every mode has points within a
few bandwidths. On the slow gyro above (the case of tests/measure/test_zoom.py) the first
iteration then measures 54 points there instead of 200 + 200.
"""

from __future__ import annotations

import numpy as np

from sysid_core.measure.evidence import WindowAssessment
from sysid_core.measure.lean import ModeGuess, mode_grid
from sysid_core.measure.sweeps import SweepPlan

__all__ = ["ZOOM_SHARE", "zoom_grid"]

#: A failed sweep is zoomed only if it covered at least this share of the band.
ZOOM_SHARE = 0.8


def zoom_grid(
    swept_hz: np.ndarray, evidence: WindowAssessment, plan: SweepPlan, limit: int
) -> np.ndarray | None:
    """Windows around the modes a failed whole-band sweep fitted, or None.

    Parameters
    ----------
    swept_hz : ndarray
        The failed sweep's frequencies.
    evidence : WindowAssessment
        Its evidence (the fitted modes and bandwidths, the sweep's step).
    plan : SweepPlan
        The run's plan (its band).
    limit : int
        The windows are measured only with fewer points than this (the next fallback's).

    Returns
    -------
    ndarray or None
        The frequencies; None when the sweep did not cover the band (at least
        :data:`ZOOM_SHARE` of it), the fitted modes are not inside the band, or the windows
        would take ``limit`` points or more.
    """
    lo, hi = plan.band_hz
    swept = np.asarray(swept_hz, dtype=float)
    if swept.size < 2 or float(np.ptp(swept)) < ZOOM_SHARE * (hi - lo):
        return None
    f = np.asarray(evidence.frequencies_hz, dtype=float)
    if f.size != 2 or not np.all(np.isfinite(f) & (f > lo) & (f < hi)):
        return None
    bw = np.asarray(evidence.bandwidth_hz, dtype=float)
    bw = np.where(np.isfinite(bw) & (bw > 0), bw, plan.resolution_hz)
    points = mode_grid(ModeGuess.of(f, bw, evidence.step_hz / 2), plan, fine=True)
    return points if points.size < limit else None
