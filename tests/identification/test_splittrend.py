"""The split's estimator in time (:mod:`sysid_core.identification.splittrend`).

Against synthetic truths drawn from the filter's own model: the 95 % band it states holds the
truth in about 95 % of draws, for a line and for a rate that random-walks; its limits are the
rules it replaces (the latest window alone, a least-squares line); what an anchored model
misses is told apart from the split; the order and the origin of the clock do not matter.
"""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from sysid_core.identification.splittrend import LAB_TREND, TrendModel, forecast

MHZ = 1e-3


def _coverage(trend: TrendModel, draws: int, seed: int, anchored: bool) -> float:
    """The share of draws whose true split vector lies in the forecast's 95 % disc."""
    rng = np.random.default_rng(seed)
    sigma = 0.7 * MHZ
    inside = 0
    for _ in range(draws):
        n = int(rng.integers(2, 9))
        t = np.sort(rng.uniform(0.0, 3600.0, n))
        at = t[-1] + rng.uniform(20.0, 600.0)
        grid = np.concatenate([t, [at]])
        # the truth: a level, a rate drawn from the prior that random-walks, a wander
        level = rng.normal(0.0, 5 * MHZ, 2)
        rate = rng.normal(0.0, trend.rate_hz_per_s, 2)
        s, truth = level.copy(), []
        for k, when in enumerate(grid):
            if k:
                dt = when - grid[k - 1]
                _, q = trend.transition(dt)
                w = rng.multivariate_normal(np.zeros(2), q + 1e-30 * np.eye(2), size=2)
                s, rate = s + dt * rate + w[:, 0], rate + w[:, 1]
            truth.append(s.copy())
        truth = np.asarray(truth)
        y = truth[:n] + rng.normal(0.0, sigma, (n, 2))
        miss = rng.normal(0.0, trend.model_error_hz, 2)
        a = truth[:n] + miss + rng.normal(0.0, sigma, (n, 2)) if anchored else None
        found = forecast(t, y, [sigma**2] * n, at, trend, anchored_hz=a)
        z2 = float(np.sum((found.vector_hz - truth[-1]) ** 2)) / found.variance_hz2
        inside += z2 <= 5.991  # chi-square, 2 degrees of freedom, 95 %
    return inside / draws


@pytest.mark.parametrize(
    ("trend", "anchored"),
    [
        (LAB_TREND, True),
        (LAB_TREND, False),
        (TrendModel(3e-5, 1800.0, 1e-10, 2e-3), True),
    ],
    ids=["line-anchored", "line", "random-walk-rate"],
)
def test_the_stated_band_holds_the_truth_95_percent_of_draws(
    trend: TrendModel, anchored: bool
) -> None:
    # 1000 draws: a binomial share of 0.95 has a standard deviation of 0.007; the bounds are
    # 3.6 and 2.9 of them away
    assert 0.925 <= _coverage(trend, 1000, seed=7, anchored=anchored) <= 0.97


def test_a_huge_wander_leaves_the_latest_window_alone() -> None:
    t = np.array([0.0, 60.0, 120.0])
    y = np.array([[1.0, 0.0], [2.0, 1.0], [3.5, -1.0]]) * MHZ
    trend = TrendModel(0.0, float("inf"), 1e3, float("inf"))
    found = forecast(t, y, [1e-8] * 3, 180.0, trend)
    np.testing.assert_allclose(found.vector_hz, y[-1], atol=1e-6 * MHZ)


def test_without_process_noise_and_a_flat_prior_it_is_the_least_squares_line() -> None:
    rng = np.random.default_rng(3)
    t = np.sort(rng.uniform(0, 1800, 6))
    y = np.c_[2e-3 + 1e-6 * t, -1e-3 + 3e-7 * t] + rng.normal(0, 1e-4, (6, 2))
    trend = TrendModel(1.0, float("inf"), 0.0, float("inf"))
    at = 2400.0
    found = forecast(t, y, [1e-8] * 6, at, trend)
    line = [np.polyval(np.polyfit(t, y[:, k], 1), at) for k in range(2)]
    np.testing.assert_allclose(found.vector_hz, line, rtol=1e-6, atol=1e-9)


