"""The evidence's ``data peak``: a mode stands above the window's edges by more than the noise.

Truth: random gyros' modal frequencies at the sweep's bias (``true_modal_frequencies_hz``).
Gyros 204, 209 and 210 carry feedthrough large enough that their whole band peaks at only
1.4-3 times its edges: a ratio rule refused them and sent their runs to denser sweeps.
"""

from __future__ import annotations

import contextlib

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from sysid_core import fit
from sysid_core.data.schema import experiment_from_measurement, measured_mask
from sysid_core.measure.evidence import assess_window, peak_prominence
from sysid_core.plugin.registry import get_registry

SEEDS = (204, 209, 210)


def _assess(seed: int, where: str):  # type: ignore[no-untyped-def]
    device = get_registry().device("random-gyro", seed=seed)
    bias = np.zeros(len(device.electrodes))
    truth = device.true_modal_frequencies_hz(bias)
    lo, hi = device.band_hz
    freqs = {
        "band": np.linspace(lo, hi, 21),  # a probe of the band
        "above": np.linspace(truth[1] + 0.3 * (hi - truth[1]), hi, 21),
        "below": np.linspace(lo, truth[0] - 0.3 * (truth[0] - lo), 21),
    }[where]
    sweep = experiment_from_measurement(
        device.measure(bias, freqs), bias, list(device.electrodes), device.structure_potential, "r"
    )
    with pytest.warns() if where != "band" else contextlib.nullcontext():
        model = fit(sweep.isel(electrode=[]), structure=device.structure)
    evidence = assess_window(sweep, model, band=True)
    check = next(c for c in evidence.checks if c.name == "data peak")
    sigma = np.linalg.norm(sweep["response"].values[0], ord=2, axis=(-2, -1))
    return evidence, check, truth, float(sigma.max() / max(sigma[0], sigma[-1]))


@pytest.mark.parametrize("seed", SEEDS)
def test_a_band_over_large_feedthrough_shows_its_modes(seed: int) -> None:
    """The whole band peaks at under 3 times its edges, yet stands tens of noise deviations
    above them: the sweep shows both modes, and its fit places them within a hundredth of the
    split of the truth."""
    evidence, check, truth, ratio = _assess(seed, "band")
    assert ratio < 3.0  # the case: a peak-to-edge ratio of 3 refused it
    assert check.passed, check.detail
    assert evidence.ok, evidence.failures()
    split = float(truth[1] - truth[0])
    assert np.all(np.abs(np.sort(evidence.frequencies_hz) - truth) < 0.01 * split)


@pytest.mark.parametrize("seed", SEEDS)
@pytest.mark.parametrize("where", ["above", "below"])
def test_a_window_beside_the_modes_has_no_peak(seed: int, where: str) -> None:
    """Over the tail of the modes plus the feedthrough the response is monotone, so no point
    inside stands above both edges by the noise's reach."""
    evidence, check, _, _ = _assess(seed, where)
    assert not check.passed, check.detail
    assert not evidence.ok


@settings(max_examples=15, deadline=None)
@given(scale=st.floats(1e-6, 1e6))
def test_the_prominence_does_not_depend_on_the_units(scale: float) -> None:
    """The response and its noise in other units (times ``scale``, the variance times its
    square) stand as many deviations above the edges."""
    device = get_registry().device("random-gyro", seed=209)
    bias = np.zeros(len(device.electrodes))
    lo, hi = device.band_hz
    sweep = experiment_from_measurement(
        device.measure(bias, np.linspace(lo, hi, 21)),
        bias,
        list(device.electrodes),
        device.structure_potential,
        "r",
    )
    assert "noise_var" in sweep
    mask = measured_mask(sweep)[0]
    psi = sweep["response"].values[0][mask]
    s = np.linalg.norm(psi, ord=2, axis=(-2, -1))
    residual = 1e-3 * np.abs(psi)
    i_pk = int(np.argmax(s))
    base = peak_prominence(sweep, mask, s, residual, i_pk)
    scaled = sweep.copy()
    scaled["response"] = sweep["response"] * scale
    scaled["noise_var"] = sweep["noise_var"] * scale**2
    got = peak_prominence(scaled, mask, s * scale, residual * scale, i_pk)
    assert np.allclose(got[0], base[0], rtol=1e-9)
    assert got[1] == base[1]
