r"""How uncertain a least-squares fit is: the covariance of the stiffness parameters.

The least-squares fit minimises ``Σ_i ||G_i θ||²`` over the scaled unknowns ``θ`` (the rows
``G_i`` of data point ``i`` are linear in its measured response;
:mod:`sysid_core.identification.problem`) subject to the structural constraints, of which the mass
normalisation ``M ⪰ I`` is always active (it fixes the scale of the homogeneous problem). Near the
optimum the fit therefore behaves like least squares with the active constraints as equalities:
with ``N`` a basis of the directions they leave free, ``θ = θ̂ + N z``.

The covariance is the cluster-robust sandwich with one cluster per data point (the 8 real
equation errors of a point share its noise) and the leverage correction of Bell and
McCaffrey ("CR2"):

.. math::

    \operatorname{Cov}(z) = H^{-1} \Big(\sum_i A_i^T (I - P_{ii})^{-1/2} r_i r_i^T
    (I - P_{ii})^{-1/2} A_i\Big) H^{-1},
    \quad A_i = G_i N,\ H = \sum_i A_i^T A_i,\ P_{ii} = A_i H^{-1} A_i^T,

with ``r_i = G_i θ̂`` the equation errors. It needs no noise model: the residuals themselves
say how large the errors are, point by point (the noise is not the same everywhere: the
equation error of a point is the noise times the model's ``Z`` there). Without the leverage
correction the intervals were 10-30 % too narrow on the cloverleaf (the resonance points
carry most of the information and their residuals are shrunk by the fit); see
``docs/confidence.md`` for the measurements.

:func:`stiffness_factor` turns ``Cov(θ)`` into a square root ``F`` of the covariance
``F Fᵀ`` of the physical stiffness parameters (``M``, ``K0`` and every ``K_p``), which is all
the tuning criteria use. It is kept as a factor: ``K0`` and ``M`` are strongly correlated
(both move with the overall scale ``ω0²``) and the split depends on ``K0 - λ M``, a
difference about 1e-4 of either; the physical covariance matrix itself, once decomposed
again, loses it to rounding (measured: bias intervals 10× too wide), while the factor maps the
well-scaled unknowns linearly and exactly.
"""

from __future__ import annotations

import numpy as np

from sysid_core.conic.program import sym
from sysid_core.identification.problem import FitProblem

__all__ = [
    "ACTIVE_TOL",
    "active_constraint_rows",
    "stiffness_factor",
    "stiffness_map",
    "stiffness_names",
    "theta_covariance",
]

#: An eigenvalue within this (relative) distance of its bound makes the constraint active.
ACTIVE_TOL = 1e-6


def _block_rows(x: np.ndarray, start: int, n: int, bound: float, scale: float) -> list[np.ndarray]:
    """Rows of the linear equalities of a 2×2 block ``x ⪰ bound·I`` that is active.

    Both eigenvalues at the bound: the block is fixed (3 rows). One: ``uᵀ X u`` is fixed along
    its eigenvector ``u`` (1 row, the constraint's tangent).
    """
    lam, vec = np.linalg.eigh(x)
    active = [i for i in range(2) if lam[i] - bound <= ACTIVE_TOL * scale]
    rows = []
    if len(active) == 2:
        for k in range(3):
            row = np.zeros(n)
            row[start + k] = 1.0
            rows.append(row)
    elif len(active) == 1:
        u = vec[:, active[0]]
        row = np.zeros(n)
        row[start : start + 3] = [u[0] ** 2, 2 * u[0] * u[1], u[1] ** 2]
        rows.append(row)
    return rows


def active_constraint_rows(problem: FitProblem, theta: np.ndarray) -> np.ndarray:
    """The active structural constraints at ``theta`` as linear equalities, ``(k, n)``.

    Checked: ``M ⪰ I`` and ``K_p ⪯ 0`` (the damping and stiffness bounds sit far below any
    fitted value).
    """
    lay, n = problem.layout, problem.layout.n
    rows = _block_rows(sym(theta[lay.M]), lay.M.start, n, 1.0, 1.0)
    for p in range(lay.n_electrodes):
        k = sym(theta[lay.K(p)])
        scale = float(np.abs(k).max()) or 1.0
        rows += _block_rows(-k, lay.K(p).start, n, 0.0, scale)
    return np.array(rows).reshape(-1, n)


def _inverse_sqrt(a: np.ndarray) -> np.ndarray:
    """``a^{-1/2}`` of each symmetric PSD block of ``a`` (``(k, m, m)``); eigenvalues floored."""
    lam, vec = np.linalg.eigh(a)
    root = 1.0 / np.sqrt(np.clip(lam, 1e-6, None))
    return (vec * root[:, None, :]) @ np.transpose(vec, (0, 2, 1))


