"""A fitted bias-dependent gyro model, in physical units.

.. math::

    Z(j\\omega; w) = -M\\omega^2 + K_0 + \\sum_p K_p w_p + jC\\omega,\\qquad
    w_p = (v_{gyro} - \\delta v_p)^2,

with the response :math:`P(\\nu) Z^{-1}` ("act") or :math:`Z^{-1}P(\\nu)` ("sen"), where
:math:`P(\\nu)=\\sum_l P_l\\nu^l` is the complex feedthrough polynomial in the normalised
frequency :math:`\\nu = (\\omega - \\omega_c)/h`. (The paper writes :math:`\\tilde R` in powers of
:math:`\\omega`; the same polynomial space is spanned, with far better conditioning.)

:func:`model_from_problem` maps a fit's scaled solution to physical units;
:func:`model_from_dataset` reads what :meth:`FittedModel.to_dataset` wrote (loading a file by
name needs the plugin registry: :func:`sysid_core.fit.load_model`). The exports to
python-control live in :mod:`sysid_core.export`.

Length: over the project's 300 lines because :class:`FittedModel` is the toolkit's central
object, one class with an argument check on every public method; its exports, modal analysis
and file loading are already in their own modules.
"""

from __future__ import annotations

import dataclasses
import json
import numbers
import os
from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np
import scipy.linalg
import xarray as xr

from sysid_core import export
from sysid_core.conic import sym
from sysid_core.covariance import stiffness_factor
from sysid_core.data import measured_mask, squared_potentials
from sysid_core.errors import DataError, ModelError
from sysid_core.io import atomic_write
from sysid_core.modal import ModalReport, modal_analysis, snr_loss_db
from sysid_core.problem import FitProblem, sigma_max_2x2
from sysid_core.structures import ModelStructure

if TYPE_CHECKING:
    import control

    from sysid_core.objective import ObjectiveResult

__all__ = [
    "DEFAULT_INPUTS",
    "DEFAULT_OUTPUTS",
    "FittedModel",
    "model_from_dataset",
    "model_from_problem",
]

#: Channel names of a model whose data set did not name its channels.
DEFAULT_OUTPUTS: tuple[str, str] = ("y1", "y2")
DEFAULT_INPUTS: tuple[str, str] = ("u1", "u2")


