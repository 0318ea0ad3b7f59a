"""The tuning criteria's eigenvalue-spread program (a small SDP in the squared potentials).

All three criteria are convex in ``w``: with ``K(w) = K0 + sum_p K_p w_p``,

* degenerate (eq. 14, spread form): ``min t`` s.t. ``mu M ⪯ K~(w) ⪯ (mu + t) M``;
* target (eq. 23, bounding the frequency error): ``min t`` s.t. ``(m0 - t) M ⪯ K~(w) ⪯
  (m0 + t) M``;
* smallest largest bias: the degenerate program on a shrinking box of ``w`` (bisection).

Numerics: the programs are written for ``K~(w) = (K(w) - lam_ref M) / (lam_ref d)`` with
``lam_ref`` the mean eigenvalue at the centre of the box and ``d = 1e-3``, so a 1 mHz split is
O(1e-4) rather than O(1e-7) of the matrix entries. A model extrapolated over wide limits can
have no oscillating modes at that centre (``lam_ref <= 0``, electrodes that soften): the spread
is still ``|lam_ref| d`` times the scaled one, and the tie-break's tolerance in Hz is read at the
band's centre, ``omega_center``.
"""

from __future__ import annotations

import numpy as np
import scipy.sparse as sp

from sysid_core.conic.program import ConeDims, ConicProgram, Solver, SolveStatus, svec2
from sysid_core.errors import SolverError
from sysid_core.model.fitted import FittedModel
from sysid_core.model.modal import normalised_stiffness, trace_deviation

__all__ = ["solve_spread", "spread_program"]

_D = 1e-3


class _Scaled:
    """The model's stiffness in the well-conditioned coordinates of the module docstring."""

    def __init__(self, model: FittedModel, box: np.ndarray) -> None:
        self.model = model
        self.box = box
        self.w_c = box.mean(axis=1)
        self.w_s = np.maximum((box[:, 1] - box[:, 0]) / 2, 1e-12)
        k_c = model.stiffness_w(self.w_c)
        # the mean of the generalized eigenvalues of (K, M): the trace of M^-1/2 K M^-1/2 / 2
        t, _ = trace_deviation(normalised_stiffness(model.M[None], k_c[None]))
        self.lam_ref = float(t[0])
        self.k_c = (k_c - self.lam_ref * model.M) / (self.lam_ref * _D)
        self.k_p = model.Kp * (self.w_s / (self.lam_ref * _D))[:, None, None]

    def w(self, u: np.ndarray) -> np.ndarray:
        """Squared potentials from the scaled variables ``u`` in [-1, 1]."""
        return self.w_c + self.w_s * u

    def hz(self, t: float) -> float:
        """An eigenvalue spread ``t`` (scaled) as a frequency difference near ``lam_ref`` (Hz)."""
        lam = self.lam_ref
        return float((np.sqrt(lam + t * lam * _D) - np.sqrt(lam)) / (2 * np.pi))

    def lam(self, mu: float) -> float:
        """A scaled eigenvalue offset ``mu`` as an eigenvalue."""
        return self.lam_ref * (1 + _D * mu)


