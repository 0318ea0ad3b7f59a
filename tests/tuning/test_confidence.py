"""Confidence regions of tuning answers: the covariance of a least-squares fit and its regions.

The main check is coverage on a truth inside the model class, where a 95 % region must hold
the true answer 95 % of the time (± sampling error over 250 noise seeds).
"""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from sysid_core import fit, load_model
from sysid_core.identification.covariance import (
    active_constraint_rows,
    stiffness_map,
    theta_covariance,
)
from sysid_core.identification.fitting import model_from_problem
from sysid_core.identification.objective import ObjectiveResult
from sysid_core.identification.problem import FitProblem
from sysid_core.model.structures import ModelStructure
from sysid_core.plugin.registry import get_registry
from sysid_core.tuning.confidence import confidence_region, stiffness_vector
from sysid_core.tuning.criteria import BiasSpace
from tests.truths import PAPER_BIASES, PAPER_FREQS, V_GYRO, cloverleaf_truth, simulate

#: The paper's band at 0.5 Hz, 121 points per experiment (the default design).
FREQS = PAPER_FREQS
NOISE = 1e-4  # of the resonant peak, per point, as on the simulated cloverleaf
SEEDS = 250
#: Three binomial standard deviations of a 95 % coverage over SEEDS draws.
SLACK = 3 * np.sqrt(0.95 * 0.05 / SEEDS)


def _space() -> BiasSpace:
    return BiasSpace(["B1", "B2"], ["B1", "B2"], np.zeros(2), (-10.0, 10.0), V_GYRO)


def _criterion(name: str = "degenerate", **options: float):
    reg = get_registry()
    return reg.criterion(name, solver=reg.solver("clarabel"), **options)


@pytest.fixture(scope="module")
def coverage_runs() -> list[dict[str, object]]:
    """250 noisy data sets of an in-class truth: answer, region and truth of each."""
    truth = cloverleaf_truth()  # velocity pick-off, no signal conditioning: in the model class
    target = truth.degenerate_bias((0, 1))
    criterion = _criterion()
    runs = []
    for seed in range(SEEDS):
        ds = simulate(truth, PAPER_BIASES, FREQS, noise_peak=NOISE, seed=seed)
        model = fit(ds)  # the default: act, order 2, bias_terms 1, least squares
        answer = criterion.solve(model, _space())
        region = confidence_region(model, answer, _space())
        assert region is not None
        runs.append(
            {
                "bias": answer.bias,
                "region": region,
                "true_bias": target,
                "true_split": truth.split_hz(answer.bias),
            }
        )
    return runs


def test_bias_region_covers_the_true_degenerate_bias_95_percent(coverage_runs) -> None:
    inside = [
        np.all(
            (r["true_bias"] >= r["region"].bias_ci[:, 0])
            & (r["true_bias"] <= r["region"].bias_ci[:, 1])
        )
        for r in coverage_runs
    ]
    assert abs(np.mean(inside) - 0.95) <= SLACK, np.mean(inside)


def test_bias_region_has_the_spread_of_the_answers(coverage_runs) -> None:
    """The regions are as wide as the answers really scatter over noise draws (not just wide)."""
    bias = np.array([r["bias"] for r in coverage_runs])
    half = np.array([0.5 * np.diff(r["region"].bias_ci, axis=1)[:, 0] for r in coverage_runs])
    # Bonferroni box for two electrodes: half-width = z(1 - 0.05/4) sigma = 2.241 sigma
    predicted_sd = np.median(half, axis=0) / 2.241
    ratio = predicted_sd / bias.std(axis=0, ddof=1)
    assert np.all((ratio > 0.75) & (ratio < 1.35)), ratio


def test_split_region_covers_the_true_split(coverage_runs) -> None:
    """The split range is the projection of a 95 % region: it holds at least 95 % of truths."""
    inside = [
        r["region"].split_ci_hz[0] <= r["true_split"] <= r["region"].split_ci_hz[1]
        for r in coverage_runs
    ]
    assert np.mean(inside) >= 0.95 - SLACK, np.mean(inside)
    # and it is informative: the largest split it allows is a few times the typical true one
    high = np.median([r["region"].split_ci_hz[1] for r in coverage_runs])
    typical = np.median([r["true_split"] for r in coverage_runs])
    assert high < 10 * typical, (high, typical)


