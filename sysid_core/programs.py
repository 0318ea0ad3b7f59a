"""Assembly of the fit's conic programs from a :class:`~sysid_core.problem.FitProblem`.

* :func:`minimax_program`: eq. (8)/(10), ``min γ`` s.t. σ̄(E_i) ≤ γ on the given points, plus
  the structural constraints ``M ⪰ I``, ``C ⪰ εI``, ``K_p ⪯ 0``, ``K(w_k) ⪰ εI``.
  Variables ``[theta, gamma, slacks]`` (the slacks are the free anti-Hermitian parts of the
  LMIs, see :meth:`FitProblem.minimax_rows`).
* :func:`least_squares_program`: ``min Σ_i ||E_i||_F²`` s.t. the structural constraints.
  Variables ``[theta, t]``.
* :func:`tie_break_program`: ``min Σ_i ||E_i||_F²`` s.t. σ̄(E_i) ≤ γ_b on the given points and
  the structural constraints: picks one point among the (non-unique) minimax optima.
  Variables ``[theta, gamma, t, slacks]``.

The squared sum is minimised through its square root, ``min t`` s.t. ``||L theta|| ≤ t`` with
``L^T L = gram / objective_scale`` (one second-order cone): measured here, the equivalent QP form
``min theta^T gram theta`` ends "AlmostSolved"/"MaxIterations" in Clarabel when the noise is small,
because its optimum is then tiny and the mass normalisation ``M ⪰ I`` is active; the cone form
solves in about 8 iterations at every noise level.
"""

from __future__ import annotations

import numpy as np
import scipy.sparse as sp

from sysid_core.conic import ConeDims, ConicProgram
from sysid_core.problem import FitProblem

__all__ = ["least_squares_program", "minimax_program", "tie_break_program"]


def _slack_count(problem: FitProblem, points: np.ndarray) -> int:
    return problem.SLACK_PER_POINT * len(points)


def _sum_of_squares_rows(problem: FitProblem, n_x: int, t_col: int) -> sp.csr_matrix:
    """Rows of the cone ``(t, L theta)`` with ``L^T L = gram / objective_scale``."""
    n = problem.n_parameters
    w, v = np.linalg.eigh(problem.gram / problem.objective_scale)
    root = (v * np.sqrt(np.clip(w, 0.0, None))).T
    a = np.zeros((n + 1, n_x))
    a[0, t_col] = -1.0
    a[1:, :n] = -root
    return sp.csr_matrix(a)


def minimax_program(problem: FitProblem, points: np.ndarray) -> ConicProgram:
    """The minimax program (8) restricted to ``points``; variables ``[theta, gamma, slacks]``."""
    n = problem.n_parameters
    n_x = n + 1 + _slack_count(problem, points)
    a_s, b_s, psd_s = problem.structural_constraints(n_x)
    a_p = problem.minimax_rows(points, n_x, gamma_col=n, slack_col=n + 1)
    c = np.zeros(n_x)
    c[n] = 1.0
    return ConicProgram(
        c=c,
        A=sp.vstack([a_s, a_p], format="csc"),
        b=np.concatenate([b_s, np.zeros(a_p.shape[0])]),
        cones=ConeDims(psd=tuple(psd_s) + (8,) * len(points)),
        meta={"kind": "minimax", "points": len(points)},
    )


def least_squares_program(problem: FitProblem) -> ConicProgram:
    """Constrained least squares over all points; variables ``[theta, t]``."""
    n = problem.n_parameters
    n_x = n + 1
    a_s, b_s, psd_s = problem.structural_constraints(n_x)
    c = np.zeros(n_x)
    c[n] = 1.0
    return ConicProgram(
        c=c,
        A=sp.vstack([_sum_of_squares_rows(problem, n_x, n), a_s], format="csc"),
        b=np.concatenate([np.zeros(n + 1), b_s]),
        cones=ConeDims(soc=(n + 1,), psd=tuple(psd_s)),
        meta={"kind": "least-squares", "points": problem.n_points},
    )


def tie_break_program(
    problem: FitProblem,
    points: np.ndarray,
    gamma_bound: float,
    scale: float | None = None,
) -> ConicProgram:
    """Least squares among the parameters with σ̄(E_i) ≤ ``gamma_bound`` on ``points``.

    Variables ``[theta, gamma, slacks]``; the objective is the quadratic
    ``theta^T gram theta / scale``; pass as ``scale`` its value at the minimax solution so that
    the optimum is O(1) (default :attr:`FitProblem.objective_scale`).
    """
    scale = problem.objective_scale if scale is None else scale
    n = problem.n_parameters
    n_x = n + 1 + _slack_count(problem, points)
    a_s, b_s, psd_s = problem.structural_constraints(n_x)
    a_p = problem.minimax_rows(points, n_x, gamma_col=n, slack_col=n + 1)
    bound = sp.csr_matrix(([1.0], ([0], [n])), shape=(1, n_x))
    p = sp.block_diag(
        [2.0 * problem.gram / scale, sp.csc_matrix((n_x - n, n_x - n))],
        format="csc",
    )
    return ConicProgram(
        c=np.zeros(n_x),
        A=sp.vstack([bound, a_s, a_p], format="csc"),
        b=np.concatenate([[gamma_bound], b_s, np.zeros(a_p.shape[0])]),
        cones=ConeDims(nonneg=1, psd=tuple(psd_s) + (8,) * len(points)),
        P=p,
        meta={"kind": "tie-break", "points": len(points), "gamma_bound": gamma_bound},
    )
