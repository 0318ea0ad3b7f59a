"""The simulated devices report each point's noise variance (``noise_var``) as a lock-in does."""

from __future__ import annotations

import numpy as np
import pytest
import xarray as xr
from sysid_simgyro import SimulatedGyro
from sysid_simgyro.device import NOISE_SUBSAMPLES

from sysid_core.device.measuring import check_answer
from sysid_core.errors import InvalidAnswerError
from sysid_core.plugin.registry import get_registry

BIAS = [0.5, -0.25, 0.0]
#: Relative standard deviation of one estimate: chi²(2(m-1)) / (2(m-1)) with m = 16.
ESTIMATE_SPREAD = np.sqrt(2.0 / (2 * (NOISE_SUBSAMPLES - 1)))


def cloverleaf(**options: object) -> SimulatedGyro:
    device = get_registry().create("device", "cloverleaf", **options)
    assert isinstance(device, SimulatedGyro)
    return device


def band(device: SimulatedGyro, n: int) -> np.ndarray:
    return np.linspace(*device.band_hz, n)


def test_the_cloverleaf_reports_its_noise_variance() -> None:
    device = cloverleaf(seed=3)
    f = band(device, 1000)
    answer = check_answer(device.measure(BIAS, f), f)  # the core accepts it
    var = answer["noise_var"]
    assert var.dims == ("frequency", "output", "input") and var.dtype == float
    values = np.asarray(var.values)
    # 4000 estimates of noise_std²: their mean within 10 % (its standard error is 0.4 %)
    assert values.mean() == pytest.approx(device.noise_std**2, rel=0.1)
    # measured, not known: each estimate scatters as a 16-sample variance does (26 %)
    spread = float(np.std(values / device.noise_std**2))
    assert 0.8 * ESTIMATE_SPREAD < spread < 1.2 * ESTIMATE_SPREAD
    # and it is the variance of the noise the response really has
    noise = answer.values - device.noiseless_response(BIAS, f)
    assert np.mean(np.abs(noise) ** 2) == pytest.approx(values.mean(), rel=0.1)


def test_shared_tones_report_k_times_the_variance() -> None:
    """``[device.bench] tones = 4``: each tone's noise variance is 4 times a single tone's."""
    single = cloverleaf(seed=3)
    device = cloverleaf(seed=3, bench={"tones": 4})
    f = band(device, 1002)  # 250 acquisitions of 4 tones, then one of 2
    values = np.asarray(device.measure(BIAS, f)["noise_var"].values)
    k = device.tones_shared(f.size)
    assert k[0] == 4 and k[-1] == 2
    full = values[k == 4]
    assert full.mean() == pytest.approx(4 * single.noise_std**2, rel=0.1)
    scaled = values / (k[:, None, None] * single.noise_std**2)
    assert scaled.mean() == pytest.approx(1.0, rel=0.1)
    assert values[k == 2].mean() < 0.75 * full.mean()  # the last acquisition's 2 tones


def test_responses_are_those_of_a_device_without_variances() -> None:
    """The variances come from a generator of their own: the responses are exactly those of the
    noise stream ``default_rng(seed)`` as before (every test and document relies on them)."""
    for options in ({}, {"bench": {"tones": 4}}):
        device = cloverleaf(seed=11, **options)
        rng = np.random.default_rng(11)
        f = band(device, 101)
        for bias in (BIAS, [1.0, 0.0, 0.0]):  # successive measurements: the stream goes on
            got = device.measure(bias, f)
            clean = device.noiseless_response(bias, f)
            scale = device.noise_std / np.sqrt(2.0) * np.sqrt(device.tones_shared(f.size))
            noise = rng.standard_normal(clean.shape) + 1j * rng.standard_normal(clean.shape)
            np.testing.assert_array_equal(got.values, clean + scale[:, None, None] * noise)
            assert "noise_var" in got.coords


def test_the_same_seed_gives_the_same_variances() -> None:
    f = np.linspace(4420.0, 4440.0, 41)
    a, b = cloverleaf(seed=8), cloverleaf(seed=8)
    first, second = a.measure(BIAS, f), b.measure(BIAS, f)
    xr.testing.assert_identical(first, second)
    again = a.measure(BIAS, f)  # a new measurement: new noise and new estimates
    assert not np.array_equal(again["noise_var"].values, first["noise_var"].values)


def test_without_noise_there_is_nothing_to_weight() -> None:
    answer = cloverleaf(noise=0.0).measure(BIAS, np.linspace(4420.0, 4440.0, 11))
    assert "noise_var" not in answer.coords


@pytest.mark.parametrize(
    ("value", "message"),
    [(-1e-9, "finite and >= 0"), (np.inf, "finite and >= 0"), (1j, "not real")],
)
def test_the_core_refuses_a_bad_noise_variance(value: complex, message: str) -> None:
    f = np.linspace(4420.0, 4440.0, 11)
    answer = cloverleaf(seed=1).measure(BIAS, f)
    values = answer["noise_var"].values.astype(complex if isinstance(value, complex) else float)
    values[3, 1, 0] = value
    bad = answer.assign_coords(noise_var=(answer["noise_var"].dims, values))
    with pytest.raises(InvalidAnswerError, match=message):
        check_answer(bad, f)


def test_the_core_accepts_unknown_variances_and_refuses_other_dims() -> None:
    f = np.linspace(4420.0, 4440.0, 11)
    answer = cloverleaf(seed=1).measure(BIAS, f)
    values = answer["noise_var"].values.copy()
    values[2] = np.nan  # unknown at one point
    check_answer(answer.assign_coords(noise_var=(answer["noise_var"].dims, values)), f)
    flat = answer.assign_coords(noise_var=("frequency", values[:, 0, 0]))
    with pytest.raises(InvalidAnswerError, match="dims"):
        check_answer(flat, f)
