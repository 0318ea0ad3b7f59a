"""Hardware effects outside the two-mode model class: other modes, DAC quantisation, peak level.

Measurement noise and capacitive feedthrough are simple enough to live in
:class:`sysid_simgyro.device.SimulatedGyro` itself; this module holds the pieces with parameters
of their own.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
import scipy.optimize

from sysid_core.device.simulation import GyroTruth
from sysid_core.model.modal import modal_analysis
from sysid_simgyro.physics import TWO_PI

__all__ = ["ExtraMode", "peak_magnitude", "quantize_bias"]


@dataclass(frozen=True)
class ExtraMode:
    """A lightly damped structural mode outside the band of the two gyro modes.

    Its contribution to the (velocity pick-off) response, before signal conditioning, is

    .. math:: \\frac{j\\omega\\, a\\, r b^T}{\\omega_m^2 - \\omega^2 + j\\omega\\omega_m/Q_m}

    with ``r bᵀ`` scaled to a largest entry of 1 and the amplitude ``a`` set by ``level``: the
    largest entry of the term at the band centre is ``level`` times the peak response of the gyro
    modes. In the band it is a small, slowly varying background; at its own frequency it is a
    resonance of its own.

    Parameters
    ----------
    frequency_hz : float
        Natural frequency ``ω_m / 2π`` (Hz).
    q : float
        Quality factor.
    pickoff : pair of float
        ``r``: how strongly each pick-off sees the mode shape.
    actuation : pair of float
        ``b``: how strongly each actuator drives it.
    level : float
        Size of the term at the band centre relative to the gyro modes' peak response.
    label : str
        What the mode is (for reports).
    """

    frequency_hz: float
    q: float
    pickoff: tuple[float, float]
    actuation: tuple[float, float]
    level: float
    label: str = ""

    def shape(self) -> np.ndarray:
        """The residue direction ``r bᵀ`` scaled to a largest absolute entry of 1."""
        shape = np.outer(self.pickoff, self.actuation).astype(float)
        return shape / np.abs(shape).max()

    def transfer(self, omega: np.ndarray) -> np.ndarray:
        """The scalar factor ``jω / (ω_m² − ω² + jω ω_m / Q)`` at ``omega`` (rad/s)."""
        omega = np.asarray(omega, dtype=float)
        wm = TWO_PI * self.frequency_hz
        return 1j * omega / (wm**2 - omega**2 + 1j * omega * wm / self.q)


def quantize_bias(bias: np.ndarray, limits: tuple[float, float], bits: int) -> np.ndarray:
    """The bias a ``bits``-bit DAC spanning ``limits`` really applies.

    A bipolar DAC has ``2**bits`` codes with step ``(high - low) / 2**bits``; code ``k`` gives
    ``low + k * step``. Each requested value goes to the nearest code, so 0 V is exact on a
    symmetric range and the full-scale value ``high`` is reached as ``high - step`` (the largest
    code), as on real converters. ``bits = 0`` disables quantisation.
    """
    bias = np.asarray(bias, dtype=float)
    if bits == 0:
        return bias.copy()
    low, high = limits
    step = (high - low) / 2**bits
    code = np.clip(np.round((bias - low) / step), 0, 2**bits - 1)
    return low + code * step


def peak_magnitude(truth: GyroTruth, bias: Sequence[float]) -> float:
    """Largest ``|response|`` entry of ``truth`` at ``bias`` over frequency (the resonant peak).

    Samples ±4 half-power bandwidths around each damped mode, then refines the best sample with
    a bounded scalar search.
    """
    stiffness = truth.stiffness(bias)
    _, damped, q = modal_analysis(truth.M, truth.C, stiffness)

    def magnitude(f_hz: np.ndarray) -> np.ndarray:
        return np.abs(truth.response(bias, np.atleast_1d(f_hz))).max(axis=(1, 2))

    grids = [fd + (fd / qd) * np.linspace(-4.0, 4.0, 801) for fd, qd in zip(damped, q, strict=True)]
    f = np.sort(np.concatenate(grids))
    mags = magnitude(f)
    i = int(np.argmax(mags))
    lo, hi = f[max(i - 1, 0)], f[min(i + 1, f.size - 1)]
    if hi <= lo:
        return float(mags[i])
    best = scipy.optimize.minimize_scalar(
        lambda x: -float(magnitude(np.array([x]))[0]),
        bounds=(lo, hi),
        method="bounded",
        options={"xatol": 1e-9 * f[i]},
    )
    return float(max(mags[i], -best.fun))
