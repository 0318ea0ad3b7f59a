"""Cross-checks of the hand-assembled conic programs against the cvxpy reference formulation.

``tests/reference.py`` writes the equation errors and constraints with named cvxpy variables
from the scaled data, never from ``FitProblem.G``; here the two must agree:

* the equation errors at a random ``theta`` (no solve: checks the operator ``G`` entry by entry);
* the optimal γ of the full minimax program (Clarabel backend) and of the cvxpy LMI program;
* the least-squares objective's optimum and minimiser;
* all three with noise weights (``noise_var``; the reference computes its own weights);

for ``act`` and ``sen`` and polynomial orders 0, 1 and 2. The data are a cloverleaf-like truth
(three experiments at the paper's biases, 4385-4445 Hz, 0.1 % + 1e-4-of-peak noise) with only
11 points per experiment: cvxpy's compile time (about 0.3 s plus 20 ms per point for a minimax
program, against 0.05 s in the solver) is this file's cost.
"""

from __future__ import annotations

import numpy as np
import pytest
from reference import (
    least_squares_reference,
    minimax_reference,
    reference_errors,
    solve_reference,
)
from sysid_models.structures import ActStructure, SenStructure
from sysid_objectives.least_squares import LeastSquares
from sysid_objectives.minimax import Minimax
from sysid_solvers.clarabel_backend import ClarabelSolver
from truths import CLOVERLEAF, OUTPUT_LOWPASS, PAPER_BIASES, cloverleaf_truth, simulate

from sysid_core.conic.program import sigma_max_2x2
from sysid_core.errors import SolverError
from sysid_core.identification.problem import FitProblem

FREQS = np.linspace(*CLOVERLEAF.band_hz, 11)
STRUCTURES = {"act": ActStructure, "sen": SenStructure}
CASES = [("act", 1), ("sen", 1), ("act", 0), ("act", 2)]
#: The least-squares optimum is O(1e-5) in scaled units: the reference's solver needs absolute
#: tolerances below Clarabel's default 1e-8 to be a reference at 1e-6 relative.
TIGHT = {"tol_gap_abs": 1e-12, "tol_gap_rel": 1e-12}


@pytest.fixture(scope="module")
def dataset():
    truth = cloverleaf_truth(h_out=OUTPUT_LOWPASS)
    return simulate(truth, PAPER_BIASES, FREQS, noise_rel=1e-3, noise_peak=1e-4, seed=11)


def make_problem(dataset, structure: str, order: int) -> FitProblem:
    return FitProblem(dataset, STRUCTURES[structure](order, bias_terms=0, stiffness="linear"))


@pytest.mark.parametrize("order", [0, 1, 2])
@pytest.mark.parametrize("structure", ["act", "sen"])
def test_operator_matches_reference_errors(dataset, structure, order):
    problem = make_problem(dataset, structure, order)
    rng = np.random.default_rng(order)
    for _ in range(2):
        theta = rng.standard_normal(problem.n_parameters)
        want = reference_errors(problem, theta)
        got = problem.errors(theta)
        assert np.abs(got - want).max() <= 1e-12 * np.abs(want).max()


@pytest.mark.parametrize(("structure", "order"), CASES)
def test_full_minimax_program_matches_reference(dataset, structure, order):
    problem = make_problem(dataset, structure, order)
    gamma_ref, theta_ref = minimax_reference(problem)
    full = Minimax(working_set=False, tie_tol=0).fit(problem, ClarabelSolver())
    assert full.gamma == pytest.approx(gamma_ref, rel=1e-6)
    # Each optimum is certified by the other formulation's errors (within solver tolerance).
    assert problem.residuals(theta_ref).max() == pytest.approx(gamma_ref, rel=1e-6)
    assert sigma_max_2x2(reference_errors(problem, full.theta)).max() == pytest.approx(
        gamma_ref, rel=1e-6
    )
    # The working-set objective (default options) reaches the same optimum.
    ws = Minimax().fit(problem, ClarabelSolver())
    assert ws.certified
    assert ws.gamma == pytest.approx(gamma_ref, rel=1e-6)


def test_sigma_max_form_matches_full_program(dataset):
    problem = make_problem(dataset, "sen", 1)
    gamma_sm, theta_sm = minimax_reference(problem, form="sigma_max")
    full = Minimax(working_set=False, tie_tol=0).fit(problem, ClarabelSolver())
    assert gamma_sm == pytest.approx(full.gamma, rel=1e-6)
    assert problem.residuals(theta_sm).max() == pytest.approx(full.gamma, rel=1e-6)


@pytest.mark.parametrize(("structure", "order"), CASES)
def test_least_squares_matches_reference(dataset, structure, order):
    problem = make_problem(dataset, structure, order)
    value_ref, theta_ref = least_squares_reference(problem, **TIGHT)
    result = LeastSquares().fit(problem, ClarabelSolver())  # default settings
    value = float(result.theta @ problem.gram @ result.theta)
    assert value == pytest.approx(value_ref, rel=1e-6)
    assert float(theta_ref @ problem.gram @ theta_ref) == pytest.approx(value_ref, rel=1e-9)
    scale = np.abs(theta_ref).max()
    np.testing.assert_allclose(result.theta, theta_ref, rtol=0, atol=1e-5 * scale)


@pytest.fixture(scope="module")
def weighted(dataset):
    """The same data with noise variances (``noise_var``): experiment 1 ten times noisier than
    the others, and every point's estimate scattered as a 16-sample variance's."""
    var = np.random.default_rng(5).chisquare(30, dataset["response"].shape) / 30 * 1e-8
    var[1] *= 100.0
    return dataset.assign(noise_var=(dataset["response"].dims, var))


@pytest.mark.parametrize("structure", ["act", "sen"])
def test_weighted_problem_matches_reference(weighted, structure):
    """The noise weights (the reference computes its own from the data set): the operator,
    the least-squares and the minimax optima agree."""
    problem = make_problem(weighted, structure, 1)
    assert problem.weights is not None
    theta = np.random.default_rng(3).standard_normal(problem.n_parameters)
    want = reference_errors(problem, theta)
    assert np.abs(problem.errors(theta) - want).max() <= 1e-12 * np.abs(want).max()
    value_ref, theta_ref = least_squares_reference(problem, **TIGHT)
    result = LeastSquares().fit(problem, ClarabelSolver())
    assert float(result.theta @ problem.gram @ result.theta) == pytest.approx(value_ref, rel=1e-6)
    np.testing.assert_allclose(result.theta, theta_ref, rtol=0, atol=1e-5 * np.abs(theta_ref).max())
    gamma_ref, _ = minimax_reference(problem)
    full = Minimax(working_set=False, tie_tol=0).fit(problem, ClarabelSolver())
    assert full.gamma == pytest.approx(gamma_ref, rel=1e-6)
    # and the weights matter: the unweighted optimum is another one (by more than ten times
    # the agreement asked for above)
    plain = make_problem(weighted.drop_vars("noise_var"), structure, 1)
    other = LeastSquares().fit(plain, ClarabelSolver())
    assert np.abs(other.theta - result.theta).max() > 1e-4 * np.abs(theta_ref).max()


def test_reference_raises_unless_optimal(dataset):
    problem = make_problem(dataset, "act", 1)
    sol = solve_reference(problem, "least-squares", max_iter=2)
    assert sol.status != "optimal"
    with pytest.raises(SolverError) as info:
        least_squares_reference(problem, max_iter=2)
    assert info.value.status == sol.status
    assert sol.status in str(info.value)