def spread_program(
    model: FittedModel,
    box: np.ndarray,
    target_lam: float | None = None,
    bound: float | None = None,
    anchor_w: np.ndarray | None = None,
) -> tuple[ConicProgram, _Scaled]:
    """The eigenvalue-spread program in scaled variables ``x = [u (n_t), mu, t]``.

    Without ``target_lam``: ``min t`` s.t. ``mu M ⪯ K~(w) ⪯ (mu + t) M`` (degenerate, eq. 14
    in its spread form). With ``target_lam``: ``min t`` s.t. ``(m0 - t) M ⪯ K~(w) ⪯ (m0 + t) M``
    where ``m0`` is the target (eq. 23 in a form that bounds the frequency error directly).
    With ``bound`` and ``anchor_w``: ``min ||(w - anchor_w)/s||^2`` s.t. ``t <= bound`` (the
    smallest change among near-optimal points, used to pick a unique answer).
    """
    sc = _Scaled(model, box)
    n_t = box.shape[0]
    n_x = n_t + 2
    iu, imu, it = slice(0, n_t), n_t, n_t + 1
    rows_a: list[np.ndarray] = []
    rows_b: list[np.ndarray] = []
    # Box: -1 <= u <= 1  ->  1 - u >= 0, 1 + u >= 0
    a_box = np.zeros((2 * n_t, n_x))
    a_box[:n_t, iu] = np.eye(n_t)
    a_box[n_t:, iu] = -np.eye(n_t)
    b_box = np.ones(2 * n_t)
    m_sv = svec2(model.M)
    kc_sv = svec2(sc.k_c)
    kp_sv = np.array([svec2(k) for k in sc.k_p]).T  # (3, n_t)
    # Lower: K~(w) - low*M ⪰ 0 ; upper: high*M - K~(w) ⪰ 0 ; s = b - A x
    lower = np.zeros((3, n_x))
    upper = np.zeros((3, n_x))
    lower[:, iu] = -kp_sv
    upper[:, iu] = kp_sv
    if target_lam is None:
        lower[:, imu] = m_sv  # - (-mu M)
        upper[:, imu] = -m_sv
        upper[:, it] = -m_sv
        b_low, b_up = kc_sv, -kc_sv
    else:
        m0 = (target_lam / sc.lam_ref - 1) / _D
        lower[:, it] = -m_sv  # K~ - (m0 - t) M
        upper[:, it] = -m_sv  # (m0 + t) M - K~
        b_low, b_up = kc_sv - m0 * m_sv, m0 * m_sv - kc_sv
    rows_a += [lower, upper]
    rows_b += [b_low, b_up]
    nonneg_a, nonneg_b = [a_box], [b_box]
    c = np.zeros(n_x)
    p = None
    if bound is None:
        c[it] = 1.0
    else:
        cap = np.zeros((1, n_x))
        cap[0, it] = 1.0
        nonneg_a.append(cap)
        nonneg_b.append(np.array([bound]))
        anchor_u = (np.asarray(anchor_w) - sc.w_c) / sc.w_s
        diag = np.zeros(n_x)
        diag[iu] = 2.0
        p = sp.diags(diag, format="csc")
        c[iu] = -2.0 * anchor_u
    a = np.vstack(nonneg_a + rows_a)
    b = np.concatenate(nonneg_b + rows_b)
    n_nonneg = sum(x.shape[0] for x in nonneg_a)
    prog = ConicProgram(
        c=c, A=sp.csc_matrix(a), b=b, cones=ConeDims(nonneg=n_nonneg, psd=(2, 2)), P=p
    )
    return prog, sc


def solve_spread(
    model: FittedModel,
    box: np.ndarray,
    solver: Solver,
    target_lam: float | None = None,
    anchor_w: np.ndarray | None = None,
    tie_tol_hz: float = 1e-5,
) -> tuple[np.ndarray, float]:
    """Minimise the spread (or target error); return ``(w, optimal value in Hz)``.

    With ``anchor_w`` and more than two tuned electrodes, the answer is the point closest to
    ``anchor_w`` (scaled) among those within ``tie_tol_hz`` of the optimum: unique. If that
    second program fails in the solver (seen with Clarabel, "InsufficientProgress", when the
    near-optimal set is a thin sliver far from the anchor), the first answer, also optimal, is
    kept.
    """
    prog, sc = spread_program(model, box, target_lam)
    try:
        x = solver.solve(prog).x
    except SolverError as exc:
        # An inaccurate end ("AlmostSolved", 4 of 100 random gyros' min-max runs) still gives a
        # point inside the box; every caller recomputes the split there from the model, so it
        # is used as an answer that is checked, not trusted.
        if exc.status is not SolveStatus.INACCURATE or exc.x is None:
            raise
        x = np.asarray(exc.x)
    n_t = box.shape[0]
    u, t = x[:n_t], float(x[n_t + 1])
    if anchor_w is not None and n_t > 2:
        # t (scaled) that corresponds to tie_tol_hz more spread, near the modes' own eigenvalue:
        # the box centre's where the model has oscillating modes there, else the band centre's
        # (a model whose electrodes soften can have none at the centre of a wide box)
        lam = sc.lam_ref if sc.lam_ref > 0 else model.omega_center**2
        dt = ((np.sqrt(lam) + 2 * np.pi * tie_tol_hz) ** 2 - lam) / (abs(sc.lam_ref) * _D)
        prog2, _ = spread_program(model, box, target_lam, bound=t + dt, anchor_w=anchor_w)
        try:
            u = solver.solve(prog2).x[:n_t]
        except SolverError:
            pass  # keep the optimal (if not unique) answer of the first program
    w = np.clip(sc.w(np.clip(u, -1.0, 1.0)), box[:, 0], box[:, 1])
    return w, t
