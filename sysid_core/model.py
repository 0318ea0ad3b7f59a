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
import numbers
import os
import warnings
from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np
import scipy.linalg
import xarray as xr

from sysid_core.errors import DataError, FrequencyGridError, ModelError, SysidWarning
from sysid_core.io import atomic_write
from sysid_core.simulation import modal_analysis

if TYPE_CHECKING:
    import control

    from sysid_core.interfaces import ModelStructure

__all__ = [
    "DEFAULT_INPUTS",
    "DEFAULT_OUTPUTS",
    "FittedModel",
    "ModalReport",
    "load_model",
    "snr_loss_db",
]

#: Channel names of a model whose data set did not name its channels.
DEFAULT_OUTPUTS: tuple[str, str] = ("y1", "y2")
DEFAULT_INPUTS: tuple[str, str] = ("u1", "u2")
#: Points of the grid over the band on which :meth:`FittedModel.to_statespace` fits and measures.
N_BAND_POINTS = 1001
#: :meth:`FittedModel.to_statespace` keeps the two modes in triangular (Schur) form instead of
#: diagonal form when the eigenvectors' condition number exceeds this (nearly defective modes).
MODAL_COND_LIMIT = 1e6
#: Background poles of :meth:`FittedModel.to_statespace`, in units of the band centre (rad/s):
#: tried in this order, the first set that meets the tolerance is used.
BACKGROUND_POLES: tuple[tuple[float, ...], ...] = (
    (),
    (1.0,),
    (1 / 3, 1.0, 3.0),
    (0.3, 0.3**0.5, 1.0, 3**0.5, 3.0),
)


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
    outputs, inputs : list of str
        Names of the two output and the two input channels (the data set's ``output`` and
        ``input`` coordinates); they name the channels of :meth:`to_statespace` and
        :meth:`to_frd`.
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

    def __post_init__(self) -> None:
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

    def _bias(self, bias: Sequence[float] | None) -> np.ndarray:
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

    def _system_name(self, b: np.ndarray) -> str:
        """``"act model at B1=2,04 V; B2=4,39 V"`` for a checked bias ``b``.

        A decimal comma: python-control reserves ``.`` in system names.
        """
        bias = "; ".join(f"{e}={v:.6g} V" for e, v in zip(self.electrodes, b, strict=True))
        return f"{self.structure.name} model at {bias or 'no bias electrodes'}".replace(".", ",")

    def _require_modes(self, b: np.ndarray) -> np.ndarray:
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
        """Modal frequencies, split, Q and SNR loss at ``bias``.

        Raises
        ------
        ModelError
            For a non-finite bias, or a bias at which ``K(bias)`` is not positive definite
            relative to ``M`` (the model has no oscillating modes there).
        TypeError
            For a bias that is not numbers.
        """
        b = self._bias(bias)
        undamped, damped, q = modal_analysis(self.M, self.C, self._require_modes(b))
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
    def _band(self, band_hz: tuple[float, float] | None) -> tuple[float, float]:
        """``band_hz`` checked, or the fitted band ``omega_center ± omega_half`` (Hz)."""
        if band_hz is None:
            return (
                (self.omega_center - self.omega_half) / (2 * np.pi),
                (self.omega_center + self.omega_half) / (2 * np.pi),
            )
        try:
            lo, hi = (float(x) for x in band_hz)
        except (TypeError, ValueError):
            raise FrequencyGridError(
                f"band_hz must be two frequencies (low, high) in Hz; got {band_hz!r}"
            ) from None
        if not (np.isfinite(lo) and np.isfinite(hi) and 0 < lo < hi):
            raise FrequencyGridError(
                f"band_hz must be finite frequencies with 0 < low < high (Hz); got ({lo}, {hi})"
            )
        return lo, hi

    def _resonant_part(self, k: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Principal part of the response at its two upper poles, as ``Cc (sI - T)^-1 Bc``.

        ``T`` (2, 2) holds the upper poles of ``Z^-1`` (diagonal unless they are nearly
        defective, then upper triangular); ``Bc`` (2, 2) and ``Cc`` (2, 2) are complex. The
        principal part of ``P(nu(s)) C (sI - T)^-1 B`` is ``sum_l P_l C N^l (sI - T)^-1 B``
        with the matrix ``N = nu(-jT)`` (``act``; mirrored for ``sen``): the analytic
        continuation of ``P`` to the poles, exact also for repeated poles.
        """
        w0 = self.omega_center
        minv = np.linalg.inv(self.M)
        # States x and x'/w0: every entry of A is O(w0), so the poles are accurate to eps*w0
        # (with x' itself the O(w0^2) stiffness block costs about five digits of the damping).
        a = np.block([[np.zeros((2, 2)), w0 * np.eye(2)], [-minv @ k / w0, -minv @ self.C]])
        t, q, n_upper = scipy.linalg.schur(
            a.astype(complex), output="complex", sort=lambda z: z.imag > 0
        )
        poles = np.diag(t)
        if n_upper != 2 or not np.all(np.isfinite(poles)) or np.any(poles.real >= 0):
            raise ModelError(
                "the model's mechanical poles at this bias are not two stable oscillating "
                f"modes (poles {', '.join(f'{p:.6g}' for p in poles)} rad/s): its damping C "
                "must be positive definite and its modes underdamped"
            )
        t11, t12, t22 = t[:2, :2], t[:2, 2:], t[2:, 2:]
        # Block-diagonalise: T11 S - S T22 = -T12; the upper and lower poles are 2*w0 apart.
        sylvester = scipy.linalg.solve_sylvester(t11, -t22, -t12)
        qh = q.conj().T
        left = qh[:2] - sylvester @ qh[2:]  # rows spanning the upper left-invariant subspace
        cx = q[:2, :2]  # [I 0] X
        yb = left[:, 2:] @ (minv / w0)  # Y [0; M^-1 / w0]
        nu = (-1j * t11 - w0 * np.eye(2)) / self.omega_half
        powers = [np.eye(2, dtype=complex)]
        for _ in range(1, self.poly.shape[0]):
            powers.append(powers[-1] @ nu)
        side = self.structure.side
        if side == "output":  # P Z^-1
            cc = sum(self.poly[d] @ cx @ powers[d] for d in range(self.poly.shape[0]))
            bc = yb
        elif side == "input":  # Z^-1 P
            cc = cx
            bc = sum(powers[d] @ yb @ self.poly[d] for d in range(self.poly.shape[0]))
        else:
            raise ModelError(
                f"model structure {self.structure.name!r} has side {side!r}; "
                "to_statespace knows 'output' (P Z^-1) and 'input' (Z^-1 P)"
            )
        lam, vec = np.linalg.eig(t11)
        if np.linalg.cond(vec) < MODAL_COND_LIMIT:  # modal form, unless nearly defective
            t11, cc, bc = np.diag(lam), cc @ vec, np.linalg.solve(vec, bc)
        # Balance each state: |column of Cc| = |row of Bc|.
        cn, bn = np.linalg.norm(cc, axis=0), np.linalg.norm(bc, axis=1)
        d = np.where((cn > 0) & (bn > 0), np.sqrt(bn / np.where(cn > 0, cn, 1.0)), 1.0)
        return t11 * d[None, :] / d[:, None], bc / d[:, None], cc * d[None, :]

    def to_statespace(
        self,
        bias: Sequence[float] | None = None,
        band_hz: tuple[float, float] | None = None,
        *,
        rtol: float = 1e-2,
    ) -> control.StateSpace:
        """A real, stable state-space system that reproduces :meth:`response` over a band.

        The complex polynomial ``P`` has complex coefficients in the real frequency, so the
        model is not a real rational function of ``s``; the realisation matches it over
        ``band_hz`` only. It is built in two parts:

        * the resonances, exactly: the two upper poles ``p_i`` of ``Z^-1`` with their exact
          residues ``P(nu(-j p_i)) R_i`` (``act``) or ``R_i P(nu(-j p_i))`` (``sen``), ``R_i``
          the rank-one residue of ``Z^-1`` and ``P`` continued to the complex frequency. Each
          mode and its conjugate is one real 2-state block ``[[Re p, -Im p], [Im p, Re p]]``
          (states ``mode<i>_re``, ``mode<i>_im``);
        * the smooth remainder over the band (at the conjugate poles a real system's residues
          are the conjugates, the model's are not), fitted by least squares with a real ``D`` and
          as few real background poles ``-a omega_b`` (``omega_b`` the band centre,
          ``a`` in 0.3 … 3, 2 states ``bg<k>_<input>`` each) as reach ``rtol``: 0, 1, 3 or 5.

        Parameters
        ----------
        bias : sequence of float, optional
            Bias potentials (volts relative to ground), one per electrode; default 0 V.
        band_hz : (float, float), optional
            Band (Hz) to match; default the fitted band ``omega_center ± omega_half``.
        rtol : float
            Target for ``approximation_error``; the fewest background poles that meet it are
            used. Default 1 %.

        Returns
        -------
        control.StateSpace
            Inputs and outputs named after the data's channels (:attr:`inputs`,
            :attr:`outputs`), named after the bias. Attributes set on it, measured on
            ``N_BAND_POINTS`` (1001) evenly spaced frequencies ``f`` of the band with ``G``
            the model's response and ``G_ss`` the system's:

            ``approximation_error``
                ``sqrt(sum |G_ss - G|^2 / sum |G|^2)`` over all points and entries.
            ``approximation_error_peak``
                ``max |G_ss - G|`` (largest entry error at any point) divided by the largest
                ``|G|`` entry over the band.
            ``approximation_band_hz``
                The band ``(low, high)``.

        Raises
        ------
        ModelError
            For a non-finite bias, or one at which the model has no oscillating modes.
        FrequencyGridError
            For a ``band_hz`` that is not two finite frequencies with ``0 < low < high``.
        TypeError
            For a bias that is not numbers.

        Warns
        -----
        SysidWarning
            When even 5 background poles leave ``approximation_error > rtol`` (a band far
            wider than the fitted one).
        """
        import control

        if isinstance(rtol, bool) or not (isinstance(rtol, (int, float)) and rtol > 0):
            raise ModelError(f"rtol must be a positive number; got {rtol!r}")
        b = self._bias(bias)
        k = self._require_modes(b)
        lo, hi = self._band(band_hz)
        f = np.linspace(lo, hi, N_BAND_POINTS)
        omega = 2 * np.pi * f
        target = self.response(f, b)
        scale = float(np.linalg.norm(target))

        t, bc, cc = self._resonant_part(k)
        a_res, b_res, c_res = _real_realisation(t, bc, cc)
        rest = target - _frequency_response(a_res, b_res, c_res, np.zeros((2, 2)), omega)
        rest = rest.reshape(-1, 4)

        omega_b = np.pi * (lo + hi)
        chosen: tuple[float, np.ndarray, np.ndarray] | None = None
        for poles in BACKGROUND_POLES:
            rates = omega_b * np.asarray(poles, dtype=float)
            basis = np.column_stack(
                [np.ones_like(omega, dtype=complex)] + [r / (1j * omega + r) for r in rates]
            )
            lhs = np.concatenate([basis.real, basis.imag])
            norms = np.linalg.norm(lhs, axis=0)  # unit columns: a well-posed least squares
            coef = (
                np.linalg.lstsq(lhs / norms, np.concatenate([rest.real, rest.imag]), rcond=None)[0]
                / norms[:, None]
            )
            err = float(np.linalg.norm(basis @ coef - rest)) / scale
            if chosen is None or err < chosen[0]:
                chosen = (err, rates, coef)
            if err <= rtol:
                chosen = (err, rates, coef)
                break
        assert chosen is not None
        _, rates, coef = chosen

        n_bg = rates.size
        a = scipy.linalg.block_diag(a_res, *(-r * np.eye(2) for r in rates))
        b_ss = np.vstack([b_res, *(r * np.eye(2) for r in rates)])
        c_ss = np.hstack([c_res, *(coef[1 + i].reshape(2, 2) for i in range(n_bg))])
        d_ss = coef[0].reshape(2, 2)
        states = [f"mode{i + 1}_{part}" for i in range(2) for part in ("re", "im")]
        states += [f"bg{i + 1}_{u}" for i in range(n_bg) for u in self.inputs]
        sys = control.StateSpace(
            a,
            b_ss,
            c_ss,
            d_ss,
            inputs=list(self.inputs),
            outputs=list(self.outputs),
            states=states,
            name=self._system_name(b),
        )
        g_ss = _frequency_response(a, b_ss, c_ss, d_ss, omega)
        sys.approximation_error = float(np.linalg.norm(g_ss - target)) / scale
        sys.approximation_error_peak = float(np.abs(g_ss - target).max() / np.abs(target).max())
        sys.approximation_band_hz = (lo, hi)
        if sys.approximation_error > rtol:
            warnings.warn(
                f"to_statespace: the realisation matches the model to "
                f"{sys.approximation_error:.2g} (relative) over {lo:g}-{hi:g} Hz, not {rtol:g}: "
                "narrow band_hz towards the fitted band",
                SysidWarning,
                stacklevel=2,
            )
        return sys

    def to_frd(
        self,
        frequencies_hz: Sequence[float] | np.ndarray | None = None,
        bias: Sequence[float] | None = None,
    ) -> control.FrequencyResponseData:
        """The model's exact response at ``bias`` as a :class:`control.FrequencyResponseData`.

        Parameters
        ----------
        frequencies_hz : array_like, optional
            Positive, strictly increasing frequencies (Hz); default 1001 points over the fitted
            band ``omega_center ± omega_half``.
        bias : sequence of float, optional
            Bias potentials (volts relative to ground), one per electrode; default 0 V.

        Returns
        -------
        control.FrequencyResponseData
            :meth:`response` at those frequencies (stored in rad/s, as python-control expects),
            inputs and outputs named after the data's channels, named after the bias.

        Raises
        ------
        ModelError
            For a non-finite bias.
        FrequencyGridError
            For frequencies that are not finite, positive and strictly increasing.
        TypeError
            For a bias that is not numbers.
        """
        import control

        b = self._bias(bias)
        if frequencies_hz is None:
            f = np.linspace(*self._band(None), N_BAND_POINTS)
        else:
            try:
                f = np.atleast_1d(np.asarray(frequencies_hz, dtype=float))
            except (TypeError, ValueError):
                raise FrequencyGridError(
                    f"frequencies_hz must be numbers (Hz); got {frequencies_hz!r}"
                ) from None
            if f.ndim != 1 or f.size == 0:
                raise FrequencyGridError(
                    f"frequencies_hz must be a non-empty 1-D grid; got shape {f.shape}"
                )
            if not np.all(np.isfinite(f)) or f.min() <= 0 or np.any(np.diff(f) <= 0):
                raise FrequencyGridError(
                    "frequencies_hz must be finite, positive and strictly increasing"
                )
        response = self.response(f, b)
        return control.FrequencyResponseData(
            np.transpose(response, (1, 2, 0)),
            2 * np.pi * f,
            inputs=list(self.inputs),
            outputs=list(self.outputs),
            name=self._system_name(b),
        )

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
            coords={
                "electrode": list(self.electrodes),
                "degree": np.arange(self.poly.shape[0]),
                "output": list(self.outputs),
                "input": list(self.inputs),
            },
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


def _real_realisation(
    t: np.ndarray, bc: np.ndarray, cc: np.ndarray
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Real ``(A, B, C)`` of ``Cc (sI - T)^-1 Bc`` plus its conjugate system.

    The complex state ``z_i`` becomes ``(Re z_i, Im z_i)``; the output is ``2 Re(Cc z)``.
    """
    n = t.shape[0]
    a = np.zeros((2 * n, 2 * n))
    for i in range(n):
        for j in range(n):
            a[2 * i : 2 * i + 2, 2 * j : 2 * j + 2] = [
                [t[i, j].real, -t[i, j].imag],
                [t[i, j].imag, t[i, j].real],
            ]
    b = np.empty((2 * n, bc.shape[1]))
    b[0::2], b[1::2] = bc.real, bc.imag
    c = np.empty((cc.shape[0], 2 * n))
    c[:, 0::2], c[:, 1::2] = 2 * cc.real, -2 * cc.imag
    return a, b, c


def _frequency_response(
    a: np.ndarray, b: np.ndarray, c: np.ndarray, d: np.ndarray, omega: np.ndarray
) -> np.ndarray:
    """``C (j omega I - A)^-1 B + D``, shape ``(N, n_out, n_in)``."""
    eye = np.eye(a.shape[0])
    return c @ np.linalg.solve(1j * omega[:, None, None] * eye - a, b) + d


def _jsonable(obj: object) -> object:
    if isinstance(obj, np.ndarray):
        return obj.tolist()
    if isinstance(obj, np.generic):
        return obj.item()
    return str(obj)


def load_model(path: str | os.PathLike[str]) -> FittedModel:
    """Read a model written by :meth:`FittedModel.save`.

    The model structure is looked up by name among the installed plugins. Files written
    before channel names were saved load with the default names ``y1, y2`` / ``u1, u2``.
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
        outputs=_names(ds, "output", DEFAULT_OUTPUTS),
        inputs=_names(ds, "input", DEFAULT_INPUTS),
    )


def _names(ds: xr.Dataset, coord: str, default: Sequence[str]) -> list[str]:
    if coord in ds.coords:
        return [str(v) for v in ds.coords[coord].values]
    return list(default)