def theta_covariance(problem: FitProblem, theta: np.ndarray) -> np.ndarray | None:
    """Covariance of the scaled unknowns of a least-squares fit (CR2 sandwich, module doc).

    Returns ``None`` if the free directions are not identified by the data (a singular
    normal matrix: too few points for the unknowns).
    """
    theta = np.asarray(theta, dtype=float)
    rows = active_constraint_rows(problem, theta)
    if rows.shape[0]:
        _, sv, vt = np.linalg.svd(rows)
        rank = int(np.sum(sv > 1e-12 * sv.max()))
        basis = vt[rank:].T
    else:
        basis = np.eye(problem.layout.n)
    g = problem.G  # (N, 8, n)
    a = g @ basis  # (N, 8, k)
    flat = a.reshape(-1, a.shape[-1])
    h = flat.T @ flat
    if not np.all(np.isfinite(h)) or np.linalg.cond(h) > 1e14:
        return None
    h_inv = np.linalg.inv(h)
    leverage = (a @ h_inv) @ np.transpose(a, (0, 2, 1))  # (N, 8, 8)
    r = g @ theta  # (N, 8)
    adjusted = (_inverse_sqrt(np.eye(8)[None] - leverage) @ r[:, :, None])[:, :, 0]
    scores = (np.transpose(a, (0, 2, 1)) @ adjusted[:, :, None])[:, :, 0]  # (N, k)
    cov_z = h_inv @ (scores.T @ scores) @ h_inv
    cov = basis @ cov_z @ basis.T
    return 0.5 * (cov + cov.T)


def stiffness_names(electrodes: list[str], quadratic: bool = False) -> list[str]:
    """Names of the stiffness parameters, in :func:`stiffness_map` order."""
    names = [f"M{ij}" for ij in ("11", "12", "22")] + [f"K0_{ij}" for ij in ("11", "12", "22")]
    names += [f"K_{e}_{ij}" for e in electrodes for ij in ("11", "12", "22")]
    if quadratic:
        names += [f"L_{e}_{ij}" for e in electrodes for ij in ("11", "12", "22")]
    return names


def stiffness_map(problem: FitProblem) -> np.ndarray:
    """The linear map from the scaled unknowns to the physical stiffness parameters.

    Rows: ``M`` (m11, m12, m22), ``K0`` ((rad/s)²), then each ``K_p`` ((rad/s)²/V²), then
    each ``L_p`` ((rad/s)²/V⁴, quadratic law only), each as (11, 12, 22); columns: ``theta``.
    The same map as :func:`sysid_core.identification.fitting.model_from_problem`.
    """
    s, lay = problem.scaling, problem.layout
    n_e = lay.n_electrodes
    t = np.zeros((6 + 3 * n_e + (3 * n_e if lay.quadratic else 0), lay.n))
    eye = np.eye(3)
    t[0:3, lay.M] = eye
    t[3:6, lay.M] = s.omega0**2 * eye
    t[3:6, lay.D] = s.omega0**2 * s.eps * eye
    kappa = s.omega0**2 * s.eps
    lin, quad = s.w_polynomials()
    for p in range(n_e):
        t[3:6, lay.K(p)] = kappa * lin[p, 0] * eye
        t[6 + 3 * p : 9 + 3 * p, lay.K(p)] = kappa * lin[p, 1] * eye
    if lay.quadratic:
        assert quad is not None
        for p in range(n_e):
            t[3:6, lay.L(p)] = kappa * quad[p, 0] * eye
            t[6 + 3 * p : 9 + 3 * p, lay.L(p)] = kappa * quad[p, 1] * eye
            t[6 + 3 * n_e + 3 * p : 9 + 3 * n_e + 3 * p, lay.L(p)] = kappa * quad[p, 2] * eye
    return t


def stiffness_factor(problem: FitProblem, covariance: np.ndarray) -> np.ndarray:
    """A square root ``F`` (``F Fᵀ`` = covariance) of the physical stiffness parameters.

    ``F = T L`` with ``T`` the :func:`stiffness_map` restricted to the unknowns it uses and
    ``L`` the symmetric square root of their (well-scaled) covariance.
    """
    t = stiffness_map(problem)
    used = np.flatnonzero(np.any(t != 0, axis=0))
    sub = covariance[np.ix_(used, used)]
    lam, vec = np.linalg.eigh(0.5 * (sub + sub.T))
    root = vec * np.sqrt(np.clip(lam, 0.0, None))
    return t[:, used] @ root
