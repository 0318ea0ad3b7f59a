"""Windows at one bias share one noise (:func:`sysid_core.drift.forecast.pooled_by_bias`).

Against a synthetic truth: windows of one code read one split vector with one noise, but each
states a variance that shrinks with the split it read (as a fit's interval linearised at a
small split does near degenerate modes). Weighted by their own variances, the filter leans on
the low readings and its forecast falls under the truth; weighted by the variance their bias
shares, it does not.
"""

from __future__ import annotations

import numpy as np
import pytest
import xarray as xr

from sysid_core.drift.forecast import pooled_by_bias
from sysid_core.identification.splittrend import LAB_TREND, forecast

MHZ = 1e-3


def _window(bias: list[float]) -> xr.Dataset:
    return xr.Dataset(attrs={"requested_bias": bias})


def test_windows_at_one_bias_take_the_median_of_their_variances() -> None:
    sweeps = [_window([1.0, 2.0]), _window([1.0, 2.0]), _window([0.5, 2.0]), _window([1.0, 2.0])]
    assert pooled_by_bias(sweeps, [1.0, 4.0, 2.0, 9.0]) == [4.0, 4.0, 2.0, 4.0]


def test_a_window_averaged_over_passes_shares_the_noise_per_pass() -> None:
    averaged = xr.Dataset(attrs={"requested_bias": [1.0, 2.0], "passes": 4})
    sweeps = [_window([1.0, 2.0]), averaged, _window([1.0, 2.0])]
    # per pass: 4, 4 x 1.5 = 6 and 8: the median 6; the averaged window holds it over 4
    assert pooled_by_bias(sweeps, [4.0, 1.5, 8.0]) == [6.0, 1.5, 6.0]


def test_a_window_alone_at_its_bias_keeps_its_own() -> None:
    assert pooled_by_bias([_window([0.1]), _window([0.2])], [3.0, 5.0]) == [3.0, 5.0]


def test_pooling_removes_the_pull_of_low_readings() -> None:
    rng = np.random.default_rng(7)
    truth, noise, n = np.array([1.0, 0.0]) * MHZ, 0.4 * MHZ, 30
    t = np.cumsum(np.full(n, 15.0))
    sweeps = [_window([0.25, -0.5])] * n
    own_error, pooled_error = [], []
    for _ in range(200):
        y = truth + rng.normal(0.0, noise, (n, 2))
        # each window states a variance that grows with what it read: σ = 0.4 × |reading|
        stated = list((0.4 * np.hypot(*y.T)) ** 2 + (0.05 * MHZ) ** 2)
        for variances, errors in (
            (stated, own_error),
            (pooled_by_bias(sweeps, stated), pooled_error),
        ):
            found = forecast(t, y, variances, t[-1], LAB_TREND)
            errors.append(found.split_hz - np.hypot(*truth))
    # 200 draws of a forecast whose σ is about 0.15 mHz: the mean error is known to ±0.01 mHz
    assert np.mean(own_error) < -0.1 * MHZ  # measured -0.33 mHz
    assert np.mean(pooled_error) == pytest.approx(0.0, abs=0.05 * MHZ)  # measured -0.01 mHz