@dataclass
class FittedModel:
    """The identified model (physical units: rad/s, volts).

    Attributes
    ----------
    structure : ModelStructure
        ``act`` or ``sen`` with its polynomial order.
    M, C, K0 : ndarray (2, 2)
        Mass (normalised by ``M ⪰ I``), damping, mechanical stiffness.
    Kp : ndarray (n_e, 2, 2)
        Electrostatic stiffness per electrode (per V²).
    poly : ndarray (order + 1, 2, 2), complex
        Coefficients ``P_l`` of the feedthrough polynomial in ``nu``.
    poly_w : ndarray (bias_terms, n_e, 2, 2), complex
        Bias-dependent coefficients ``P_{l,p}`` (per V²): at squared potentials ``w`` the
        polynomial's coefficient of ``nu^l`` is ``P_l + sum_p P_{l,p} w_p`` (see
        :meth:`poly_at`); empty for the paper's bias-independent polynomial.
    omega_center, omega_half : float
        ``nu = (omega - omega_center) / omega_half``.
    electrodes : list of str
        Electrode names.
    structure_potential : float
        ``v_gyro`` (volts).
    gamma : float
        Optimal fit residual γ (physical units of ψ·Z).
    max_residual : float
        Largest σ̄(E) over the data at the returned parameters.
    meta : dict
        Objective, solver, timing, data size and other facts about the fit.
    outputs, inputs : list of str
        Names of the two output and the two input channels (the data set's ``output`` and
        ``input`` coordinates); they name the channels of :meth:`to_statespace` and
        :meth:`to_frd`.
    Lp : ndarray (n_e, 2, 2) or None
        Quadratic stiffness per electrode (per V⁴) of the ``quadratic`` stiffness law:
        ``K(w) = K0 + sum_p (K_p w_p + L_p w_p²)``; ``None`` for the paper's linear law.
    stiffness_factor : ndarray or None
        A square root ``F`` of the covariance ``F Fᵀ`` of the stiffness parameters ``M``,
        ``K0``, ``K_p`` and ``L_p`` if any (each as its entries 11, 12, 22; order and units in
        :func:`sysid_core.covariance.stiffness_map`), when the objective states a covariance
        (least squares); what the tuning's confidence regions come from
        (:mod:`sysid_core.confidence`). Kept as a factor: ``K0`` and ``M`` are strongly
        correlated and the covariance itself loses the small differences that set the split.
    """

    structure: ModelStructure
    M: np.ndarray
    C: np.ndarray
    K0: np.ndarray
    Kp: np.ndarray
    poly: np.ndarray
    omega_center: float
    omega_half: float
    electrodes: list[str]
    structure_potential: float
    gamma: float = float("nan")
    max_residual: float = float("nan")
    meta: dict[str, Any] = field(default_factory=dict)
    outputs: list[str] = field(default_factory=lambda: list(DEFAULT_OUTPUTS))
    inputs: list[str] = field(default_factory=lambda: list(DEFAULT_INPUTS))
    poly_w: np.ndarray = field(default_factory=lambda: np.zeros((0, 0, 2, 2), dtype=complex))
    stiffness_factor: np.ndarray | None = None
    Lp: np.ndarray | None = None

    def __post_init__(self) -> None:
        if self.poly_w.size == 0:
            self.poly_w = np.zeros((0, len(self.electrodes), 2, 2), dtype=complex)
        if self.Lp is not None:
            self.Lp = np.asarray(self.Lp, dtype=float).reshape(len(self.electrodes), 2, 2)
        if self.stiffness_factor is not None:
            n = (6 + 3 * len(self.electrodes)) + (
                3 * len(self.electrodes) if self.Lp is not None else 0
            )
            self.stiffness_factor = np.asarray(self.stiffness_factor, dtype=float)
            if self.stiffness_factor.ndim != 2 or self.stiffness_factor.shape[0] != n:
                raise DataError(
                    f"stiffness_factor has shape {self.stiffness_factor.shape}; a model with "
                    f"{len(self.electrodes)} electrode(s) needs {n} rows"
                )
        self.outputs = [str(name) for name in self.outputs]
        self.inputs = [str(name) for name in self.inputs]
        if len(self.outputs) != 2 or len(self.inputs) != 2:
            raise DataError(
                f"a gyro model has 2 outputs and 2 inputs; got outputs {self.outputs} "
                f"and inputs {self.inputs}"
            )

    # ------------------------------------------------------------------ basics
    @property
    def n_electrodes(self) -> int:
        """Number of bias electrodes."""
        return len(self.electrodes)

    def check_bias(self, bias: Sequence[float] | np.ndarray | None) -> np.ndarray:
        """``bias`` as a checked float array: numbers (else ``TypeError``), one per electrode
        (else :class:`DataError`), finite (else :class:`ModelError`)."""
        if bias is None:
            return np.zeros(self.n_electrodes)
        raw = np.asarray(bias)
        if raw.dtype.kind == "O" and all(
            isinstance(x, numbers.Real) and not isinstance(x, bool) for x in raw.flat
        ):
            raw = raw.astype(float)  # e.g. fractions
        if raw.dtype.kind not in "iuf":
            raise TypeError(
                f"bias must be numbers, one potential in volts per electrode "
                f"({', '.join(self.electrodes) or 'none'}); got {bias!r}"
            )
        b = raw.astype(float)
        if b.shape != (self.n_electrodes,):
            raise DataError(
                f"bias has {b.size} value(s); the model has {self.n_electrodes} electrodes "
                f"({', '.join(self.electrodes)})"
            )
        bad = np.flatnonzero(~np.isfinite(b))
        if bad.size:
            p = int(bad[0])
            raise ModelError(
                f"bias of electrode {self.electrodes[p]} is {b[p]}: biases must be finite "
                "potentials in volts"
            )
        return b

    def label(self, b: np.ndarray) -> str:
        """``"act model at B1=2,04 V; B2=4,39 V"`` for a checked bias ``b``.

        A decimal comma: python-control reserves ``.`` in system names.
        """
        bias = "; ".join(f"{e}={v:.6g} V" for e, v in zip(self.electrodes, b, strict=True))
        return f"{self.structure.name} model at {bias or 'no bias electrodes'}".replace(".", ",")

    def modal_stiffness(self, b: np.ndarray) -> np.ndarray:
        """The stiffness at the checked bias ``b``; :class:`ModelError` unless it is positive
        definite relative to ``M`` (two oscillating modes)."""
        k = self.stiffness(b)
        try:
            lam = scipy.linalg.eigh(k, self.M, eigvals_only=True)
        except (np.linalg.LinAlgError, ValueError) as exc:
            raise ModelError(
                f"the model has no modes at bias {b.tolist()} V: M is not positive definite "
                f"or K(bias) is not finite ({exc})"
            ) from None
        if not (np.all(np.isfinite(lam)) and lam.min() > 0):
            fitted = self.meta.get("fit_bias")
            hint = (
                f"; it was fitted at biases {fitted} V: use a bias near those"
                if fitted is not None
                else "; use a bias near the ones it was fitted at"
            )
            raise ModelError(
                f"the model has no oscillating modes at bias {b.tolist()} V: its "
                f"stiffness K(bias) is not positive definite relative to M (eigenvalues "
                f"{', '.join(f'{x:.4g}' for x in lam)} (rad/s)^2){hint}"
            )
        return k

    def squared_potentials(self, bias: Sequence[float] | np.ndarray | None) -> np.ndarray:
        """``w_p = (v_gyro - dv_p)**2``."""
        return squared_potentials(self.structure_potential, self.check_bias(bias))

    def stiffness_w(self, w: np.ndarray) -> np.ndarray:
        """``K0 + sum_p K_p w_p`` (plus ``L_p w_p²``) for squared potentials ``w``."""
        w = np.asarray(w, dtype=float)
        k = self.K0 + np.tensordot(w, self.Kp, axes=1)
        if self.Lp is not None:
            k = k + np.tensordot(w**2, self.Lp, axes=1)
        return k

    def linearized(self, w0: np.ndarray) -> FittedModel:
        """The model with its stiffness replaced by its tangent at squared potentials ``w0``.

        The tuning criteria (and the confidence regions) work with a stiffness that is linear
        in ``w``; a ``quadratic`` model is linearized at a point and solved again there until
        the answer stops moving (:func:`sysid_core.tuning.solve_criterion`). Its
        :attr:`stiffness_factor` is mapped by the same linear map. A linear model is returned
        as it is.
        """
        if self.Lp is None:
            return self
        w0 = np.asarray(w0, dtype=float).reshape(-1)
        n_e = len(self.electrodes)
        factor = None
        if self.stiffness_factor is not None:
            t = np.zeros((6 + 3 * n_e, 6 + 6 * n_e))
            t[: 6 + 3 * n_e, : 6 + 3 * n_e] = np.eye(6 + 3 * n_e)
            for p in range(n_e):
                lp = slice(6 + 3 * n_e + 3 * p, 9 + 3 * n_e + 3 * p)
                t[3:6, lp] = -(w0[p] ** 2) * np.eye(3)
                t[6 + 3 * p : 9 + 3 * p, lp] = 2.0 * w0[p] * np.eye(3)
            factor = t @ self.stiffness_factor
        return dataclasses.replace(
            self,
            K0=self.K0 - np.tensordot(w0**2, self.Lp, axes=1),
            Kp=self.Kp + 2.0 * w0[:, None, None] * self.Lp,
            Lp=None,
            stiffness_factor=factor,
            meta={**self.meta, "linearized_at_w": w0.tolist()},
        )

    def stiffness(self, bias: Sequence[float] | np.ndarray | None = None) -> np.ndarray:
        """Total stiffness at ``bias`` (volts relative to ground)."""
        return self.stiffness_w(self.squared_potentials(bias))

    def poly_at(self, bias: Sequence[float] | np.ndarray | None = None) -> np.ndarray:
        """The polynomial's coefficients at ``bias``: ``P_l + sum_p P_{l,p} w_p``,
        shape ``(order + 1, 2, 2)``."""
        if self.poly_w.shape[0] == 0:
            return self.poly
        w = self.squared_potentials(bias)
        out = np.array(self.poly, dtype=complex)
        out[: self.poly_w.shape[0]] += np.tensordot(w, self.poly_w, axes=([0], [1]))
        return out

    def polynomial(
        self, omega: np.ndarray, bias: Sequence[float] | np.ndarray | None = None
    ) -> np.ndarray:
        """``P(nu(omega))`` at ``bias`` (it matters only with ``poly_w``), shape ``(N, 2, 2)``."""
        nu = (np.asarray(omega, dtype=float) - self.omega_center) / self.omega_half
        powers = nu[:, None] ** np.arange(self.poly.shape[0])[None, :]
        return np.tensordot(powers, self.poly_at(bias), axes=1)

    def z(self, omega: np.ndarray, bias: Sequence[float] | np.ndarray | None = None) -> np.ndarray:
        """``Z(j omega)`` at ``bias``, shape ``(N, 2, 2)``."""
        om = np.asarray(omega, dtype=float)[:, None, None]
        return -self.M * om**2 + self.stiffness(bias) + 1j * om * self.C

    def response(
        self, frequencies_hz: np.ndarray, bias: Sequence[float] | np.ndarray | None = None
    ) -> np.ndarray:
        """Model frequency response ``(N, 2, 2)`` at ``bias`` and ``frequencies_hz``."""
        omega = 2 * np.pi * np.atleast_1d(np.asarray(frequencies_hz, dtype=float))
        return self.structure.response(self.polynomial(omega, bias), self.z(omega, bias))

    def equation_error(self, dataset: xr.Dataset) -> np.ndarray:
        """σ̄ of the equation error at every measured point of ``dataset``: ``(n_exp, n_f)``.

        Unmeasured points are NaN.
        """
        mask = measured_mask(dataset)
        f = dataset["frequency"].values
        out = np.full(mask.shape, np.nan)
        for k in range(mask.shape[0]):
            omega = 2 * np.pi * f[mask[k]]
            psi = dataset["response"].values[k][mask[k]]
            bias = dataset["bias"].values[k]
            e = self.polynomial(omega, bias) - self.structure.product(psi, self.z(omega, bias))
            out[k, mask[k]] = sigma_max_2x2(e)
        return out

    # ------------------------------------------------------------------ modal figures
    def modal(self, bias: Sequence[float] | np.ndarray | None = None) -> ModalReport:
        """Modal frequencies, split, Q and SNR loss at ``bias``.

        Raises
        ------
        ModelError
            For a non-finite bias, or a bias at which ``K(bias)`` is not positive definite
            relative to ``M`` (the model has no oscillating modes there).
        TypeError
            For a bias that is not numbers.
        """
        b = self.check_bias(bias)
        undamped, damped, q = modal_analysis(self.M, self.C, self.modal_stiffness(b))
        split = float(undamped[1] - undamped[0])
        return ModalReport(
            bias=b.tolist(),
            frequencies_hz=undamped,
            damped_hz=damped,
            q=q,
            split_hz=split,
            snr_loss_db=snr_loss_db(split, float(undamped.mean()), float(np.mean(q))),
        )

    def modal_frequencies_hz(self, bias: Sequence[float] | np.ndarray | None = None) -> np.ndarray:
        """Undamped modal frequencies at ``bias`` (Hz), ascending."""
        return self.modal(bias).frequencies_hz

    def split_hz(self, bias: Sequence[float] | np.ndarray | None = None) -> float:
        """Modal frequency split at ``bias`` (Hz)."""
        return self.modal(bias).split_hz

    # ------------------------------------------------------------------ python-control
    def to_statespace(
        self,
        bias: Sequence[float] | np.ndarray | None = None,
        band_hz: tuple[float, float] | None = None,
        *,
        rtol: float = 1e-2,
    ) -> control.StateSpace:
        """A real, stable state-space system reproducing :meth:`response` over a band.

        See :func:`sysid_core.export.to_statespace` (the realisation, its error attributes
        ``approximation_error`` and ``approximation_error_peak``, and ``rtol``).
        """
        return export.to_statespace(self, bias, band_hz, rtol=rtol)

    def to_frd(
        self,
        frequencies_hz: Sequence[float] | np.ndarray | None = None,
        bias: Sequence[float] | np.ndarray | None = None,
    ) -> control.FrequencyResponseData:
        """The model's exact response at ``bias`` as a python-control FRD.

        See :func:`sysid_core.export.to_frd`.
        """
        return export.to_frd(self, frequencies_hz, bias)

    # ------------------------------------------------------------------ persistence
    def to_dataset(self) -> xr.Dataset:
        """The model as an :class:`xarray.Dataset` (what :meth:`save` writes)."""
        ds = xr.Dataset(
            {
                "M": (("row", "col"), self.M),
                "C": (("row", "col"), self.C),
                "K0": (("row", "col"), self.K0),
                "Kp": (("electrode", "row", "col"), self.Kp),
                "poly_real": (("degree", "row", "col"), self.poly.real),
                "poly_imag": (("degree", "row", "col"), self.poly.imag),
                "poly_w_real": (("bias_degree", "electrode", "row", "col"), self.poly_w.real),
                "poly_w_imag": (("bias_degree", "electrode", "row", "col"), self.poly_w.imag),
                **(
                    {"stiffness_factor": (("parameter", "factor"), self.stiffness_factor)}
                    if self.stiffness_factor is not None
                    else {}
                ),
                **({"Lp": (("electrode", "row", "col"), self.Lp)} if self.Lp is not None else {}),
            },
            coords={
                "electrode": list(self.electrodes),
                "degree": np.arange(self.poly.shape[0]),
                "output": list(self.outputs),
                "input": list(self.inputs),
            },
            attrs={
                "structure": self.structure.name,
                "order": self.structure.order,
                "bias_terms": self.structure.bias_terms,
                "stiffness": getattr(self.structure, "stiffness", "linear"),
                "omega_center": self.omega_center,
                "omega_half": self.omega_half,
                "structure_potential": self.structure_potential,
                "gamma": self.gamma,
                "max_residual": self.max_residual,
                "meta": json.dumps(self.meta, default=_jsonable),
                "units": "M normalised (M >= I); C rad/s; K0 (rad/s)^2; Kp (rad/s)^2/V^2",
            },
        )
        return ds

    def save(self, path: str | os.PathLike[str]) -> Path:
        """Write the model as netCDF, atomically."""
        ds = self.to_dataset()
        return atomic_write(path, lambda tmp: ds.to_netcdf(tmp, engine="h5netcdf"))


