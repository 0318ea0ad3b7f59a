"""Windows around modes that move: a slow gyro's fine window, and the freshest modes as centre.

Truth: random gyro 112 (1.49 kHz, Q about 55 000, bandwidths 0.025 Hz) on a drifting bench
(3 K/h ramp, 0.5 K/√h walk, charging, analyzer wander, 60 dB SNR), whose 18-point window takes
about ten minutes by its clock: the modes move by about a bandwidth meanwhile. Measured in a
tuning run (1.5 K/h, where the walk added the rest) before the motion allowance: a coarse window
found the modes to 2 mHz, the fine window of ``±2`` bandwidths measured ten minutes later
missed the upper one (at 0.5 bandwidth from its edge), and 8 iterations verified nothing
(434 mHz at the end); with it, every iteration from the fourth verified its split (22 mHz at the
end).
"""

from __future__ import annotations

import numpy as np
import pytest
import xarray as xr

from sysid_core.data.schema import experiment_from_measurement, point_times
from sysid_core.measure.evidence import WindowAssessment
from sysid_core.measure.fitter import Fitter
from sysid_core.measure.lean import MAX_FINE_HALF_POINTS, RESOLVED_STEP, ModeGuess, mode_grid
from sysid_core.measure.modegrid import shaped_grid
from sysid_core.measure.motion import (
    MOTION_PPM_PER_H,
    PREDICTION_ERROR,
    motion_allowance,
    recentred,
)
from sysid_core.plugin.registry import get_registry
from sysid_core.run.config import ExperimentConfig
from sysid_core.tuning.confidence import ConfidenceRegion
from sysid_core.tuning.criteria import TuningResult

LAB = {
    "clock": True,
    "seed": 112,
    "temperature_ramp_k_per_h": -3.0,
    "temperature_walk_k_per_sqrt_h": 0.5,
    "charging_v_per_h": 0.015,
    "gain_wander": 0.003,
    "phase_wander_deg": 0.1,
}
BIAS = np.array([-6.1298, 2.0880, 0.0, 0.0, 0.0])


def _region(frequency_ci_hz: tuple[float, float]) -> ConfidenceRegion:
    return ConfidenceRegion(
        level=0.95,
        bias_ci=np.array([[-1.0, 1.0], [-1.0, 1.0]]),
        split_ci_hz=(0.0, 0.02),
        frequency_ci_hz=frequency_ci_hz,
        samples=0,
    )


def _answer(region: ConfidenceRegion) -> TuningResult:
    f = np.array([1797.8, 1797.8])
    return TuningResult(np.zeros(2), np.zeros(2), f, 0.0, "degenerate", 0.0, confidence=region)


def test_the_motion_allowance_scales_with_frequency_and_time() -> None:
    assert motion_allowance(1500.0, None, 30.0) == 0.0  # no clock: nothing moves
    t = np.array([0.0, 600.0])
    expected = MOTION_PPM_PER_H * 1e-6 * 1500.0 * (2 * 600.0 + 30.0) / 3600.0
    assert motion_allowance(1500.0, t, 30.0) == pytest.approx(expected)
    assert motion_allowance(15000.0, t, 30.0) == pytest.approx(10 * expected)


def test_a_fine_grid_resolves_modes_whatever_their_uncertainty() -> None:
    """With ``fine``, the core around each mode has a step of at most RESOLVED_STEP bandwidths."""
    plan = ExperimentConfig().sweep_plan((1400.0, 1600.0))
    bw = np.array([0.025, 0.03])
    for sigma in (0.0, 0.01, 0.03, 0.08):
        guess = ModeGuess.of([1486.7, 1487.15], bw, sigma)
        points = shaped_grid(guess, plan, resolve=True, fine=True)
        half = guess.core_half_widths()
        for f, b, h in zip(guess.frequencies_hz, bw, half, strict=True):
            core = points[np.abs(points - f) <= h * (1 + 1e-9)]
            cap = h / MAX_FINE_HALF_POINTS  # the cap wins only for a wide core
            assert np.max(np.diff(core)) <= max(RESOLVED_STEP * b, cap) * (1 + 1e-9)
            assert core.min() <= f - min(h, MAX_FINE_HALF_POINTS * RESOLVED_STEP * b) + 1e-9
        if sigma == 0.0:  # no motion: the grid of a mode known exactly, as before
            assert points.size == shaped_grid(guess, plan, resolve=True).size