# --------------------------------------------------------------- the covariance's pieces
@pytest.fixture(scope="module")
def problem_and_theta() -> tuple[FitProblem, np.ndarray, ModelStructure]:
    truth = cloverleaf_truth()
    ds = simulate(truth, PAPER_BIASES, FREQS, noise_peak=NOISE, seed=1)
    structure = get_registry().structure("act", order=2, bias_terms=1)
    problem = FitProblem(ds, structure)
    objective = get_registry().objective("least-squares")
    result = objective.fit(problem, get_registry().solver("clarabel"))
    return problem, result.theta, structure


def test_mass_normalisation_is_active_and_fixes_the_scale(problem_and_theta) -> None:
    problem, theta, _ = problem_and_theta
    rows = active_constraint_rows(problem, theta)
    assert rows.shape[0] >= 1  # M ⪰ I touches its bound: the fit's scale is fixed there
    cov = theta_covariance(problem, theta)
    assert cov is not None
    # no variance along the active constraints (they are equalities near the optimum)
    np.testing.assert_allclose(rows @ cov @ rows.T, 0.0, atol=1e-12 * np.abs(cov).max())
    # and the scale direction (theta itself) is not free: its variance is tiny next to theta's
    assert theta @ cov @ theta < 1e-6 * (theta @ theta)


@settings(max_examples=25, deadline=None)
@given(st.lists(st.floats(-1e-3, 1e-3), min_size=8, max_size=8), st.integers(0, 10_000))
def test_stiffness_map_is_the_model_map(problem_and_theta, steps, where) -> None:
    """A change of the unknowns moves the physical M, K0, K_p by exactly stiffness_map's rows."""
    problem, theta, _ = problem_and_theta
    rng = np.random.default_rng(where)
    delta = np.zeros_like(theta)
    delta[rng.choice(problem.layout.n_z, size=8, replace=False)] = steps

    def physical(th: np.ndarray) -> np.ndarray:
        result = ObjectiveResult(
            theta=th, gamma=0.0, max_residual=0.0, certified=True, objective="x"
        )
        return stiffness_vector(model_from_problem(problem, result))

    t = stiffness_map(problem)
    expected = physical(theta) + t @ delta
    np.testing.assert_allclose(physical(theta + delta), expected, rtol=1e-9, atol=1e-6)


def test_region_is_reproducible_and_saved_with_the_model(tmp_path) -> None:
    ds = simulate(cloverleaf_truth(), PAPER_BIASES, FREQS, noise_peak=NOISE, seed=3)
    model = fit(ds)
    answer = _criterion().solve(model, _space())
    first = confidence_region(model, answer, _space())
    again = confidence_region(model, answer, _space())
    assert first is not None and again is not None
    np.testing.assert_array_equal(first.bias_ci, again.bias_ci)
    loaded = load_model(model.save(tmp_path / "m.nc"))
    assert loaded.stiffness_factor is not None
    np.testing.assert_array_equal(loaded.stiffness_factor, model.stiffness_factor)
    third = confidence_region(loaded, answer, _space())
    assert third is not None
    np.testing.assert_array_equal(third.bias_ci, first.bias_ci)
    # every key of the JSON contract
    assert set(first.as_dict()) == {"confidence_level", "bias_ci", "split_ci_hz", "frequency_ci_hz"}
    lo, hi = first.frequency_ci_hz
    assert lo < answer.frequency_hz < hi


def test_minimax_fit_states_no_region() -> None:
    ds = simulate(cloverleaf_truth(), PAPER_BIASES, FREQS, noise_peak=NOISE, seed=3)
    model = fit(ds, "act", order=1, objective="minimax", bias_terms=0)
    assert model.stiffness_factor is None
    answer = _criterion().solve(model, _space())
    assert confidence_region(model, answer, _space()) is None
    assert "bias_ci" not in answer.as_dict()


def test_target_region_holds_the_target_frequency() -> None:
    """With the target criterion the frequency condition is part of the region."""
    truth = cloverleaf_truth()
    ds = simulate(truth, PAPER_BIASES, FREQS, noise_peak=NOISE, seed=4)
    model = fit(ds)
    answer = _criterion("target", target_hz=4430.0, tolerance_hz=1.0).solve(model, _space())
    region = confidence_region(model, answer, _space())
    assert region is not None
    lo, hi = region.frequency_ci_hz
    assert lo <= 4430.0 + 0.01 and hi >= 4430.0 - 0.01
    assert np.all(region.bias_ci[:, 0] <= answer.bias) and np.all(
        answer.bias <= region.bias_ci[:, 1]
    )