def _jsonable(obj: object) -> object:
    if isinstance(obj, np.ndarray):
        return obj.tolist()
    if isinstance(obj, np.generic):
        return obj.item()
    return str(obj)


def model_from_dataset(ds: xr.Dataset, structure: ModelStructure) -> FittedModel:
    """The model :meth:`FittedModel.to_dataset` wrote, with its ``structure`` rebuilt by the
    caller (by name and order from ``ds.attrs``: see :func:`sysid_core.fit.load_model`).

    Files written before channel names were saved get the default names ``y1, y2`` / ``u1, u2``.
    """
    return FittedModel(
        structure=structure,
        M=ds["M"].values,
        C=ds["C"].values,
        K0=ds["K0"].values,
        Kp=ds["Kp"].values,
        poly=ds["poly_real"].values + 1j * ds["poly_imag"].values,
        poly_w=(
            ds["poly_w_real"].values + 1j * ds["poly_w_imag"].values
            if "poly_w_real" in ds
            else np.zeros((0, ds.sizes["electrode"], 2, 2), dtype=complex)
        ),
        omega_center=float(ds.attrs["omega_center"]),
        omega_half=float(ds.attrs["omega_half"]),
        electrodes=[str(e) for e in ds["electrode"].values],
        structure_potential=float(ds.attrs["structure_potential"]),
        gamma=float(ds.attrs["gamma"]),
        max_residual=float(ds.attrs["max_residual"]),
        meta=json.loads(str(ds.attrs["meta"])),
        outputs=_names(ds, "output", DEFAULT_OUTPUTS),
        inputs=_names(ds, "input", DEFAULT_INPUTS),
        stiffness_factor=ds["stiffness_factor"].values if "stiffness_factor" in ds else None,
        Lp=ds["Lp"].values if "Lp" in ds else None,
    )


