"""A verification whose fine window is still too coarse measures a finer one, not the band.

Random gyro 509 in the uncontrolled lab (3.6 kHz, true bandwidths 0.08 Hz, one of them 0.035-0.045
Hz near degenerate modes): its last fine window stepped 0.037 Hz against a refitted bandwidth of
0.0346 Hz, and the run swept the whole band (61 points, 16 minutes) and a window after it, in
which its split drifted from 3.7 to 14.8 mHz. The sweeps here are scripted; what is checked is
the order of the windows and how the second fine one is sized.
"""

from __future__ import annotations

from typing import Any

import numpy as np
import xarray as xr
from sysid_models import ActStructure
from truths import cloverleaf_truth

from sysid_core.measure.evidence import Check, WindowAssessment
from sysid_core.measure.lean import FINE_STEP, ModeGuess, mode_grid
from sysid_core.measure.sweeps import SweepPlan
from sysid_core.measure.verification import Verification, modes_at, verify
from sysid_core.model.fitted import FittedModel
from sysid_core.model.modal import ModalReport
from sysid_core.tuning.criteria import TuningResult

PLAN = SweepPlan((3540.0, 3690.0), 2.5, 6.0, 0.05, 1.0, 0.01, 20_000)
MODES = np.array([3608.840, 3608.842])


def _evidence(
    step: float, bandwidth: float, resolved: bool, band: bool = False
) -> WindowAssessment:
    checks = [Check("fit", True, ""), Check("resolved", resolved, f"step {step} Hz")]
    return WindowAssessment(
        (3600.0, 3615.0), step, band, MODES.copy(), np.array([bandwidth, 0.11]), checks
    )


def _run(script: list[WindowAssessment], windows: list[int]) -> tuple[list[str], Verification]:
    """Verify with scripted sweeps: their file names in order, and the verification."""
    names: list[str] = []
    sizes = iter(windows)

    def sweep(freqs: np.ndarray, name: str, band: bool) -> tuple[xr.Dataset, Any, WindowAssessment]:
        names.append(name)
        return xr.Dataset(), None, script[len(names) - 1]

    def window(center: float, split: float, predicted: bool, seen: np.ndarray | None) -> np.ndarray:
        return np.linspace(center - 1, center + 1, next(sizes))

    modes = ModalReport([0.0, 0.0], MODES, MODES, np.array([45e3, 45e3]), 0.002, 0.0)
    answer = TuningResult(np.zeros(2), np.zeros(2), MODES, 0.0, "degenerate", 0.0)
    return names, verify(modes, answer, PLAN, sweep, lambda line: None, lean=window)


def test_a_second_fine_window_follows_one_still_too_coarse() -> None:
    script = [
        _evidence(0.048, 0.046, False),  # the window around the prediction: coarse
        _evidence(0.037, 0.0346, False),  # the fine one: a refit 7 % narrower than its step
        _evidence(0.025, 0.035, True),  # the second fine one resolves it
    ]
    names, found = _run(script, [18, 26, 34])
    assert names == ["verify.nc", "verify-fine.nc", "verify-fine2.nc"]
    assert found.status == "verified"


def test_no_finer_second_window_means_the_band_as_before() -> None:
    script = [
        _evidence(0.048, 0.046, False),
        _evidence(0.037, 0.0346, False),
        _evidence(2.5, 0.04, True, band=True),  # the whole band locates the modes
        _evidence(0.02, 0.04, True),  # the window around them verifies
    ]
    names, found = _run(script, [18, 26, 26, 30])  # the second fine grid is no finer
    assert names == ["verify.nc", "verify-fine.nc", "verify-band.nc", "verify-2.nc"]
    assert found.status == "verified"


def test_a_fine_grid_resolves_the_narrowest_bandwidth_it_is_given() -> None:
    bw = np.array([0.08, 0.08])
    guess = ModeGuess.of(MODES, bw, 0.03)  # the motion since the last window: 0.03 Hz
    first = mode_grid(guess, PLAN, resolve=True, fine=True)
    finest = FINE_STEP * 0.0346
    second = mode_grid(guess, PLAN, resolve=True, fine=True, finest_hz=finest)
    for grid, limit in ((first, 0.9 * 0.08), (second, finest)):
        near = grid[np.abs(grid - MODES.mean()) <= 0.08 + 1e-9]
        assert np.max(np.diff(near)) <= limit + 1e-9
    assert second.size > first.size


def test_an_answer_where_the_model_has_no_oscillating_modes_sweeps_the_band() -> None:
    """Random gyro 112 at 60 dB (draw 1): a model extrapolated from sweeps that never showed both
    modes answered where its stiffness was not positive definite (predicted modes 0 and 1436 Hz),
    and the run stopped with an error; now the band locates the modes."""
    script = [
        _evidence(2.5, 0.04, True, band=True),  # the band locates the modes
        _evidence(0.02, 0.04, True),  # a window around them verifies
    ]
    names: list[str] = []
    lines: list[str] = []

    def sweep(freqs: np.ndarray, name: str, band: bool) -> tuple[xr.Dataset, Any, WindowAssessment]:
        names.append(name)
        return xr.Dataset(), None, script[len(names) - 1]

    answer = TuningResult(np.zeros(2), np.zeros(2), MODES, 0.0, "degenerate", 0.0)  # "tuned"
    found = verify(None, answer, PLAN, sweep, lines.append)
    assert names == ["verify-band.nc", "verify-2.nc"]
    assert found.status == "verified"
    assert "no oscillating modes" in lines[0]


def test_modes_at_is_none_where_the_stiffness_is_not_positive_definite() -> None:
    truth = cloverleaf_truth()
    kp = np.array(truth.Kp, dtype=float)
    kp[0] = -truth.K0 / 200.0  # B1 softens both modes by K0 / 200 per V² of (v - v_gyro)²
    model = FittedModel(
        structure=ActStructure(2),
        M=truth.M,
        C=truth.C,
        K0=truth.K0,
        Kp=kp,
        poly=np.zeros((3, 2, 2), dtype=complex),
        omega_center=2 * np.pi * 4415.0,
        omega_half=2 * np.pi * 30.0,
        electrodes=list(truth.electrodes),
        structure_potential=truth.structure_potential,
    )
    near = modes_at(model, np.array([9.0, 0.0]))  # (9 - 15.58)² = 43 V²: K0 (1 - 0.22)
    assert near is not None and np.all(near.frequencies_hz > 0)
    assert modes_at(model, np.array([-9.0, 0.0])) is None  # 604 V²: K0 (1 - 3.0)
