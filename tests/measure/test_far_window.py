"""A window far from the modes is evidence that it does not show them, not the end of a run.

Truth: random gyro 204's modal frequencies at the sweep's bias (``true_modal_frequencies_hz``).
A model whose law was carried far from its sweeps can place a verification window decades away
from the modes; that window's fit is overdamped (real poles), which the evidence once passed to
the modal analysis, whose error ended the run.
"""

from __future__ import annotations

import warnings

import numpy as np

from sysid_core import fit
from sysid_core.data.schema import experiment_from_measurement
from sysid_core.measure.evidence import assess_window
from sysid_core.plugin.registry import get_registry


def test_a_window_decades_above_the_modes_is_not_observed_and_raises_nothing() -> None:
    """Fourteen points from 4 to 170 times the upper mode: the fit has no two resonances, the
    evidence says so in its ``observed`` check, and the window does not count as seen."""
    device = get_registry().device("random-gyro", seed=204)
    bias = np.zeros(len(device.electrodes))
    truth = device.true_modal_frequencies_hz(bias)
    freqs = np.geomspace(4 * truth[1], 170 * truth[1], 14)
    sweep = experiment_from_measurement(
        device.measure(bias, freqs), bias, list(device.electrodes), device.structure_potential, "r"
    )
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # the fit's own notes on a window without modes
        model = fit(sweep.isel(electrode=[]), structure=device.structure)
    for band in (False, True):
        evidence = assess_window(sweep, model, band=band)
        observed = next(c for c in evidence.checks if c.name == "observed")
        assert not observed.passed
        assert "no two resonances" in observed.detail
        assert not evidence.seen and not evidence.ok