def test_the_freshest_modes_centre_a_window_when_they_know_more() -> None:
    """A fit of hours of drifting data knows the mean frequency to ±2 Hz; the sweep just
    measured knows it to its bandwidth."""
    predicted = _answer(_region((1795.8, 1799.8)))
    centre, sigma = recentred(predicted, moved_hz=0.3, latest_hz=1797.5, age_s=1800.0)
    assert centre == pytest.approx(1797.8)
    motion = MOTION_PPM_PER_H * 1e-6 * 1797.8 * 0.5
    assert sigma == pytest.approx(PREDICTION_ERROR * 0.3 + motion + 0.01)
    # the answer's own centre and uncertainty when they are the narrower
    sure = _answer(_region((1797.79, 1797.81)))
    assert recentred(sure, 0.3, 1797.0, 1800.0) == (pytest.approx(1797.8), pytest.approx(0.02))


def _coarse_then_fine(allow_motion: bool) -> tuple[WindowAssessment, np.ndarray, np.ndarray]:
    """A coarse window around modes known to 0.15 Hz, then a fine one around those it found.

    The fine window's evidence and the true modes at its start and end.
    """
    reg = get_registry()
    device = reg.device("random-gyro", seed=112, noise=1e-3, bench=LAB)
    structure = reg.structure(device.structure)
    fitter = Fitter(structure, reg.objective("least-squares"), reg.solver("clarabel"))
    plan = ExperimentConfig().sweep_plan(device.band_hz)
    names = list(device.electrodes)

    def measure(freqs: np.ndarray) -> tuple[xr.Dataset, WindowAssessment]:
        da = device.measure(BIAS, freqs)
        ds = experiment_from_measurement(da, BIAS, names, device.structure_potential, "random")
        return ds, fitter.window(ds, band=False)[1]

    true0 = device.true_modal_frequencies_hz(BIAS)
    bw = true0 / 55_000.0
    ds, ev = measure(mode_grid(ModeGuess.of(true0 + 0.02, bw, 0.15), plan, resolve=True))
    assert ev.too_coarse(), ev.failures()  # it found both modes, too coarsely to verify them
    found = ev.frequencies_hz
    assert np.max(np.abs(found - device.true_modal_frequencies_hz(BIAS))) < 2 * bw.max()
    assert float(np.ptp(point_times(ds, 0))) > 300  # a slow gyro: minutes per window
    moved = motion_allowance(ev.center_hz, point_times(ds, 0), device.settle_s)
    guess = ModeGuess.of(found, ev.bandwidth_hz, moved if allow_motion else 0.0)
    start = device.true_modal_frequencies_hz(BIAS)
    _, fine = measure(mode_grid(guess, plan, resolve=True, fine=True))
    return fine, start, device.true_modal_frequencies_hz(BIAS)


def test_a_slow_gyros_fine_window_follows_its_moving_modes() -> None:
    """A ramp of 3 K/h moves the modes by 0.02 Hz in the ten minutes of a window, as the
    lab's ramp and walk together did in the run; two identical benches (same seeds)."""
    fine, start, end = _coarse_then_fine(allow_motion=True)
    assert fine.ok, fine.failures()
    # the split the gyro had while the window was measured, give or take the common motion
    # meanwhile (a stepped sweep meets the lower mode before the upper one): 19 mHz here
    lo, hi = sorted([start[1] - start[0], end[1] - end[0]])
    common = abs(float(np.mean(end) - np.mean(start)))
    assert lo - common < fine.split_hz < hi + common
    # without the allowance: a window of ±2 bandwidths misses a mode that moved
    still, _, _ = _coarse_then_fine(allow_motion=False)
    assert not still.ok
    assert "resolved" in still.failures()


def test_the_lab_sets_how_fast_its_modes_may_move() -> None:
    """``[experiment] motion_ppm_per_h`` reaches the plan, and the allowance scales with it."""
    plan = ExperimentConfig(motion_ppm_per_h=6.0).sweep_plan((1400.0, 1600.0))
    assert plan.motion_ppm_per_h == 6.0
    assert ExperimentConfig().sweep_plan((1400.0, 1600.0)).motion_ppm_per_h == MOTION_PPM_PER_H
    t = np.array([0.0, 600.0])
    slow = motion_allowance(1500.0, t, 30.0, plan.motion_ppm_per_h)
    assert slow == pytest.approx(motion_allowance(1500.0, t, 30.0) / 10.0)
    with pytest.raises(ValueError, match="motion_ppm_per_h"):
        ExperimentConfig(motion_ppm_per_h=-1.0)
