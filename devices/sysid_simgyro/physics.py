"""Building blocks of the simulated gyros' parameter sets (unit modal mass, SI units).

Stiffness is in (rad/s)², electrostatic stiffness per squared volt in (rad/s)²/V², damping in
rad/s. Calibration tables usually quote stiffness divided by (2π)², in Hz²; the helpers below take
that form and return physical units.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from sysid_core.device.simulation import LowPass

__all__ = [
    "TWO_PI",
    "damping_matrix",
    "differential_phase_deg",
    "lowpass_with_differential_phase",
    "rotation",
    "softening_stiffness",
    "stiffness_from_modes",
]

TWO_PI = 2.0 * np.pi


def rotation(angle_deg: float) -> np.ndarray:
    """The 2×2 rotation matrix by ``angle_deg`` (columns are the rotated axes)."""
    a = np.radians(angle_deg)
    return np.array([[np.cos(a), -np.sin(a)], [np.sin(a), np.cos(a)]])


def softening_stiffness(gain_hz2: float, angle_deg: float, minor: float = 0.05) -> np.ndarray:
    """Electrostatic stiffness of one bias electrode, ``K_p`` in (rad/s)²/V².

    ``K_p = -(2π)² g (n nᵀ + minor · m mᵀ)`` with ``n = (cos θ, sin θ)`` the direction the electrode
    pulls on and ``m`` its normal: nearly rank one and negative semidefinite (an electrostatic
    spring always softens).

    Parameters
    ----------
    gain_hz2 : float
        ``g``, the softening along ``n`` in Hz² per V².
    angle_deg : float
        ``θ``, the electrode's axis in the modal plane (degrees).
    minor : float
        Relative softening across the axis (fringe fields); 0 makes ``K_p`` rank one.
    """
    r = rotation(angle_deg)
    n, m = r[:, 0], r[:, 1]
    return -(TWO_PI**2) * gain_hz2 * (np.outer(n, n) + minor * np.outer(m, m))


def damping_matrix(q: Sequence[float], axis_deg: float, omega_ref: float) -> np.ndarray:
    """``C = ω_ref U diag(1/Q₁, 1/Q₂) Uᵀ`` (rad/s), ``U`` the rotation by ``axis_deg``.

    Parameters
    ----------
    q : pair of float
        Quality factors along the two principal damping axes.
    axis_deg : float
        Angle of the first principal damping axis (degrees).
    omega_ref : float
        Reference angular frequency (rad/s), normally the modes' mean.
    """
    u = rotation(axis_deg)
    return omega_ref * u @ np.diag([1.0 / q[0], 1.0 / q[1]]) @ u.T


def stiffness_from_modes(frequencies_hz: Sequence[float], axis_deg: float) -> np.ndarray:
    """Stiffness (rad/s)² of a unit-mass 2-DOF system with the given modes along ``axis_deg``.

    The first frequency belongs to the axis at ``axis_deg``, the second to its normal.
    """
    u = rotation(axis_deg)
    lam = (TWO_PI * np.asarray(frequencies_hz, dtype=float)) ** 2
    return u @ np.diag(lam) @ u.T


def differential_phase_deg(lowpass: LowPass, frequency_hz: float) -> float:
    """Phase lag of channel 2 relative to channel 1 of ``lowpass`` at ``frequency_hz`` (degrees)."""
    h = np.diagonal(lowpass(np.array([TWO_PI * frequency_hz]))[0])
    return float(np.degrees(np.angle(h[0]) - np.angle(h[1])))


def lowpass_with_differential_phase(
    corner_hz: float, gains: Sequence[float], phase_deg: float, at_hz: float
) -> LowPass:
    """Two first-order low-passes; channel 2 lags channel 1 by exactly ``phase_deg`` at ``at_hz``.

    Channel 1 has the corner ``corner_hz``; channel 2's corner solves
    ``atan(f/f₂) = atan(f/f₁) + φ`` in closed form, ``f₂ = f / tan(atan(f/f₁) + φ)``.
    """
    phase_1 = np.arctan(at_hz / corner_hz)
    corner_2 = at_hz / np.tan(phase_1 + np.radians(phase_deg))
    return LowPass(corner_hz=(float(corner_hz), float(corner_2)), gain=(gains[0], gains[1]))
