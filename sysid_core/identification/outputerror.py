r"""Output-error refinement of a one-sweep model: the least-squares fit of the response itself.

The fits of :mod:`sysid_core.identification.fitting` minimise the equation error
:math:`E = P - \psi Z` (``act``; :math:`P - Z\psi` for ``sen``), which is linear in the unknowns;
the weighted refits of :mod:`sysid_core.identification.reweighting` bring it to first order to
the response error :math:`\hat G - \psi`. Both need the modes roughly right to begin with: where
a sweep samples high-Q peaks at a step of a bandwidth or more, the weights ``1/‖Z‖`` of a fit
whose poles are a bandwidth off are wrong where they matter most, and the iteration can settle
on modes that miss the data's own peaks while the response error stays several times the
noise (measured: a 12.7 kHz gyro, true bandwidths about 0.2/0.5 Hz, a 54-point window at
0.67 Hz near the modes, 60 dB shared by 8 tones: the equation-error fit misses the data by
0.48 of the response and the weighted one by 0.63, where the truth leaves 0.12, the noise).

:func:`refine_output_error` minimises the response error itself over the one-sweep model's
``M``, ``C``, ``K0`` and ``P`` (a Levenberg-Marquardt search started from a fitted model, with
the exact Jacobian of :math:`\hat G = P Z^{-1}` or :math:`Z^{-1} P`), each point weighted by its
measured noise where the sweep carries it: the maximum-likelihood fit of the sweep under
Gaussian noise. ``M = L Lᵀ`` and ``C = R Rᵀ`` keep the mass and the damping positive
semidefinite whatever the step. A start near the truth converges to it (the window above:
modes within 12 and 7 mHz of the truth, the data missed by about their noise); the
search is kept only when it misses the data by less than the start did, ``K0`` is positive
definite, ``M`` is not nearly singular and both modes are damped.
"""

from __future__ import annotations

import dataclasses

import numpy as np
import scipy.optimize
import xarray as xr

from sysid_core.conic.program import SYM_BASIS, sym
from sysid_core.data.schema import measured_mask
from sysid_core.errors import ModelError
from sysid_core.identification.problem import EPS_DAMPING
from sysid_core.model.fitted import FittedModel
from sysid_core.model.modal import principal_part

__all__ = ["MAX_EVALUATIONS", "MIN_MASS_RATIO", "refine_output_error"]

#: The search stops after this many evaluations of the response per unknown.
MAX_EVALUATIONS = 50
#: A refined mass matrix's eigenvalues may differ by at most the inverse of this ratio (a
#: gyro's two modal masses are of one order; a nearly singular ``M`` is a search gone astray).
MIN_MASS_RATIO = 1e-3


def _sym_entries(a: np.ndarray) -> np.ndarray:
    """The entries 11, 12, 22 of a (nearly) symmetric 2×2 matrix: the inverse of ``sym``."""
    return np.array([a[0, 0], 0.5 * (a[0, 1] + a[1, 0]), a[1, 1]])


def _factor(a: np.ndarray) -> np.ndarray:
    """A lower-triangular ``L`` with ``L Lᵀ = a`` (``a`` symmetric; made positive if it is not)."""
    s = 0.5 * (a + a.T)
    vals, vecs = np.linalg.eigh(s)
    vals = np.maximum(vals, 1e-9 * max(float(vals.max()), 1e-300))
    return np.linalg.cholesky((vecs * vals) @ vecs.T)


def _factor_derivatives(lo: np.ndarray) -> list[np.ndarray]:
    """``∂(L Lᵀ)`` for ``L``'s entries 11, 21 and 22."""
    a, b, c = lo[0, 0], lo[1, 0], lo[1, 1]
    return [
        np.array([[2 * a, b], [b, 0.0]]),
        np.array([[0.0, a], [a, 2 * b]]),
        np.array([[0.0, 0.0], [0.0, 2 * c]]),
    ]


