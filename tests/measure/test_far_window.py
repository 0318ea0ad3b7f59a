"""A window whose fit has no two resonances is evidence that it shows no modes, not an error.

Truth: random gyro 204's modal frequencies at the sweep's bias (``true_modal_frequencies_hz``).
A model whose law was carried far from its sweeps can place a verification window decades away
from the modes; that window's fit can be overdamped (real poles), which the evidence once passed
to the modal analysis, whose error ended the run. Whether a fit of such a window comes out
overdamped depends on rounding (it does on one BLAS and not on another), so the overdamped model
here is the window's fit with its damping raised to 20 times the critical scale, ``20 ω0 M``.
"""

from __future__ import annotations

import dataclasses
import warnings

import numpy as np

from sysid_core import fit
from sysid_core.data.schema import experiment_from_measurement
from sysid_core.measure.evidence import assess_window
from sysid_core.plugin.registry import get_registry


def test_a_window_whose_fit_is_overdamped_is_not_observed_and_raises_nothing() -> None:
    """Fourteen points from 4 to 170 times the upper mode, fitted; with an overdamped damping
    the fit has no two resonances: the evidence says so in its ``observed`` check, and the
    window does not count as seen, narrow or whole-band."""
    device = get_registry().device("random-gyro", seed=204)
    bias = np.zeros(len(device.electrodes))
    truth = device.true_modal_frequencies_hz(bias)
    freqs = np.geomspace(4 * truth[1], 170 * truth[1], 14)
    sweep = experiment_from_measurement(
        device.measure(bias, freqs), bias, list(device.electrodes), device.structure_potential, "r"
    )
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # the fit's own notes on a window without modes
        fitted = fit(sweep.isel(electrode=[]), structure=device.structure)
    model = dataclasses.replace(fitted, C=20.0 * fitted.omega_center * np.asarray(fitted.M))
    for band in (False, True):
        evidence = assess_window(sweep, model, band=band)
        observed = next(c for c in evidence.checks if c.name == "observed")
        assert not observed.passed
        assert "no two resonances" in observed.detail
        # the modal analysis's own verdict on the model: real poles, no two oscillating modes
        assert "not two stable oscillating modes" in observed.detail
        assert not evidence.seen and not evidence.ok
