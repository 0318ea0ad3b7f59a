"""Ground-truth two-mode gyro dynamics, for simulated devices, examples and tests.

The truth is the paper's physical model with every element explicit::

    y = H_out(s) R s^k Z(s)^-1 B H_in(s) u,      Z(s) = M s^2 + C s + K0 + sum_p K_p v_p^2,

with ``v_p = v_gyro - dv_p``, ``k = 1`` for a velocity pick-off (``0`` for displacement) and
``H_out``, ``H_in`` diagonal first-order low-passes (signal conditioning). Simulated devices add
what real hardware has and the model class does not (noise, feedthrough, other modes) on top.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field

import numpy as np

from sysid_core.data import squared_potentials
from sysid_core.modal import modal_analysis
from sysid_core.tuning import degenerate_bias

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

    def __post_init__(self) -> None:
        self.M = np.asarray(self.M, dtype=float)
        self.C = np.asarray(self.C, dtype=float)
        self.K0 = np.asarray(self.K0, dtype=float)
        self.Kp = np.asarray(self.Kp, dtype=float).reshape(-1, 2, 2)
        self.R = np.asarray(self.R, dtype=float)
        self.B = np.asarray(self.B, dtype=float)
        if len(self.electrodes) != self.Kp.shape[0]:
            raise ValueError(f"{len(self.electrodes)} electrode names for {self.Kp.shape[0]} K_p")

    @property
    def n_electrodes(self) -> int:
        """Number of bias electrodes."""
        return int(self.Kp.shape[0])

    def squared_potentials(self, bias: Sequence[float]) -> np.ndarray:
        """``w_p = (v_gyro - dv_p)**2``."""
        return squared_potentials(self.structure_potential, bias)

    def stiffness(self, bias: Sequence[float]) -> np.ndarray:
        """``K0 + sum_p K_p v_p^2`` at ``bias`` (volts relative to ground)."""
        w = self.squared_potentials(bias)
        return self.K0 + np.tensordot(w, self.Kp, axes=1)

    def response(self, bias: Sequence[float], frequencies_hz: np.ndarray) -> np.ndarray:
        """Exact frequency response ``(N, 2, 2)`` at ``bias``."""
        omega = 2 * np.pi * np.asarray(frequencies_hz, dtype=float)
        s = 1j * omega[:, None, None]
        z = -self.M * omega[:, None, None] ** 2 + self.stiffness(bias) + s * self.C
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

    def degenerate_bias(self, electrodes: tuple[int, int] = (0, 1)) -> np.ndarray:
        """Biases on two electrodes (others at 0 V) that make ``K(w) = lambda M`` exactly.

        See :func:`sysid_core.tuning.degenerate_bias`.
        """
        return degenerate_bias(self.K0, self.Kp, self.M, self.structure_potential, electrodes)
