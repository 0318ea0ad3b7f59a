"""A whole-band sweep's fit: the plain fit or the one weighted as the noise enters, the closer.

Truth: random gyros' modal frequencies at the sweep's bias (``true_modal_frequencies_hz``).
Random gyro 226 (9.8 kHz, bandwidths 0.14 and 0.22 Hz) swept over its band at 0.5 Hz, with
the noise of 60 dB shared by 8 tones (``√8 · 1e-3`` of the peak): the plain (equation-error)
fit places a mode 0.2 Hz off and misses the peaks by 0.8 of the response, so the evidence
refused the sweep and a run fell back to ever denser band sweeps (1.7 h of bench clock).
"""

from __future__ import annotations

import numpy as np
import pytest

from sysid_core.identification.fitting import fit_structure
from sysid_core.measure.evidence import BAND_FIT_TOLERANCE, response_error
from tests.truths import random_gyro_sweep

#: 60 dB, the drive shared by 8 tones.
EIGHT_TONES = np.sqrt(8.0) * 1e-3


def _band(seed: int, noise_seed: int, step_hz: float = 0.5):  # type: ignore[no-untyped-def]
    def over_the_band(device, bias):  # type: ignore[no-untyped-def]
        lo, hi = device.band_hz
        return np.arange(lo, hi, step_hz)

    return random_gyro_sweep(seed, EIGHT_TONES, noise_seed, over_the_band, b1=1.0)


@pytest.mark.parametrize("noise_seed", [1, 2, 3])
def test_a_band_of_high_q_modes_locates_them(noise_seed: int) -> None:
    device, bias, sweep, fitter = _band(226, noise_seed)
    truth = device.true_modal_frequencies_hz(bias)
    plain, _ = fit_structure(
        sweep.isel(electrode=[]), fitter.structure, fitter.objective, fitter.solver
    )
    _, evidence = fitter.window(sweep, band=True)
    bandwidth = np.asarray(evidence.bandwidth_hz)
    assert evidence.ok, evidence.failures()
    # within a fifth of a bandwidth: a window placed around them holds them
    assert np.all(np.abs(np.sort(evidence.frequencies_hz) - truth) < 0.2 * bandwidth)
    # what the plain fit alone gives on this case: refused
    assert response_error(sweep, plain) > BAND_FIT_TOLERANCE


@pytest.mark.parametrize("seed", [203, 208, 213])
def test_a_band_whose_plain_fit_shows_both_modes_keeps_it(seed: int) -> None:
    _, _, sweep, fitter = _band(seed, 1, step_hz=2.0)
    single = sweep.isel(electrode=[])
    plain, _ = fit_structure(single, fitter.structure, fitter.objective, fitter.solver)
    model, evidence = fitter.window(sweep, band=True)
    assert evidence.ok, evidence.failures()
    assert model.meta.get("z_weighted_refits") is None
    assert response_error(sweep, model) == pytest.approx(response_error(sweep, plain), rel=1e-9)
