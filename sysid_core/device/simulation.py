"""Ground-truth two-mode gyro dynamics, for simulated devices, examples and tests.

The truth is the paper's physical model with every element explicit::

    y = H_out(s) R s^k Z(s)^-1 B H_in(s) u,      Z(s) = M s^2 + C s + K0 + sum_p K_p v_p^2,

with ``v_p = v_gyro - dv_p``, ``k = 1`` for a velocity pick-off (``0`` for displacement) and
``H_out``, ``H_in`` diagonal first-order low-passes (signal conditioning). Simulated devices add
what real hardware has and the model class does not (noise, feedthrough, other modes) on top.

An optional bias law makes the electrostatic stiffness deviate from ``v_p^2`` (outside the model
class, which is affine in ``w_p = v_p^2``): ``K_p v_p^2 (1 + beta_p dv_p^2)``.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field

import numpy as np
import scipy.optimize

from sysid_core.data.schema import squared_potentials
from sysid_core.model.modal import degenerate_pair_bias, modal_analysis

__all__ = ["GyroTruth", "LowPass"]


@dataclass(frozen=True)
class LowPass:
    """Diagonal first-order low-pass ``gain_i / (1 + s / (2 pi corner_i))`` per channel."""

    corner_hz: tuple[float, float]
    gain: tuple[float, float] = (1.0, 1.0)

    def __call__(self, omega: np.ndarray) -> np.ndarray:
        """Response at ``omega`` (rad/s): shape ``(N, 2, 2)``."""
        omega = np.asarray(omega, dtype=float)
        out = np.zeros((omega.size, 2, 2), dtype=complex)
        for i in range(2):
            out[:, i, i] = self.gain[i] / (1 + 1j * omega / (2 * np.pi * self.corner_hz[i]))
        return out


@dataclass
class GyroTruth:
    """A two-mode gyro with known parameters (physical units: rad/s, volts).

    Parameters
    ----------
    M, C, K0 : ndarray, shape (2, 2)
        Mass, damping and mechanical stiffness.
    Kp : ndarray, shape (n_e, 2, 2)
        Electrostatic stiffness per electrode, multiplied by ``v_p**2``.
    structure_potential : float
        ``v_gyro`` (volts).
    electrodes : sequence of str
        Electrode names.
    R, B : ndarray, shape (2, 2)
        Pick-off and actuator matrices (non-collocation).
    velocity_pickoff : bool
        Output proportional to velocity (``s x``) rather than displacement.
    h_out, h_in : LowPass or None
        Signal conditioning at the output / input.
    bias_law : ndarray, shape (n_e,), or None
        ``beta_p`` (1/V^2) of a bias law that deviates from ``v_p^2``: electrode ``p`` adds
        ``K_p w_p (1 + beta_p dv_p^2)`` with ``w_p = (v_gyro - dv_p)^2``. ``None`` (default) is
        the pure ``v_p^2`` law of the model class.
    """

    M: np.ndarray
    C: np.ndarray
    K0: np.ndarray
    Kp: np.ndarray
    structure_potential: float
    electrodes: Sequence[str] = ("B1", "B2")
    R: np.ndarray = field(default_factory=lambda: np.eye(2))
    B: np.ndarray = field(default_factory=lambda: np.eye(2))
    velocity_pickoff: bool = True
    h_out: LowPass | None = None
    h_in: LowPass | None = None
    bias_law: np.ndarray | None = None

    def __post_init__(self) -> None:
        """Make the matrices float arrays and check the electrode names and bias law."""
        self.M = np.asarray(self.M, dtype=float)
        self.C = np.asarray(self.C, dtype=float)
        self.K0 = np.asarray(self.K0, dtype=float)
        self.Kp = np.asarray(self.Kp, dtype=float).reshape(-1, 2, 2)
        self.R = np.asarray(self.R, dtype=float)
        self.B = np.asarray(self.B, dtype=float)
        if len(self.electrodes) != self.Kp.shape[0]:
            raise ValueError(f"{len(self.electrodes)} electrode names for {self.Kp.shape[0]} K_p")
        if self.bias_law is not None:
            self.bias_law = np.asarray(self.bias_law, dtype=float).reshape(-1)
            if self.bias_law.size != self.Kp.shape[0]:
                raise ValueError(
                    f"{self.bias_law.size} bias-law coefficients for {self.Kp.shape[0]} K_p"
                )

    @property
    def n_electrodes(self) -> int:
        """Number of bias electrodes."""
        return int(self.Kp.shape[0])

    def squared_potentials(self, bias: Sequence[float]) -> np.ndarray:
        """``w_p = (v_gyro - dv_p)**2``."""
        return squared_potentials(self.structure_potential, bias)

    def stiffness(self, bias: Sequence[float]) -> np.ndarray:
        """``K0 + sum_p K_p v_p^2`` at ``bias`` (volts relative to ground).

        With a :attr:`bias_law`, ``K0 + sum_p K_p v_p^2 (1 + beta_p dv_p^2)``.
        """
        w = self.squared_potentials(bias)
        if self.bias_law is not None:
            w = w * (1.0 + self.bias_law * np.asarray(bias, dtype=float) ** 2)
        return self.K0 + np.tensordot(w, self.Kp, axes=1)

    def response(
        self,
        bias: Sequence[float],
        frequencies_hz: np.ndarray,
        stiffness: np.ndarray | None = None,
    ) -> np.ndarray:
        """Exact frequency response ``(N, 2, 2)`` at ``bias``.

        ``stiffness`` (``(N, 2, 2)``, one per frequency) replaces ``K(bias)``: a gyro that
        changes while it is swept (a simulated bench that drifts).
        """
        omega = 2 * np.pi * np.asarray(frequencies_hz, dtype=float)
        s = 1j * omega[:, None, None]
        k = self.stiffness(bias) if stiffness is None else stiffness
        z = -self.M * omega[:, None, None] ** 2 + k + s * self.C
        g = np.linalg.solve(z, np.broadcast_to(self.B, z.shape))  # Z^-1 B
        if self.velocity_pickoff:
            g = s * g
        out = self.R @ g
        if self.h_out is not None:
            out = self.h_out(omega) @ out
        if self.h_in is not None:
            out = out @ self.h_in(omega)
        return out

    def modal_frequencies_hz(self, bias: Sequence[float]) -> np.ndarray:
        """Undamped modal frequencies at ``bias``, ascending (Hz)."""
        return modal_analysis(self.M, self.C, self.stiffness(bias))[0]

    def split_hz(self, bias: Sequence[float]) -> float:
        """Modal frequency split at ``bias`` (Hz)."""
        f = self.modal_frequencies_hz(bias)
        return float(f[1] - f[0])

    def degenerate_bias(
        self,
        electrodes: tuple[int, int] = (0, 1),
        bias: Sequence[float] | np.ndarray | None = None,
    ) -> np.ndarray:
        """Biases on two electrodes that make ``K = lambda M`` exactly, the others held.

        Without a :attr:`bias_law`, the closed form
        (:func:`sysid_core.model.modal.degenerate_pair_bias`) with the root
        ``v_p = v_gyro - dv_p`` of the sign of ``v_gyro``. With one, the stiffness is no longer
        affine in ``w``: the closed form is the start of a solve (Powell's hybrid
        method, ``scipy.optimize.root``) of the two conditions that make
        ``M^-1/2 K M^-1/2`` a multiple of the identity, to a relative anisotropy below 1e-11.

        Parameters
        ----------
        electrodes : tuple of int
            The two electrodes that move.
        bias : sequence of float, optional
            Every electrode's bias (volts); the electrodes not in ``electrodes`` stay at these
            values. Default: 0 V.

        Raises
        ------
        RuntimeError
            If the solve with a bias law does not converge to an exact degeneracy.
        """
        n_e = self.n_electrodes
        held = np.zeros(n_e) if bias is None else np.asarray(bias, dtype=float).reshape(-1)
        if held.size != n_e:
            raise ValueError(f"{held.size} biases for {n_e} electrodes")
        start = self._closed_form_degenerate_bias(electrodes, held)
        if self.bias_law is None:
            return start
        return self._refined_degenerate_bias(electrodes, start)

    def _closed_form_degenerate_bias(self, pair: tuple[int, int], held: np.ndarray) -> np.ndarray:
        """The exact solution of the ``v_p^2`` law (the bias law ignored on the moving pair)."""
        a, b = pair
        vg = float(self.structure_potential)
        others = held.copy()
        others[[a, b]] = vg  # w = 0 on the moving pair: their stiffness is added by the solve
        base = self.stiffness(others.tolist())
        bias = held.copy()
        try:
            bias[[a, b]] = degenerate_pair_bias(
                base, self.Kp[a], self.Kp[b], self.M, vg, clamp=True
            )
        except np.linalg.LinAlgError:  # no closed form (a collinear pair): start from the held
            pass
        return bias

    def _anisotropy(self, bias: np.ndarray, m_isqrt: np.ndarray) -> np.ndarray:
        """``(A11 - A22) / 2`` and ``A12`` of ``A = M^-1/2 K(bias) M^-1/2``: zero iff degenerate."""
        a = m_isqrt @ self.stiffness(bias.tolist()) @ m_isqrt
        return np.array([0.5 * (a[0, 0] - a[1, 1]), 0.5 * (a[0, 1] + a[1, 0])])

    def _refined_degenerate_bias(self, pair: tuple[int, int], start: np.ndarray) -> np.ndarray:
        """:meth:`degenerate_bias` for a stiffness with a bias law (see there)."""
        a, b = pair
        n_e = self.n_electrodes
        evals, evecs = np.linalg.eigh(self.M)
        m_isqrt = evecs @ np.diag(1.0 / np.sqrt(evals)) @ evecs.T
        scale = 0.5 * float(np.trace(m_isqrt @ self.stiffness([0.0] * n_e) @ m_isqrt))

        def full(x: np.ndarray) -> np.ndarray:
            bias = start.copy()
            bias[a], bias[b] = x
            return bias

        def residual(x: np.ndarray) -> np.ndarray:
            return self._anisotropy(full(x), m_isqrt) / scale

        sol = scipy.optimize.root(residual, start[[a, b]], method="hybr", options={"xtol": 1e-14})
        bias = full(np.asarray(sol.x, dtype=float))
        left = float(np.abs(residual(sol.x)).max())
        if not (np.all(np.isfinite(bias)) and left < 1e-11):
            raise RuntimeError(
                f"no exact degenerate bias found for electrodes "
                f"{self.electrodes[a]}, {self.electrodes[b]} with the bias law "
                f"{self.bias_law.tolist() if self.bias_law is not None else None}: the solve "
                f"from the closed form {start.tolist()} V stopped at {bias.tolist()} V with a "
                f"relative anisotropy of {left:.3g} ({sol.message})"
            )
        return bias