#: A scaled solution whose ``λ_min(M)`` exceeds 1 by more than this is normalised.
MASS_NORMALISE_TOL = 1e-9


def unit_mass(problem: FitProblem, result: ObjectiveResult) -> tuple[ObjectiveResult, float | None]:
    """``result`` scaled so that ``λ_min(M) = 1`` when it is larger, and the factor applied.

    The equation error is linear in the unknowns, so ``α·theta`` fits exactly as well as
    ``theta`` up to the factor ``α``: the constraint ``M ⪰ I`` fixes the scale only as an
    inequality. A noisy fit's optimum has ``λ_min(M) = 1``; an exact one (noiseless data in the
    model class) is a whole ray of optima, and the solver may stop anywhere on it (measured: 1.48
    times the truth with one OpenBLAS kernel, the truth with another). Dividing every unknown
    by ``λ = λ_min(M) > 1`` keeps ``M ⪰ I`` and ``K_p ⪯ 0``, divides every equation error (and
    so γ) by ``λ`` and the covariance by ``λ²``.
    """
    lay = problem.layout
    lam = float(np.linalg.eigvalsh(sym(result.theta[lay.M])).min())
    if not np.isfinite(lam) or lam <= 1.0 + MASS_NORMALISE_TOL:
        return result, None
    return (
        dataclasses.replace(
            result,
            theta=result.theta / lam,
            gamma=result.gamma / lam,
            max_residual=result.max_residual / lam,
            covariance=None if result.covariance is None else result.covariance / lam**2,
        ),
        lam,
    )


