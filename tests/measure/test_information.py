"""Information per second: what a grid's points tell about the split, and the grid chosen by it."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st
from scipy.optimize import least_squares

from sysid_core.measure.information import (
    measuring_order,
    mode_information,
    per_second,
    split_information,
    split_weights,
)
from sysid_core.measure.modegrid import SHAPES, ModeGuess, mode_grid, shaped_grid
from sysid_core.measure.sweeps import MIN_POINTS, SweepPlan, fewest_points

PLAN = SweepPlan((4385.0, 4445.0), 0.5, 6.0, 0.05, 1.0, 0.01, 20_000)


def _response(theta: np.ndarray, f: np.ndarray) -> np.ndarray:
    f0, bw, rr, ri, dr, di, er, ei = theta
    return (rr + 1j * ri) / (1 + 2j * (f - f0) / bw) + dr + 1j * di + (er + 1j * ei) * (f - 4420)


def test_the_information_is_the_inverse_variance_of_fitted_frequencies() -> None:
    """The known truth: 400 least-squares fits of a noisy resonance scatter as ``1/√I`` says.

    One mode (4420 Hz, 0.1 Hz wide, unit residue, a feedthrough with a slope) on the default
    grid's points, complex noise of 0.01 (each part); the sample variance of the fitted ``f0``
    of 400 draws has a relative standard error of ``√(2/399) = 7 %``: within 25 % it is the
    Fisher variance ``σ² / I``.
    """
    guess = ModeGuess.of([4420.0, 4440.0], [0.1, 0.1])
    f = shaped_grid(guess, PLAN)
    truth = np.array([4420.0, 0.1, 1.0, 0.0, 0.02, -0.01, 0.001, 0.0])
    clean = _response(truth, f)
    rng = np.random.default_rng(7)
    sigma, fits = 0.01, []
    for _ in range(400):
        data = clean + sigma * (rng.standard_normal(f.size) + 1j * rng.standard_normal(f.size))

        def residual(theta: np.ndarray, data: np.ndarray = data) -> np.ndarray:
            r = _response(theta, f) - data
            return np.concatenate([r.real, r.imag])

        fits.append(least_squares(residual, truth, x_scale="jac").x[0])
    expected = sigma**2 / mode_information(f, 4420.0, 0.1)
    assert np.var(fits, ddof=1) == pytest.approx(expected, rel=0.25)


def test_far_points_tell_less_than_points_on_the_mode() -> None:
    on = np.linspace(4419.95, 4420.05, 5)
    off = on + 1.0  # ten bandwidths away
    anchors = np.array([4410.0, 4430.0])
    near = mode_information(np.concatenate([on, anchors]), 4420.0, 0.1)
    far = mode_information(np.concatenate([off, anchors]), 4420.0, 0.1)
    assert far < 1e-3 * near
    # too few points to tell the frequency from the other unknowns: no information
    assert mode_information(on[:2], 4420.0, 0.1) == 0.0


def test_the_grid_chosen_is_the_cheap_informative_one() -> None:
    """With one tone every point costs a dwell: the default shape's 18 points carry hardly more
    than a narrower core's 16, so the narrower one is measured (the cheapest, and of the
    cheapest the most informative per second)."""
    guess = ModeGuess.of([4424.0, 4429.0], [0.1, 0.1])

    def value(points: np.ndarray) -> float:
        info = split_information(points, guess.frequencies_hz, guess.bandwidth_hz)
        return per_second(info, points.size, 1, lambda n: 1.2 + n)

    default = shaped_grid(guess, PLAN)
    chosen = mode_grid(guess, PLAN, cost_s=lambda n: 1.2 + n)
    assert chosen.size < default.size
    assert value(chosen) > 1.1 * value(default)
    grids = [shaped_grid(guess, PLAN, shape=s) for s in SHAPES]
    cheapest = min(g.size for g in grids)
    assert chosen.size == cheapest
    best = max(value(g) for g in grids if g.size == cheapest)
    assert value(chosen) == pytest.approx(best)


def test_far_points_are_dropped_with_one_tone_and_kept_where_an_acquisition_has_room() -> None:
    """Near degenerate modes (0.5 mHz apart): with one tone the second pair of anchors costs two
    dwells and is left out; with eight tones what fits of it fills the second acquisition,
    already paid for."""
    guess = ModeGuess.of([4430.0, 4430.0005], [0.1, 0.05])
    one = mode_grid(guess, PLAN, resolve=True, cost_s=lambda n: 1.2 + n)
    plan = dataclasses.replace(PLAN, tones=8)
    eight = mode_grid(guess, plan, resolve=True, cost_s=lambda n: 1.2 + -(-n // 8))
    far = lambda g: int(np.sum(np.abs(g - 4430.0) > 1.0))  # noqa: E731
    assert far(one) == 2 and far(eight) > far(one)
    assert eight.size == 16 and one.size < eight.size


@given(st.integers(1, 64))
def test_fewest_points_are_whole_acquisitions_nearest_the_minimum(tones: int) -> None:
    n = fewest_points(tones)
    assert n % tones == 0 and n >= tones
    assert abs(n - MIN_POINTS) <= tones / 2 or n == tones


def test_a_fit_of_a_drifting_mode_gives_the_frequency_at_the_windows_time() -> None:
    """The known truth: a mode moving at a steady rate during a window is fitted at ``Σ a_i t_i``.

    One mode (4420 Hz, 0.1 Hz wide) moves 2 mHz over a window of the default grid measured in
    :func:`measuring_order` (one point per second), no noise. The least-squares ``f0`` is the
    frequency at the window's time by :func:`split_weights` to a hundredth of the move (the
    weights are first order in it), and not the frequency at the window's middle.
    """
    guess = ModeGuess.of([4420.0, 4420.0], [0.1, 0.1])
    f = measuring_order(shaped_grid(guess, PLAN), [4420.0, 4420.0], [0.1, 0.1])
    t = np.arange(f.size, dtype=float)
    rate = 2e-3 / t[-1]
    truth = np.array([4420.0, 0.1, 1.0, 0.0, 0.02, -0.01, 0.001, 0.0])
    moved = [np.r_[4420.0 + rate * ti, truth[1:]] for ti in t]
    data = np.array([_response(th, np.array([fi]))[0] for th, fi in zip(moved, f, strict=True)])

    def residual(theta: np.ndarray) -> np.ndarray:
        r = _response(theta, f) - data
        return np.concatenate([r.real, r.imag])

    fitted = least_squares(residual, truth, x_scale="jac", xtol=1e-15, ftol=1e-15).x[0]
    order = np.argsort(f)
    weights = split_weights(f[order], [4420.0, 4420.0], [0.1, 0.1])
    assert weights is not None
    assert weights.sum() == pytest.approx(1.0)
    when = float(weights @ t[order])
    assert fitted == pytest.approx(4420.0 + rate * when, abs=2e-5)
    assert abs(fitted - (4420.0 + rate * t.mean())) > 5e-4
    # measured least informative first, the window's time is in its last tenth
    assert when > 0.9 * t[-1]


@given(
    centre=st.floats(-0.3, 0.3),
    ratio=st.floats(0.3, 3.0),
    split=st.floats(0.0, 0.5),
)
def test_the_measuring_order_is_a_permutation_ending_where_the_split_is_told(
    centre: float, ratio: float, split: float
) -> None:
    """Every point once; the last one measured carries the largest share of the split."""
    f0 = 4420.0 + centre
    guess = ModeGuess.of([f0, f0 + split * 0.1], [0.1, 0.1 * ratio], 0.02)
    grid = shaped_grid(guess, PLAN)
    ordered = measuring_order(grid, guess.frequencies_hz, guess.bandwidth_hz)
    np.testing.assert_array_equal(np.sort(ordered), np.sort(grid))
    weights = split_weights(np.sort(grid), guess.frequencies_hz, guess.bandwidth_hz)
    assert weights is not None
    assert weights[np.searchsorted(np.sort(grid), ordered[-1])] == pytest.approx(weights.max())
