"""Assembly of the fit's conic programs from a fit problem.

Each program is built from a :class:`~sysid_core.identification.problem.FitProblem`:

* :func:`minimax_program`: eq. (8)/(10), ``min γ`` s.t. σ̄(E_i) ≤ γ on the given points, plus
  the structural constraints ``M ⪰ I``, ``C ⪰ εI``, ``K_p ⪯ 0``, ``K(w_k) ⪰ εI``.
  Variables ``[theta, gamma, slacks]`` (the slacks are the free anti-Hermitian parts of the
  LMIs, see :func:`minimax_rows`).
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

from typing import cast

import numpy as np
import scipy.sparse as sp

from sysid_core.conic.program import SQRT2, SVEC_SYM, ConeDims, ConicProgram, svec_indices
from sysid_core.identification.problem import EPS_DAMPING, EPS_STIFFNESS, FitProblem

__all__ = [
    "SLACK_PER_POINT",
    "least_squares_program",
    "minimax_program",
    "minimax_rows",
    "structural_constraints",
    "tie_break_program",
]

#: Extra free variables per point in :func:`minimax_rows` (the anti-Hermitian slack).
SLACK_PER_POINT = 20


def structural_constraints(
    problem: FitProblem, n_x: int
) -> tuple[sp.csr_matrix, np.ndarray, list[int]]:
    """Rows ``(A, b)`` and PSD sizes for M ⪰ I, C ⪰ εI, K_p ⪯ 0 and K(w_k) ⪰ εI.

    ``n_x`` is the number of variables (``theta`` first); all cones are 2x2 PSD.
    """
    lay = problem.layout
    eye_svec = np.array([1.0, 0.0, 1.0])
    blocks: list[tuple[list[tuple[slice, np.ndarray]], np.ndarray]] = [
        ([(lay.M, -SVEC_SYM)], -eye_svec),
        ([(lay.C, -SVEC_SYM)], -EPS_DAMPING * eye_svec),
    ]
    blocks += [([(lay.K(p), SVEC_SYM)], np.zeros(3)) for p in range(lay.n_electrodes)]
    eps = problem.scaling.eps
    qs = problem.scaled_q() if lay.quadratic else None
    for k, wk in enumerate(problem.scaled_w()):
        terms = [(lay.M, -SVEC_SYM), (lay.D, -eps * SVEC_SYM)]
        terms += [(lay.K(p), -eps * wk[p] * SVEC_SYM) for p in range(lay.n_electrodes)]
        if qs is not None:
            terms += [(lay.L(p), -eps * qs[k, p] * SVEC_SYM) for p in range(lay.n_electrodes)]
        blocks.append((terms, -EPS_STIFFNESS * eye_svec))
    a = np.zeros((3 * len(blocks), n_x))
    b = np.zeros(3 * len(blocks))
    for i, (terms, off) in enumerate(blocks):
        for sl, mat in terms:
            a[3 * i : 3 * i + 3, sl] = mat
        b[3 * i : 3 * i + 3] = off
    return sp.csr_matrix(a), b, [2] * len(blocks)


def minimax_rows(
    problem: FitProblem,
    points: np.ndarray,
    n_x: int,
    gamma_col: int,
    slack_col: int,
) -> sp.csr_matrix:
    """Rows of the LMIs σ̄(E_i) ≤ γ for the given points, as 8x8 real PSD cones.

    σ̄(E) ≤ γ iff the Hermitian ``H = [[γI, E^H], [E, γI]] = A + jB ⪰ 0``, iff its real
    embedding ``X = [[A, -B], [B, A]] ⪰ 0`` (rows ordered Re v, Im v). ``X`` commutes with
    the complex structure ``J = [[0, -I], [I, 0]]``, and the dual of such a cone is degenerate
    in the 20 directions that anticommute with ``J``: interior-point solvers then stall
    (Clarabel ends "AlmostSolved" on noisy data). The cone is therefore written
    ``X + N ⪰ 0`` with a free ``N = [[Cn, Dn], [Dn, -Cn]]`` (``Cn``, ``Dn`` symmetric 4x4),
    which is equivalent (average with ``J^T (X + N) J = X - N``) and removes the degeneracy.
    The ``N`` of point ``i`` takes columns ``slack_col + 20 i ...``; ``b`` of these rows is 0.
    """
    points = np.asarray(points, dtype=np.int64)
    k, n = points.size, problem.layout.n
    idx = svec_indices(8)
    # Entries of X driven by E: (row, col, G-row, sign)
    spec: list[tuple[int, int, int, float]] = []
    for a in (0, 1):
        for bb in (0, 1):
            spec.append((2 + a, bb, 2 * a + bb, 1.0))  # A: Re E
            spec.append((6 + a, 4 + bb, 2 * a + bb, 1.0))  # A again
            spec.append((6 + a, bb, 4 + 2 * a + bb, 1.0))  # B[2+a, b] = Im E[a, b]
            spec.append((4 + a, 2 + bb, 4 + 2 * bb + a, -1.0))  # B[a, 2+b] = -Im E[b, a]
    rows_e = np.array([idx[r, c] for r, c, _, _ in spec])
    grow = [g for _, _, g, _ in spec]
    sign = np.array([sg for _, _, _, sg in spec])
    coef = problem.G[points][:, grow, :] * (-SQRT2 * sign)[None, :, None]
    base = (np.arange(k) * 36)[:, None]
    r_e = np.broadcast_to((base + rows_e)[:, :, None], coef.shape)
    c_e = np.broadcast_to(np.arange(n)[None, None, :], coef.shape)
    diag_rows = base + np.array([idx[d, d] for d in range(8)])[None, :]
    # Slack N: (row, local column, coefficient in A)
    slack: list[tuple[int, int, float]] = []
    j = 0
    for r in range(4):
        for c in range(r + 1):
            sc = 1.0 if r == c else SQRT2
            slack += [(idx[r, c], j, -sc), (idx[4 + r, 4 + c], j, sc)]
            j += 1
    for r in range(4):
        for c in range(r + 1):
            slack.append((idx[4 + r, c], j, -SQRT2))
            if r != c:
                slack.append((idx[4 + c, r], j, -SQRT2))
            j += 1
    s_rows = base + np.array([t[0] for t in slack])[None, :]
    s_cols = (
        slack_col
        + (np.arange(k) * SLACK_PER_POINT)[:, None]
        + np.array([t[1] for t in slack])[None, :]
    )
    s_vals = np.broadcast_to(np.array([t[2] for t in slack])[None, :], s_rows.shape)
    rows = np.concatenate([r_e.ravel(), diag_rows.ravel(), s_rows.ravel()])
    cols = np.concatenate([c_e.ravel(), np.full(diag_rows.size, gamma_col), s_cols.ravel()])
    vals = np.concatenate([coef.ravel(), np.full(diag_rows.size, -1.0), s_vals.ravel()])
    keep = vals != 0
    return sp.csr_matrix((vals[keep], (rows[keep], cols[keep])), shape=(36 * k, n_x))


def _slack_count(problem: FitProblem, points: np.ndarray) -> int:
    return SLACK_PER_POINT * len(points)


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
    a_s, b_s, psd_s = structural_constraints(problem, n_x)
    a_p = minimax_rows(problem, points, n_x, gamma_col=n, slack_col=n + 1)
    c = np.zeros(n_x)
    c[n] = 1.0
    return ConicProgram(
        c=c,
        A=sp.vstack([a_s, a_p], format="csc"),
        b=np.concatenate([b_s, np.zeros(a_p.shape[0])]),
        cones=ConeDims(psd=tuple(psd_s) + (8,) * len(points)),
    )


def least_squares_program(problem: FitProblem) -> ConicProgram:
    """Constrained least squares over all points; variables ``[theta, t]``."""
    n = problem.n_parameters
    n_x = n + 1
    a_s, b_s, psd_s = structural_constraints(problem, n_x)
    c = np.zeros(n_x)
    c[n] = 1.0
    return ConicProgram(
        c=c,
        A=sp.vstack([_sum_of_squares_rows(problem, n_x, n), a_s], format="csc"),
        b=np.concatenate([np.zeros(n + 1), b_s]),
        cones=ConeDims(soc=(n + 1,), psd=tuple(psd_s)),
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
    a_s, b_s, psd_s = structural_constraints(problem, n_x)
    a_p = minimax_rows(problem, points, n_x, gamma_col=n, slack_col=n + 1)
    bound = sp.csr_matrix(([1.0], ([0], [n])), shape=(1, n_x))
    # A csc_matrix: scipy returns a sparse array only when some block is one, and here the blocks
    # are dense and csc_matrix; scipy-stubs cannot tell that from a mixed list.
    p = cast(
        "sp.csc_matrix",
        sp.block_diag(
            [2.0 * problem.gram / scale, sp.csc_matrix((n_x - n, n_x - n))], format="csc"
        ),
    )
    return ConicProgram(
        c=np.zeros(n_x),
        A=sp.vstack([bound, a_s, a_p], format="csc"),
        b=np.concatenate([[gamma_bound], b_s, np.zeros(a_p.shape[0])]),
        cones=ConeDims(nonneg=1, psd=tuple(psd_s) + (8,) * len(points)),
        P=p,
    )
