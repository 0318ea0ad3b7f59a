"""Assembly of the fit's conic programs from a :class:`~sysid_core.problem.FitProblem`.

Three programs, over ``x = theta`` or ``x = [theta, gamma, slacks]`` (the slacks are the
free anti-Hermitian parts of the LMIs, see :meth:`FitProblem.minimax_rows`):

* :func:`minimax_program`: eq. (8)/(10), ``min γ`` s.t. σ̄(E_i) ≤ γ on the given points, plus
  the structural constraints ``M ⪰ I``, ``C ⪰ εI``, ``K_p ⪯ 0``, ``K(w_k) ⪰ εI``.
* :func:`least_squares_program`: ``min Σ_i ||E_i||_F² / N`` s.t. the structural constraints
  (a QP with 2x2 PSD cones).
* :func:`tie_break_program`: ``min Σ_i ||E_i||_F² / N`` s.t. σ̄(E_i) ≤ γ_b on the given points
  and the structural constraints: picks one point among the (non-unique) minimax optima.
"""

from __future__ import annotations

import numpy as np
import scipy.sparse as sp

from sysid_core.conic import ConeDims, ConicProgram
from sysid_core.problem import FitProblem

__all__ = ["least_squares_program", "minimax_program", "tie_break_program"]


def _n_x(problem: FitProblem, points: np.ndarray) -> int:
    return problem.n_parameters + 1 + problem.SLACK_PER_POINT * len(points)


def minimax_program(problem: FitProblem, points: np.ndarray) -> ConicProgram:
    """The minimax program (8) restricted to ``points``; variables ``[theta, gamma, slacks]``."""
    n, n_x = problem.n_parameters, _n_x(problem, points)
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
    """The constrained least-squares program over all points; variables ``theta``."""
    n = problem.n_parameters
    a_s, b_s, psd_s = problem.structural_constraints(n)
    return ConicProgram(
        c=np.zeros(n),
        A=sp.csc_matrix(a_s),
        b=b_s,
        cones=ConeDims(psd=tuple(psd_s)),
        P=sp.csc_matrix(2.0 * problem.gram),
        meta={"kind": "least-squares", "points": problem.n_points},
    )


def tie_break_program(problem: FitProblem, points: np.ndarray, gamma_bound: float) -> ConicProgram:
    """Least squares among the parameters with σ̄(E_i) ≤ ``gamma_bound`` on ``points``."""
    n, n_x = problem.n_parameters, _n_x(problem, points)
    a_s, b_s, psd_s = problem.structural_constraints(n_x)
    a_p = problem.minimax_rows(points, n_x, gamma_col=n, slack_col=n + 1)
    bound = sp.csr_matrix(([1.0], ([0], [n])), shape=(1, n_x))
    p = sp.block_diag([2.0 * problem.gram, sp.csc_matrix((n_x - n, n_x - n))], format="csc")
    return ConicProgram(
        c=np.zeros(n_x),
        A=sp.vstack([bound, a_s, a_p], format="csc"),
        b=np.concatenate([[gamma_bound], b_s, np.zeros(a_p.shape[0])]),
        cones=ConeDims(nonneg=1, psd=tuple(psd_s) + (8,) * len(points)),
        P=p,
        meta={"kind": "tie-break", "points": len(points), "gamma_bound": gamma_bound},
    )
