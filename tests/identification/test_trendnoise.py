"""The windows' variance scale and rate change from their innovations (:mod:`.trendnoise`).

Against synthetic truths with a known scatter or a known change of the rate: where the stated
trend holds, the windows rarely reject it (the test's 5 %) and the band is unchanged; where the
windows scatter more than their fits state, or the rate changes within the run, the stated band
misses the truth in most draws and the fitted one holds it in about 95 %.
"""

from __future__ import annotations

import numpy as np
import pytest

from sysid_core.identification.splittrend import LAB_TREND, TrendModel, forecast
from sysid_core.identification.trendnoise import LR_CRITICAL, RATE_CHANGES_S, fitted_trend

MHZ = 1e-3
SIGMA = 3 * MHZ  # what each window's fit states, per component


def _draws(scale: float, n: int, draws: int, seed: int) -> list[tuple]:
    """``draws`` runs of ``n`` windows 20-60 s apart and the truth at the next one.

    The truth: a level and a rate drawn from the stated trend's prior; ``scale``: how many
    times the windows' variance exceeds what their fits state.
    """
    rng = np.random.default_rng(seed)
    out = []
    for _ in range(draws):
        t = np.cumsum(rng.uniform(20.0, 60.0, n + 1))
        rate = rng.normal(0.0, LAB_TREND.rate_hz_per_s, 2)
        truth = np.outer(t - t[0], rate) + rng.normal(0, 5 * MHZ, 2)
        y = truth[:n] + rng.normal(0.0, SIGMA * np.sqrt(scale), (n, 2))
        out.append((t, y, truth[n]))
    return out


def _coverage(draws: list[tuple], fit: bool) -> tuple[float, float, list[TrendModel]]:
    """The share of draws whose next split lies in the 95 % disc, the share that rejected the
    stated trend, and the models used."""
    inside, models = 0, []
    for t, y, truth in draws:
        n = y.shape[0]
        variances = [SIGMA**2] * n
        model = fitted_trend(t[:n], y, variances, LAB_TREND) if fit else LAB_TREND
        found = forecast(t[:n], y, variances, t[n], model)
        inside += float(np.sum((found.vector_hz - truth) ** 2)) / found.variance_hz2 <= 5.991
        models.append(model)
    rejected = sum(m != LAB_TREND for m in models)
    return inside / len(draws), rejected / len(draws), models


def test_the_critical_value_is_the_boundary_mixtures_95_percent_point() -> None:
    # ½ P(χ²₁ > c) + ¼ P(χ²₂ > c) = 0.05: ½ 0.0398 + ¼ 0.1206
    assert LR_CRITICAL == pytest.approx(4.2306, abs=1e-3)


@pytest.mark.parametrize("n", [10, 60])
def test_where_the_stated_trend_holds_it_is_kept(n: int) -> None:
    # 300 draws: a binomial share of 0.05 has a standard deviation of 0.013; the asymptotic
    # test is conservative on a grid and few windows
    covered, rejected, _ = _coverage(_draws(1.0, n, 300, seed=1), fit=True)
    assert rejected <= 0.08
    assert 0.92 <= covered <= 0.975


def test_windows_that_scatter_three_times_their_fits_are_scaled() -> None:
    draws = _draws(9.0, 60, 300, seed=3)
    stated, _, _ = _coverage(draws, fit=False)
    covered, rejected, models = _coverage(draws, fit=True)
    assert stated < 0.5
    assert rejected >= 0.95
    assert 0.92 <= covered <= 0.98
    assert np.median([m.window_variance_scale for m in models]) == pytest.approx(9.0, rel=0.42)


def test_under_three_windows_the_stated_trend_stands() -> None:
    t = np.array([0.0, 60.0])
    y = np.array([[0.0, 0.0], [1.0, 1.0]])  # a jump no trend explains
    assert fitted_trend(t, y, [SIGMA**2] * 2, LAB_TREND) is LAB_TREND


def test_a_variance_scale_under_one_is_refused() -> None:
    with pytest.raises(ValueError, match="window_variance_scale"):
        TrendModel(3e-5, float("inf"), 0.0, 2e-3, window_variance_scale=0.5)


def _turning(n: int, draws: int, seed: int) -> list[tuple]:
    """``draws`` runs of ``n`` windows 3-6 s apart whose split's rate turns within the run.

    The split moves along a circle of 8 mHz once in the run's span (its rate changes by its
    own size in about a sixth of the span), what a fast gyro verified hundreds of times in an
    uncontrolled lab saw; each window reads it with the noise its fit states.
    """
    rng = np.random.default_rng(seed)
    out = []
    for _ in range(draws):
        t = np.cumsum(rng.uniform(3.0, 6.0, n + 1))
        phase = rng.uniform(0, 2 * np.pi) + 2 * np.pi * (t - t[0]) / (t[-1] - t[0])
        truth = 8 * MHZ * np.column_stack([np.cos(phase), np.sin(phase)])
        y = truth[:n] + rng.normal(0.0, SIGMA, (n, 2))
        out.append((t, y, truth[n]))
    return out


def test_a_rate_that_turns_within_the_run_is_let_change() -> None:
    draws = _turning(150, 40, seed=5)
    stated, _, _ = _coverage(draws, fit=False)
    covered, rejected, models = _coverage(draws, fit=True)
    assert stated < 0.5  # measured 0.0: a line through the circle
    assert rejected >= 0.95
    assert covered >= 0.875  # measured 1.0 (40 of 40), each with τ_r = 1 min
    assert all(np.isfinite(m.rate_change_s) for m in models)
    assert {m.rate_change_s for m in models} <= set(RATE_CHANGES_S)
