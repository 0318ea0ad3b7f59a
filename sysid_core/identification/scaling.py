"""The scaled unknowns of a fit: their layout in ``theta`` and the constants that scale them.

See :mod:`sysid_core.identification.problem` for the scaling's equations; this module holds the
bookkeeping (:class:`ParameterLayout`) and the constants chosen from the data (:class:`Scaling`),
including the quadratic stiffness law's orthogonal basis.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from sysid_core.conic.program import sigma_max_2x2

__all__ = ["ParameterLayout", "Scaling"]


@dataclass(frozen=True)
class ParameterLayout:
    """Positions of the scaled unknowns in ``theta``.

    Order: ``M`` (3: m11, m12, m22), ``C~`` (3), ``D~0`` (3), ``K~_p`` (3 per electrode), then per
    polynomial degree ``l``: real parts of ``P~_l`` (4, row-major) and imaginary parts (4); then,
    for ``l < bias_terms`` and each electrode ``p``, the 8 reals of ``P~_{l,p}``; then, with a
    quadratic stiffness law, ``L~_p`` (3 per electrode); last, the drift terms: a common offset
    ``δ_e`` per earlier epoch (1 each: the stiffness of epoch ``e`` is the latest one's plus
    ``δ_e`` times the mass's shape) and, with a trend, ``D~_t`` (3).
    """

    n_electrodes: int
    order: int
    bias_terms: int = 0
    quadratic: bool = False
    n_offsets: int = 0
    trend: bool = False

    @property
    def n_z(self) -> int:
        """Number of unknowns of ``Z`` (real)."""
        return 9 + 3 * self.n_electrodes

    @property
    def n(self) -> int:
        """Total number of real unknowns."""
        return self._n_before_offsets + self.n_offsets + (3 if self.trend else 0)

    @property
    def _n_before_offsets(self) -> int:
        return self._n_before_l + (3 * self.n_electrodes if self.quadratic else 0)

    @property
    def _n_before_l(self) -> int:
        return self.n_z + 8 * (self.order + 1) + 8 * self.bias_terms * self.n_electrodes

    M = slice(0, 3)
    C = slice(3, 6)
    D = slice(6, 9)

    def K(self, p: int) -> slice:
        """Slice of electrode ``p``'s stiffness."""
        return slice(9 + 3 * p, 12 + 3 * p)

    def L(self, p: int) -> slice:
        """Slice of electrode ``p``'s quadratic stiffness ``L~_p`` (quadratic law only)."""
        if not self.quadratic:
            raise IndexError("a linear stiffness law has no L_p")
        return slice(self._n_before_l + 3 * p, self._n_before_l + 3 * p + 3)

    def offset(self, e: int) -> slice:
        """Slice (of 1) of the ``e``-th earlier epoch's common offset ``δ_e``."""
        if not 0 <= e < self.n_offsets:
            raise IndexError(f"no drift offset {e} (there are {self.n_offsets})")
        start = self._n_before_offsets + e
        return slice(start, start + 1)

    @property
    def T(self) -> slice:
        """Slice of the stiffness trend ``D~_t`` (3)."""
        if not self.trend:
            raise IndexError("the fit has no trend")
        start = self._n_before_offsets + self.n_offsets
        return slice(start, start + 3)

    def poly(self, degree: int) -> slice:
        """Slice of the 8 reals of ``P~_degree`` (4 real parts then 4 imaginary parts)."""
        start = self.n_z + 8 * degree
        return slice(start, start + 8)

    def poly_w(self, degree: int, p: int) -> slice:
        """Slice of the 8 reals of ``P~_{degree,p}`` (bias-dependent term of electrode ``p``)."""
        start = self.n_z + 8 * (self.order + 1) + 8 * (degree * self.n_electrodes + p)
        return slice(start, start + 8)

    def names(self) -> list[str]:
        """Human-readable name of each unknown."""
        names = [f"{m}{ij}" for m in ("M", "C", "D0") for ij in ("11", "12", "22")]
        names += [f"K{p + 1}_{ij}" for p in range(self.n_electrodes) for ij in ("11", "12", "22")]
        for deg in range(self.order + 1):
            names += [
                f"P{deg}_{part}{ij}" for part in ("re", "im") for ij in ("11", "12", "21", "22")
            ]
        for deg in range(self.bias_terms):
            for p in range(self.n_electrodes):
                names += [
                    f"P{deg}w{p + 1}_{part}{ij}"
                    for part in ("re", "im")
                    for ij in ("11", "12", "21", "22")
                ]
        if self.quadratic:
            names += [
                f"L{p + 1}_{ij}" for p in range(self.n_electrodes) for ij in ("11", "12", "22")
            ]
        names += [f"delta{e + 1}" for e in range(self.n_offsets)]
        names += [f"T{ij}" for ij in ("11", "12", "22")] if self.trend else []
        return names


@dataclass(frozen=True)
class Scaling:
    """The constants that make the fit well conditioned (see the module docstring).

    With the quadratic stiffness law, electrode ``p``'s second regressor is not ``w_p²`` (whose
    values over a design of a few volts are nearly proportional to ``w_p``'s) but the discrete
    orthogonal polynomial ``φ_p = (x_p² − a_p − b_p x_p) / h_p`` in ``x_p = w~_p``: ``a_p, b_p``
    make it orthogonal to ``1`` and ``x_p`` over the data points, ``h_p`` scales its largest
    value to 1 (``q_basis[p] = (a_p, b_p, h_p)``). :meth:`w_polynomials` maps both regressors
    back to polynomials in ``w``.
    """

    omega0: float
    eps: float
    nu_half: float
    w_center: np.ndarray
    w_scale: np.ndarray
    psi_scale: float
    q_basis: np.ndarray | None = None

    @classmethod
    def from_data(
        cls,
        omega: np.ndarray,
        w: np.ndarray,
        psi: np.ndarray,
        experiment: np.ndarray | None = None,
    ) -> Scaling:
        """Choose the scaling for the data's frequencies, squared potentials and responses.

        The frequencies ``omega`` are in rad/s, the squared potentials ``w`` ``(n_exp, n_e)``, the
        responses ``psi`` ``(N, 2, 2)``; ``experiment`` (``(N,)``, the experiment of each point)
        weights each experiment by its points in the quadratic basis (default: equal weights).
        """
        omega0 = 0.5 * (omega.min() + omega.max())
        delta = (omega / omega0) ** 2 - 1
        eps = float(np.abs(delta).max())
        nu_half = float(np.abs(omega - omega0).max())
        w_center = w.mean(axis=0)
        spread = np.abs(w - w_center).max(axis=0)
        w_scale = np.where(spread > 0, spread, 1.0)
        psi_scale = float(np.median(sigma_max_2x2(psi))) * omega0**2 * eps
        if not np.isfinite(psi_scale) or psi_scale <= 0:
            psi_scale = 1.0
        counts = (
            np.ones(w.shape[0])
            if experiment is None
            else np.bincount(experiment, minlength=w.shape[0]).astype(float)
        )
        q_basis = _orthogonal_quadratic((w - w_center) / w_scale, counts)
        return cls(float(omega0), eps, nu_half, w_center, w_scale, psi_scale, q_basis)

    def scaled_w(self, w: np.ndarray) -> np.ndarray:
        """``x = w~ = (w − w̄) / s`` for squared potentials ``w`` (``(..., n_e)``)."""
        return (w - self.w_center) / self.w_scale

    def scaled_q(self, w: np.ndarray) -> np.ndarray:
        """The quadratic regressors ``φ_p`` for squared potentials ``w`` (``(..., n_e)``)."""
        assert self.q_basis is not None
        x = self.scaled_w(w)
        a, b, h = self.q_basis.T
        return (x**2 - a - b * x) / h

    def w_polynomials(self) -> tuple[np.ndarray, np.ndarray | None]:
        """Coefficients in ``w`` of ``w~_p`` and ``φ_p``: ``(lin, quad)``.

        ``lin[p] = (c0, c1)`` (``w~_p = c0 + c1 w_p``) and ``quad[p] = (d0, d1, d2)``
        (``φ_p = d0 + d1 w_p + d2 w_p²``), or ``quad = None`` without the quadratic basis.
        """
        c1 = 1.0 / self.w_scale
        c0 = -self.w_center * c1
        lin = np.column_stack([c0, c1])
        if self.q_basis is None:
            return lin, None
        a, b, h = self.q_basis.T
        # x² − a − b x with x = c0 + c1 w
        d0 = (c0**2 - a - b * c0) / h
        d1 = (2 * c0 * c1 - b * c1) / h
        d2 = c1**2 / h
        return lin, np.column_stack([d0, d1, d2])


def _orthogonal_quadratic(x: np.ndarray, weights: np.ndarray) -> np.ndarray:
    """Per column of ``x`` (``(n_exp, n_e)``), the ``(a, b, h)`` of its quadratic regressor.

    The regressor ``(x² − a − b x) / h`` is orthogonal to ``1`` and ``x`` under ``weights`` and
    at most 1 in magnitude. A column with fewer than three distinct values has no quadratic
    part: ``h = 1`` and the regressor is the (zero) residual; the rank condition refuses such a
    design before a fit.
    """
    out = np.zeros((x.shape[1], 3))
    sw = np.sqrt(weights / weights.sum())
    for p in range(x.shape[1]):
        basis = np.column_stack([np.ones(x.shape[0]), x[:, p]]) * sw[:, None]
        (a, b), *_ = np.linalg.lstsq(basis, x[:, p] ** 2 * sw, rcond=None)
        resid = x[:, p] ** 2 - a - b * x[:, p]
        peak = float(np.abs(resid).max())
        out[p] = (a, b, peak if peak > 1e-12 else 1.0)
    return out
