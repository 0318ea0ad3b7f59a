"""The evidence's fit check allows a noisy sweep its measured noise, and no more.

Truth: the simulated cloverleaf's modes at the window's bias; the noise is the device's own,
reported per point as ``noise_var`` the way a lock-in does.
"""

from __future__ import annotations

import numpy as np
from sysid_cloverleaf import CloverleafGyro

from sysid_core import fit
from sysid_core.data.schema import experiment_from_measurement
from sysid_core.measure.evidence import FIT_TOLERANCE, NOISE_ALLOWANCE, assess_window

BIAS = np.array([2.0407, 4.3882, 0.0])  # degenerate modes near 4430 Hz


def _window(noise: float) -> tuple:
    device = CloverleafGyro(seed=3, noise=noise)
    f0 = float(np.mean(device.true_modal_frequencies_hz(BIAS)))
    freqs = f0 + np.linspace(-0.4, 0.4, 41)
    sweep = experiment_from_measurement(
        device.measure(BIAS, freqs), BIAS, list(device.electrodes), device.structure_potential, "c"
    )
    return sweep, fit(sweep.isel(electrode=[]), structure="act")


def _fit_check(sweep, model) -> tuple[bool, str]:  # type: ignore[no-untyped-def]
    check = next(c for c in assess_window(sweep, model).checks if c.name == "fit")
    return check.passed, check.detail


def test_a_sweep_noisier_than_the_tolerance_passes_by_its_measured_noise() -> None:
    """At 20 dB the noise alone misses the response by more than 0.2: with its measured
    variance the window still shows its modes; without it the check fails as before."""
    sweep, model = _window(0.1)
    passed, detail = _fit_check(sweep, model)
    assert passed, detail
    assert "measured noise" in detail
    rel = float(detail.split("error ")[1].split(" ")[0])
    assert rel > FIT_TOLERANCE  # the case: the noise, not the model, makes the error
    assert not _fit_check(sweep.drop_vars("noise_var"), model)[0]


def test_the_allowance_is_the_noise_not_a_blank_cheque() -> None:
    """The noisy window against the model of a window 0.2 Hz or more away (a bias step of 0.5 V)
    still fails, and a quiet window keeps the tolerance it had."""
    sweep, _ = _window(0.1)
    device = CloverleafGyro(seed=3, noise=0.1)
    shifted = BIAS + np.array([0.5, 0.0, 0.0])
    f0 = float(np.mean(device.true_modal_frequencies_hz(shifted)))
    assert abs(f0 - float(sweep["frequency"].values.mean())) > 0.2
    other = experiment_from_measurement(
        device.measure(shifted, f0 + np.linspace(-0.4, 0.4, 41)),
        shifted,
        list(device.electrodes),
        device.structure_potential,
        "c",
    )
    wrong = fit(other.isel(electrode=[]), structure="act")
    passed, detail = _fit_check(sweep, wrong)
    assert not passed, detail
    quiet, model = _window(1e-4)
    passed, detail = _fit_check(quiet, model)
    assert passed, detail
    limit = float(detail.split("limit ")[1].split(":")[0])
    assert FIT_TOLERANCE <= limit < FIT_TOLERANCE * (1 + 1e-3)
    assert NOISE_ALLOWANCE > 1.0