def model_from_problem(problem: FitProblem, result: ObjectiveResult, **meta: object) -> FittedModel:
    """Map an objective's scaled solution of ``problem`` back to physical units.

    The inverse of the scaling of :mod:`sysid_core.problem`. The model's channel names are the
    data set's ``output`` and ``input`` coordinates; ``meta`` is added to the model's ``meta``
    (e.g. the solver's name and the fit time). The map is linear in ``result.theta``; a fit
    normalises the scale first (:func:`unit_mass`).
    """
    self = problem
    coords = self.dataset.coords
    outputs: np.ndarray | tuple[str, str] = (
        coords["output"].values if "output" in coords else DEFAULT_OUTPUTS
    )
    inputs: np.ndarray | tuple[str, str] = (
        coords["input"].values if "input" in coords else DEFAULT_INPUTS
    )
    s, lay, th = self.scaling, self.layout, result.theta
    m = sym(th[lay.M])
    c = s.omega0 * s.eps * sym(th[lay.C])
    # Z's stiffness is ω0²(M + ε(D~ + Σ w~_p K~_p + Σ φ_p L~_p)) with w~_p and φ_p polynomials
    # in w_p (Scaling.w_polynomials): collect the coefficients of 1, w_p and w_p².
    kappa = s.omega0**2 * s.eps
    lin, quad = s.w_polynomials()
    k_tilde = [sym(th[lay.K(p)]) for p in range(lay.n_electrodes)]
    l_tilde = [sym(th[lay.L(p)]) for p in range(lay.n_electrodes)] if lay.quadratic else []
    k0 = s.omega0**2 * (m + s.eps * sym(th[lay.D]))
    kp = np.zeros((lay.n_electrodes, 2, 2))
    for p in range(lay.n_electrodes):
        k0 = k0 + kappa * lin[p, 0] * k_tilde[p]
        kp[p] = kappa * lin[p, 1] * k_tilde[p]
    lp = None
    if lay.quadratic:
        assert quad is not None
        lp = np.zeros((lay.n_electrodes, 2, 2))
        for p in range(lay.n_electrodes):
            k0 = k0 + kappa * quad[p, 0] * l_tilde[p]
            kp[p] += kappa * quad[p, 1] * l_tilde[p]
            lp[p] = kappa * quad[p, 2] * l_tilde[p]

    def coefficient(sl: slice) -> np.ndarray:
        return s.psi_scale * (th[sl][:4] + 1j * th[sl][4:]).reshape(2, 2)

    poly = np.array([coefficient(lay.poly(d)) for d in range(lay.order + 1)])
    # P~_{l,p} multiplies w~_p = (w_p - w_c,p) / s_p: per V², and the offset moves into P_l.
    poly_w = np.array(
        [
            [coefficient(lay.poly_w(d, p)) / s.w_scale[p] for p in range(lay.n_electrodes)]
            for d in range(lay.bias_terms)
        ],
        dtype=complex,
    ).reshape(lay.bias_terms, lay.n_electrodes, 2, 2)
    for d in range(lay.bias_terms):
        poly[d] -= np.tensordot(s.w_center, poly_w[d], axes=1)
    factor = None if result.covariance is None else stiffness_factor(problem, result.covariance)
    return FittedModel(
        structure=self.structure,
        M=m,
        C=c,
        K0=k0,
        Kp=kp,
        poly=poly,
        poly_w=poly_w,
        omega_center=s.omega0,
        omega_half=s.nu_half,
        electrodes=self.electrodes,
        structure_potential=self.structure_potential,
        gamma=result.gamma * s.psi_scale,
        max_residual=result.max_residual * s.psi_scale,
        outputs=[str(name) for name in outputs],
        inputs=[str(name) for name in inputs],
        meta={
            "objective": result.objective,
            "certified": result.certified,
            "solves": result.solves,
            "working_set": result.working_set,
            "solver_iterations": result.iterations,
            "n_points": self.n_points,
            "n_experiments": self.n_experiments,
            "n_parameters": self.n_parameters,
            "device": str(self.dataset.attrs.get("device", "unknown")),
            "band_hz": [float(self.frequency_hz.min()), float(self.frequency_hz.max())],
            "fit_bias": self.bias.tolist(),
            **meta,
        },
        stiffness_factor=factor,
        Lp=lp,
    )


def _names(ds: xr.Dataset, coord: str, default: Sequence[str]) -> list[str]:
    if coord in ds.coords:
        return [str(v) for v in ds.coords[coord].values]
    return list(default)