class _ResponseFit:
    """The response error of one sweep as a function of scaled unknowns ``x``.

    ``K0 = ω0² (M + ε D)``, ``C = ω0 ε R Rᵀ``, ``P = s P̃``, ``M = L Lᵀ`` with ``L``'s 11 entry
    held (the response is unchanged when ``M``, ``C``, ``K0`` and ``P`` are scaled together);
    ``x`` is ``L21, L22, D (11, 12, 22), R11, R21, R22, Re P̃, Im P̃``. With ``Ω = ω/ω0`` and
    ``δ = (Ω² − 1)/ε``, ``Z = ω0² ε (D − δ M + jΩ R Rᵀ)``.
    """

    def __init__(self, f_hz: np.ndarray, psi: np.ndarray, weight: np.ndarray, start: FittedModel):
        omega = 2 * np.pi * f_hz
        self.start, self.weight = start, weight
        self.w0 = float(start.omega_center)
        self.eps = max(float(np.max(np.abs((omega / self.w0) ** 2 - 1.0))), 1e-9)
        self.s_psi = max(float(np.linalg.norm(start.poly)), 1e-300)
        nu = (omega - self.w0) / float(start.omega_half)
        self.powers = nu[:, None] ** np.arange(start.poly.shape[0])[None, :]  # (N, L)
        self.delta = ((omega / self.w0) ** 2 - 1.0) / self.eps
        self.jw = 1j * omega / self.w0
        self.target = psi * (self.w0**2 * self.eps) / self.s_psi
        self.output = start.structure.side == "output"
        self.l11 = float(_factor(start.M)[0, 0])

    def initial(self) -> np.ndarray:
        """``x`` of the start model."""
        start, w0, eps = self.start, self.w0, self.eps
        lo, r = _factor(start.M), _factor(start.C) / np.sqrt(w0 * eps)
        d = (_sym_entries(start.K0) / w0**2 - _sym_entries(start.M)) / eps
        p = start.poly.ravel() / self.s_psi
        return np.concatenate([lo[1], d, [r[0, 0]], r[1], p.real, p.imag])

    def unpack(self, x: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """``L``, ``D``, ``R`` and ``P̃``."""
        n = self.start.poly.size
        lo = np.array([[self.l11, 0.0], [x[0], x[1]]])
        r = np.array([[x[5], 0.0], [x[6], x[7]]])
        p = (x[8 : 8 + n] + 1j * x[8 + n :]).reshape(self.start.poly.shape)
        return lo, sym(x[2:5]), r, p

    def _inverse_and_response(self, x: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        lo, d, r, p = self.unpack(x)
        m, c = lo @ lo.T, r @ r.T
        z = d[None] - self.delta[:, None, None] * m[None] + self.jw[:, None, None] * c[None]
        zi = np.linalg.inv(z)
        pv = np.tensordot(self.powers, p, axes=1)
        return zi, (pv @ zi if self.output else zi @ pv)

    def residuals(self, x: np.ndarray) -> np.ndarray:
        """The weighted response errors, real and imaginary parts."""
        r = (self._inverse_and_response(x)[1] - self.target) * self.weight
        return np.concatenate([r.real.ravel(), r.imag.ravel()])

    def jacobian(self, x: np.ndarray) -> np.ndarray:
        """``∂ residuals / ∂x``, exactly."""
        lo, _, r, _ = self.unpack(x)
        zi, g = self._inverse_and_response(x)

        def dz(dzmat: np.ndarray) -> np.ndarray:  # dG for dZ: -G dZ Z⁻¹ or -Z⁻¹ dZ G
            return -(g @ dzmat @ zi) if self.output else -(zi @ dzmat @ g)

        delta, jw = self.delta[:, None, None], self.jw[:, None, None]
        cols = [dz(-delta * dm[None]) for dm in _factor_derivatives(lo)[1:]]
        cols += [dz(np.broadcast_to(SYM_BASIS[a], zi.shape)) for a in range(3)]
        cols += [dz(jw * dc[None]) for dc in _factor_derivatives(r)]
        dp = []
        for index in np.ndindex(self.start.poly.shape):
            e = np.zeros((2, 2))
            e[index[1], index[2]] = 1.0
            basis = self.powers[:, index[0], None, None] * e[None]
            dp.append(basis @ zi if self.output else zi @ basis)
        cols += dp + [1j * col for col in dp]
        jac = np.stack([c * self.weight for c in cols], axis=-1).reshape(-1, len(cols))
        return np.concatenate([jac.real, jac.imag])

    def model(self, x: np.ndarray, evaluations: int) -> FittedModel | None:
        """The model of ``x``, or None where it is not a gyro's.

        A gyro's: ``K0`` positive definite, ``M`` not nearly singular (:data:`MIN_MASS_RATIO`),
        both modes damped: stable poles, bandwidths above ``EPS_DAMPING·ε·f``, the bound the
        conic fits put on ``C`` (:mod:`sysid_core.identification.problem`).
        """
        lo, d, r, p = self.unpack(x)
        m = lo @ lo.T
        k0 = self.w0**2 * (m + self.eps * d)
        masses = np.linalg.eigvalsh(m)
        # a mass matrix no more ill-conditioned than a modal frequency's resolution allows
        if not (np.all(np.linalg.eigvalsh(k0) > 0) and masses[0] > MIN_MASS_RATIO * masses[1]):
            return None
        start = self.start
        model = dataclasses.replace(
            start,
            M=m,
            C=self.w0 * self.eps * (r @ r.T),
            K0=k0,
            poly=p * self.s_psi,
            gamma=float("nan"),
            max_residual=float("nan"),
            meta={**start.meta, "output_error": True, "output_error_evaluations": evaluations},
            stiffness_factor=None,
        )
        try:  # two damped oscillating modes, as the evidence reads them
            principal_part(
                model.M, model.C, k0, model.poly, self.w0, model.omega_half, model.structure.side
            )
            modes = model.modal([])
        except (ModelError, np.linalg.LinAlgError):
            return None
        f, bw = np.asarray(modes.frequencies_hz), np.asarray(modes.bandwidth_hz, dtype=float)
        # no sharper than the fits allow (Q under about 1/(ε EPS_DAMPING))
        if not np.all(np.isfinite(f) & np.isfinite(bw) & (bw > EPS_DAMPING * self.eps * f)):
            return None
        return model


def refine_output_error(sweep: xr.Dataset, start: FittedModel) -> FittedModel | None:
    """The model of one sweep that minimises its response error, searched from ``start``.

    Parameters
    ----------
    sweep : xarray.Dataset
        One experiment at one bias.
    start : FittedModel
        A fit of ``sweep`` without electrodes (``sweep.isel(electrode=[])``'s).

    Returns
    -------
    FittedModel or None
        The refined model (``meta["output_error"]`` set), or None when the search ends on an
        unphysical model or does not reduce the response error.
    """
    if start.n_electrodes or sweep.sizes.get("experiment", 1) != 1:
        return None
    mask = measured_mask(sweep)[0]
    f = np.asarray(sweep["frequency"].values, dtype=float)[mask]
    psi = np.asarray(sweep["response"].values[0])[mask]
    if f.size < 2:
        return None
    weight = np.ones(psi.shape)
    if "noise_var" in sweep:
        var = np.asarray(sweep["noise_var"].values, dtype=float)[0][mask]
        if np.all(np.isfinite(var) & (var > 0)):
            weight = 1.0 / np.sqrt(var)
    problem = _ResponseFit(f, psi, weight / np.sqrt(np.mean(weight**2)), start)
    x0 = problem.initial()
    before = float(np.linalg.norm(problem.residuals(x0)))
    try:
        found = scipy.optimize.least_squares(
            problem.residuals,
            x0,
            jac=problem.jacobian,
            method="lm",
            x_scale="jac",
            max_nfev=MAX_EVALUATIONS * x0.size,
        )
    except (ValueError, np.linalg.LinAlgError):
        return None
    if not np.all(np.isfinite(found.x)) or float(np.linalg.norm(found.fun)) >= before:
        return None
    return problem.model(found.x, int(found.nfev))