def test_what_the_anchored_model_misses_is_told_from_the_split() -> None:
    # anchored estimates miss by a constant 3 mHz; with them the forecast is the truth,
    # and it is tighter than from the own splits alone
    t = np.arange(6) * 120.0
    truth = np.c_[1e-3 + 2e-6 * t, -1e-3 * np.ones(6)]
    rng = np.random.default_rng(0)
    own = truth + rng.normal(0, 0.5 * MHZ, truth.shape)
    anchored = truth + np.array([3e-3, -3e-3]) + rng.normal(0, 0.5 * MHZ, truth.shape)
    trend = TrendModel(3e-5, float("inf"), 0.0, 5e-3)
    both = forecast(t, own, [(0.5 * MHZ) ** 2] * 6, 720.0, trend, anchored_hz=anchored)
    alone = forecast(t, own, [(0.5 * MHZ) ** 2] * 6, 720.0, trend)
    at = np.array([1e-3 + 2e-6 * 720.0, -1e-3])
    assert np.linalg.norm(both.vector_hz - at) <= 3 * np.sqrt(2 * both.variance_hz2)
    assert both.variance_hz2 < alone.variance_hz2


@settings(max_examples=40, deadline=None)
@given(
    shift=st.floats(-1e6, 1e6),
    order=st.permutations(range(4)),
)
def test_the_clock_origin_and_window_order_do_not_matter(shift: float, order: list[int]) -> None:
    t = np.array([0.0, 90.0, 200.0, 330.0])
    y = np.array([[1.0, 0.5], [1.2, 0.4], [1.1, 0.2], [1.6, 0.1]]) * MHZ
    a = y + 2 * MHZ
    v = np.array([1.0, 2.0, 0.5, 1.0]) * MHZ**2
    ref = forecast(t, y, v, 400.0, LAB_TREND, anchored_hz=a)
    idx = list(order)
    moved = forecast(t[idx] + shift, y[idx], v[idx], 400.0 + shift, LAB_TREND, anchored_hz=a[idx])
    scale = np.sqrt(ref.variance_hz2)
    np.testing.assert_allclose(moved.vector_hz, ref.vector_hz, atol=1e-6 * scale)
    assert moved.variance_hz2 == pytest.approx(ref.variance_hz2, rel=1e-6)


@pytest.mark.parametrize(
    ("t", "y", "v"),
    [
        ([], np.zeros((0, 2)), []),
        ([0.0, np.nan], np.zeros((2, 2)), [1.0, 1.0]),
        ([0.0, 1.0], np.zeros((2, 2)), [1.0, -1.0]),
        ([0.0, 1.0], np.zeros((3, 2)), [1.0, 1.0]),
    ],
    ids=["empty", "nan-time", "negative-variance", "shapes"],
)
def test_bad_windows_are_refused_in_one_line(t: list, y: np.ndarray, v: list) -> None:
    with pytest.raises(ValueError, match="forecast"):
        forecast(t, y, v, 10.0, LAB_TREND)


def test_a_negative_or_nan_parameter_is_refused() -> None:
    with pytest.raises(ValueError, match="rate_hz_per_s"):
        TrendModel(-1.0, 1.0, 0.0, 1.0)
    with pytest.raises(ValueError, match="model_error_hz"):
        TrendModel(1.0, 1.0, 0.0, float("nan"))


@settings(max_examples=25, deadline=None)
@given(st.integers(1, 12), st.integers(0, 10_000))
def test_the_forecast_is_its_weights_on_what_the_windows_read(n: int, seed: int) -> None:
    """The filter is linear in the windows' vectors: its weights give every draw's forecast."""
    from sysid_core.identification.splittrend import forecast_weights

    rng = np.random.default_rng(seed)
    t = np.sort(rng.uniform(0.0, 600.0, n))
    variances = rng.uniform(0.2, 2.0, n) * MHZ**2
    at = t[-1] + rng.uniform(0.0, 60.0)
    weights, sigma = forecast_weights(t, variances, at, LAB_TREND)
    y = rng.normal(0.0, 3 * MHZ, (n, 2))
    found = forecast(t, y, variances, at, LAB_TREND)
    # to the diffuse prior's millionth: its variance scales with what the windows read
    assert weights @ y == pytest.approx(found.vector_hz, abs=1e-5 * float(np.abs(y).max()))
    assert sigma == pytest.approx(found.sigma_hz, rel=1e-5)
