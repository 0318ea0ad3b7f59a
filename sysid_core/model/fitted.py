r"""A fitted bias-dependent gyro model, in physical units.

.. math::

    Z(j\omega; w) = -M\omega^2 + K_0 + \sum_p K_p w_p + jC\omega,\qquad
    w_p = (v_{gyro} - \delta v_p)^2,

with the response :math:`P(\nu) Z^{-1}` ("act") or :math:`Z^{-1}P(\nu)` ("sen"), where
:math:`P(\nu)=\sum_l P_l\nu^l` is the complex feedthrough polynomial in the normalised
frequency :math:`\nu = (\omega - \omega_c)/h`. (The paper writes :math:`\tilde R` in powers of
:math:`\omega`; the same polynomial space is spanned, with far better conditioning.)

:func:`sysid_core.identification.fitting.model_from_problem` maps a fit's scaled solution to
physical units; :func:`model_from_dataset` reads what :meth:`FittedModel.to_dataset` wrote
(:mod:`sysid_core.model.files`; loading a file by name needs the plugin registry:
:func:`sysid_core.api.load_model`). The exports to python-control live in
:mod:`sysid_core.model.export`.
"""

from __future__ import annotations

import numbers
import os
from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np
import scipy.linalg
import xarray as xr

from sysid_core.conic.program import sigma_max_2x2
from sysid_core.data.io import atomic_write
from sysid_core.data.schema import measured_mask, squared_potentials
from sysid_core.errors import DataError, ModelError
from sysid_core.model import export, files
from sysid_core.model.facts import FitFacts
from sysid_core.model.files import DEFAULT_INPUTS, DEFAULT_OUTPUTS, channel_names
from sysid_core.model.laws import linearize
from sysid_core.model.modal import ModalReport, modal_analysis, snr_loss_db
from sysid_core.model.structures import ModelStructure

if TYPE_CHECKING:
    import control

__all__ = [
    "DEFAULT_INPUTS",
    "DEFAULT_OUTPUTS",
    "FittedModel",
    "channel_names",
    "model_from_dataset",
]


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
        :func:`sysid_core.identification.covariance.stiffness_map`), when the objective states a
        covariance (least squares); what the tuning's confidence regions come from
        (:mod:`sysid_core.tuning.confidence`). Kept as a factor: ``K0`` and ``M`` are strongly
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

    @property
    def facts(self) -> FitFacts:
        """What the fit found, typed (:mod:`sysid_core.model.facts`), read from :attr:`meta`."""
        return FitFacts.of(self.meta)

    def __post_init__(self) -> None:
        """Fill in the defaults that depend on the electrodes and check the array shapes."""
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
        """``bias`` as a checked float array.

        Its values must be numbers (else ``TypeError``), one per electrode (else
        :class:`DataError`) and finite (else :class:`ModelError`).
        """
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
        """The stiffness at the checked bias ``b``, checked to give two oscillating modes.

        :class:`ModelError` unless it is positive definite relative to ``M``.
        """
        k = self.stiffness(b)
        try:
            lam = scipy.linalg.eigh(k, self.M, eigvals_only=True)
        except (np.linalg.LinAlgError, ValueError) as exc:
            raise ModelError(
                f"the model has no modes at bias {b.tolist()} V: M is not positive definite "
                f"or K(bias) is not finite ({exc})"
            ) from None
        if not (np.all(np.isfinite(lam)) and lam.min() > 0):
            fitted = self.facts.fit_bias
            hint = (
                f"; it was fitted at biases {fitted.tolist()} V: use a bias near those"
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
        the answer stops moving (:func:`sysid_core.tuning.criteria.solve_criterion`). Its
        :attr:`stiffness_factor` is mapped by the same linear map. A linear model is returned
        as it is.
        """
        return linearize(self, w0)

    def stiffness(self, bias: Sequence[float] | np.ndarray | None = None) -> np.ndarray:
        """Total stiffness at ``bias`` (volts relative to ground)."""
        return self.stiffness_w(self.squared_potentials(bias))

    def poly_at(self, bias: Sequence[float] | np.ndarray | None = None) -> np.ndarray:
        """The polynomial's coefficients at ``bias``: ``P_l + sum_p P_{l,p} w_p``.

        The shape is ``(order + 1, 2, 2)``.
        """
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

        See :func:`sysid_core.model.export.to_statespace` (the realisation, its error attributes
        ``approximation_error`` and ``approximation_error_peak``, and ``rtol``).
        """
        return export.to_statespace(self, bias, band_hz, rtol=rtol)

    def to_frd(
        self,
        frequencies_hz: Sequence[float] | np.ndarray | None = None,
        bias: Sequence[float] | np.ndarray | None = None,
    ) -> control.FrequencyResponseData:
        """The model's exact response at ``bias`` as a python-control FRD.

        See :func:`sysid_core.model.export.to_frd`.
        """
        return export.to_frd(self, frequencies_hz, bias)

    # ------------------------------------------------------------------ persistence
    def to_dataset(self) -> xr.Dataset:
        """The model as an :class:`xarray.Dataset` (what :meth:`save` writes)."""
        return files.model_to_dataset(self)

    def save(self, path: str | os.PathLike[str]) -> Path:
        """Write the model as netCDF, atomically."""
        ds = self.to_dataset()
        return atomic_write(path, lambda tmp: ds.to_netcdf(tmp, engine="h5netcdf"))


def model_from_dataset(ds: xr.Dataset, structure: ModelStructure) -> FittedModel:
    """The model :meth:`FittedModel.to_dataset` wrote, with the ``structure`` the caller rebuilt.

    The caller rebuilds it by name and order from ``ds.attrs`` (see
    :func:`sysid_core.api.load_model`).

    Files written before channel names were saved get the default names ``y1, y2`` / ``u1, u2``.
    """
    return FittedModel(structure=structure, **files.model_fields(ds))
