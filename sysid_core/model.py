"""A fitted bias-dependent gyro model, in physical units.

.. math::

    Z(j\\omega; w) = -M\\omega^2 + K_0 + \\sum_p K_p w_p + jC\\omega,\\qquad
    w_p = (v_{gyro} - \\delta v_p)^2,

with the response :math:`P(\\nu) Z^{-1}` ("act") or :math:`Z^{-1}P(\\nu)` ("sen"), where
:math:`P(\\nu)=\\sum_l P_l\\nu^l` is the complex feedthrough polynomial in the normalised
frequency :math:`\\nu = (\\omega - \\omega_c)/h`. (The paper writes :math:`\\tilde R` in powers of
:math:`\\omega`; the same polynomial space is spanned, with far better conditioning.)
"""

from __future__ import annotations

import json
import os
from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np
import xarray as xr

from sysid_core.errors import DataError
from sysid_core.io import atomic_write
from sysid_core.simulation import modal_analysis

if TYPE_CHECKING:
    import control

    from sysid_core.interfaces import ModelStructure

__all__ = ["FittedModel", "ModalReport", "load_model", "snr_loss_db"]


def snr_loss_db(split_hz: float, center_hz: float, q: float) -> float:
    """SNR loss ``10 log10(1 + 4 Q^2 mu^2)`` in dB, ``mu = split / center`` (paper, Sec. I)."""
    mu = split_hz / center_hz
    return float(10 * np.log10(1 + 4 * q**2 * mu**2))


@dataclass(frozen=True)
class ModalReport:
    """Modal figures of a model at one bias.

    Attributes
    ----------
    bias : list of float
        Bias potentials (volts relative to ground).
    frequencies_hz : ndarray
        Undamped modal frequencies (generalized eigenvalues of ``(K, M)``), ascending.
    damped_hz : ndarray
        Exact damped modal frequencies, ascending.
    q : ndarray
        Quality factor of each damped mode.
    split_hz : float
        ``frequencies_hz[1] - frequencies_hz[0]``.
    snr_loss_db : float
        ``10 log10(1 + 4 Q^2 mu^2)`` with the mean Q and ``mu = split / mean frequency``.
    """

    bias: list[float]
    frequencies_hz: np.ndarray
    damped_hz: np.ndarray
    q: np.ndarray
    split_hz: float
    snr_loss_db: float

    def as_dict(self) -> dict[str, Any]:
        """JSON-friendly form."""
        return {
            "bias": [float(b) for b in self.bias],
            "frequencies_hz": [float(f) for f in self.frequencies_hz],
            "damped_hz": [float(f) for f in self.damped_hz],
            "q": [float(q) for q in self.q],
            "split_hz": self.split_hz,
            "snr_loss_db": self.snr_loss_db,
        }


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

    # ------------------------------------------------------------------ basics
    @property
    def n_electrodes(self) -> int:
        """Number of bias electrodes."""
        return len(self.electrodes)

    def _bias(self, bias: Sequence[float] | None) -> np.ndarray:
        b = np.zeros(self.n_electrodes) if bias is None else np.asarray(bias, dtype=float)
        if b.shape != (self.n_electrodes,):
            raise DataError(
                f"bias has {b.size} value(s); the model has {self.n_electrodes} electrodes "
                f"({', '.join(self.electrodes)})"
            )
        return b

    def squared_potentials(self, bias: Sequence[float] | None) -> np.ndarray:
        """``w_p = (v_gyro - dv_p)**2``."""
        return (self.structure_potential - self._bias(bias)) ** 2

    def stiffness_w(self, w: np.ndarray) -> np.ndarray:
        """``K0 + sum_p K_p w_p`` for squared potentials ``w``."""
        return self.K0 + np.tensordot(np.asarray(w, dtype=float), self.Kp, axes=1)

    def stiffness(self, bias: Sequence[float] | None = None) -> np.ndarray:
        """Total stiffness at ``bias`` (volts relative to ground)."""
        return self.stiffness_w(self.squared_potentials(bias))

    def polynomial(self, omega: np.ndarray) -> np.ndarray:
        """``P(nu(omega))`` with shape ``(N, 2, 2)``."""
        nu = (np.asarray(omega, dtype=float) - self.omega_center) / self.omega_half
        powers = nu[:, None] ** np.arange(self.poly.shape[0])[None, :]
        return np.tensordot(powers, self.poly, axes=1)

    def z(self, omega: np.ndarray, bias: Sequence[float] | None = None) -> np.ndarray:
        """``Z(j omega)`` at ``bias``, shape ``(N, 2, 2)``."""
        om = np.asarray(omega, dtype=float)[:, None, None]
        return -self.M * om**2 + self.stiffness(bias) + 1j * om * self.C

    def response(
        self, frequencies_hz: np.ndarray, bias: Sequence[float] | None = None
    ) -> np.ndarray:
        """Model frequency response ``(N, 2, 2)`` at ``bias`` and ``frequencies_hz``."""
        omega = 2 * np.pi * np.atleast_1d(np.asarray(frequencies_hz, dtype=float))
        return self.structure.response(self.polynomial(omega), self.z(omega, bias))

    def equation_error(self, dataset: xr.Dataset) -> np.ndarray:
        """σ̄ of the equation error at every measured point of ``dataset``: ``(n_exp, n_f)``.

        Unmeasured points are NaN.
        """
        from sysid_core.data import measured_mask
        from sysid_core.problem import sigma_max_2x2

        mask = measured_mask(dataset)
        f = dataset["frequency"].values
        out = np.full(mask.shape, np.nan)
        for k in range(mask.shape[0]):
            omega = 2 * np.pi * f[mask[k]]
            psi = dataset["response"].values[k][mask[k]]
            z = self.z(omega, dataset["bias"].values[k])
            e = self.polynomial(omega) - self.structure.product(psi, z)
            out[k, mask[k]] = sigma_max_2x2(e)
        return out

    # ------------------------------------------------------------------ modal figures
    def modal(self, bias: Sequence[float] | None = None) -> ModalReport:
        """Modal frequencies, split, Q and SNR loss at ``bias``."""
        b = self._bias(bias)
        undamped, damped, q = modal_analysis(self.M, self.C, self.stiffness(b))
        split = float(undamped[1] - undamped[0])
        return ModalReport(
            bias=b.tolist(),
            frequencies_hz=undamped,
            damped_hz=damped,
            q=q,
            split_hz=split,
            snr_loss_db=snr_loss_db(split, float(undamped.mean()), float(np.mean(q))),
        )

    def modal_frequencies_hz(self, bias: Sequence[float] | None = None) -> np.ndarray:
        """Undamped modal frequencies at ``bias`` (Hz), ascending."""
        return self.modal(bias).frequencies_hz

    def split_hz(self, bias: Sequence[float] | None = None) -> float:
        """Modal frequency split at ``bias`` (Hz)."""
        return self.modal(bias).split_hz

    # ------------------------------------------------------------------ python-control
    def to_statespace(
        self, bias: Sequence[float] | None = None, band_hz: tuple[float, float] | None = None
    ) -> control.StateSpace:
        """A real state-space realisation at ``bias`` (states ``x``, ``x'``).

        ``Z^-1`` is realised exactly. The complex polynomial ``P`` has no real realisation, so it
        is replaced by the real position-plus-velocity map ``a0 + a1 s`` that matches it best, in
        the least-squares sense, over ``band_hz`` (default: the fitted band). The relative
        error of that match is stored in ``sys.approximation_error``; inside the band the
        realisation reproduces :meth:`response` to that accuracy.
        """
        import control

        b = self._bias(bias)
        lo, hi = band_hz or (
            (self.omega_center - self.omega_half) / (2 * np.pi),
            (self.omega_center + self.omega_half) / (2 * np.pi),
        )
        omega = 2 * np.pi * np.linspace(lo, hi, 64)
        target = self.polynomial(omega)  # (N,2,2)
        basis = np.stack([np.ones_like(omega), omega], axis=1).astype(complex)
        basis[:, 1] *= 1j  # a0 + a1 (j omega)
        lhs = np.concatenate([basis.real, basis.imag])
        rhs = np.concatenate([target.real, target.imag]).reshape(2 * omega.size, 4)
        coef, *_ = np.linalg.lstsq(lhs, rhs, rcond=None)
        a0, a1 = coef[0].reshape(2, 2), coef[1].reshape(2, 2)
        approx = a0 + 1j * omega[:, None, None] * a1
        err = float(np.linalg.norm(approx - target) / np.linalg.norm(target))
        minv = np.linalg.inv(self.M)
        a = np.block([[np.zeros((2, 2)), np.eye(2)], [-minv @ self.stiffness(b), -minv @ self.C]])
        side = getattr(self.structure, "side", "output")
        if side == "output":  # y = (a0 + a1 s) x,  M x'' + C x' + K x = u
            sys = control.StateSpace(a, np.vstack([np.zeros((2, 2)), minv]), np.hstack([a0, a1]), 0)
        else:  # G = Z^-1 (a0 + a1 s) = (Z^-T (a0^T + a1^T s))^T  and Z = Z^T
            dual = control.StateSpace(
                a, np.vstack([np.zeros((2, 2)), minv]), np.hstack([a0.T, a1.T]), 0
            )
            sys = control.StateSpace(dual.A.T, dual.C.T, dual.B.T, dual.D.T)
        sys.approximation_error = err
        return sys

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
            },
            coords={"electrode": list(self.electrodes), "degree": np.arange(self.poly.shape[0])},
            attrs={
                "structure": self.structure.name,
                "order": self.structure.order,
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

    def describe(self) -> dict[str, Any]:
        """A JSON-friendly summary: parameters and fit facts."""
        return {
            "structure": self.structure.name,
            "order": self.structure.order,
            "electrodes": list(self.electrodes),
            "structure_potential": self.structure_potential,
            "gamma": self.gamma,
            "max_residual": self.max_residual,
            "M": self.M.tolist(),
            "C": self.C.tolist(),
            "K0": self.K0.tolist(),
            "Kp": self.Kp.tolist(),
            "meta": json.loads(json.dumps(self.meta, default=_jsonable)),
        }


def _jsonable(obj: object) -> object:
    if isinstance(obj, np.ndarray):
        return obj.tolist()
    if isinstance(obj, np.generic):
        return obj.item()
    return str(obj)


def load_model(path: str | os.PathLike[str]) -> FittedModel:
    """Read a model written by :meth:`FittedModel.save`.

    The model structure is looked up by name among the installed plugins.
    """
    from sysid_core.registry import get_registry

    path = Path(path)
    if not path.exists():
        raise DataError(f"no model file at {path}")
    with xr.open_dataset(path, engine="h5netcdf") as raw:
        ds = raw.load()
    structure = get_registry().create(
        "model structure", str(ds.attrs["structure"]), order=int(ds.attrs["order"])
    )
    return FittedModel(
        structure=structure,
        M=ds["M"].values,
        C=ds["C"].values,
        K0=ds["K0"].values,
        Kp=ds["Kp"].values,
        poly=ds["poly_real"].values + 1j * ds["poly_imag"].values,
        omega_center=float(ds.attrs["omega_center"]),
        omega_half=float(ds.attrs["omega_half"]),
        electrodes=[str(e) for e in ds["electrode"].values],
        structure_potential=float(ds.attrs["structure_potential"]),
        gamma=float(ds.attrs["gamma"]),
        max_residual=float(ds.attrs["max_residual"]),
        meta=json.loads(str(ds.attrs["meta"])),
    )
