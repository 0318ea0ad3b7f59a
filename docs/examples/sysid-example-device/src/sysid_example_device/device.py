"""``example-gyro``: a simulated two-electrode vibratory gyro built on the toolkit's truth model.

Parameters (invented for the example; unit modal mass):

* native modes 9998 and 10002 Hz (split 4 Hz), the stiffer one along 20°;
* two bias electrodes ``T1`` (0°) and ``T2`` (45°), each softening 900 Hz²/V² along its axis and
  5 % of that across it; structure potential 10 V; bias limits ±5 V;
* Q 10 000 and 12 000; pick-off ``R = [[1, 0.1], [-0.05, 0.95]]``, velocity pick-off;
* complex measurement noise, ``noise`` (default 1e-4) times the native resonant peak.

The modes become degenerate at 9996.89 Hz with ``T1 = -3.10 V`` and ``T2 = -2.65 V``, inside
the limits.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import ClassVar

import numpy as np
import xarray as xr

from sysid_core.device.simulation import GyroTruth
from sysid_core.errors import BiasLimitError, ConfigError

__all__ = ["ExampleGyro", "example_truth"]

TWO_PI = 2.0 * np.pi


def _rotation(angle_deg: float) -> np.ndarray:
    a = math.radians(angle_deg)
    return np.array([[math.cos(a), -math.sin(a)], [math.sin(a), math.cos(a)]])


def _electrode(gain_hz2: float, angle_deg: float, minor: float = 0.05) -> np.ndarray:
    """Electrostatic stiffness (rad/s)²/V² of an electrode pulling along ``angle_deg``."""
    r = _rotation(angle_deg)
    n, m = r[:, 0], r[:, 1]
    return -(TWO_PI**2) * gain_hz2 * (np.outer(n, n) + minor * np.outer(m, m))


def example_truth() -> GyroTruth:
    """The exact model of the example gyro."""
    structure_potential = 10.0
    kp = np.array([_electrode(900.0, 0.0), _electrode(900.0, 45.0)])
    axes = _rotation(20.0)
    native = axes @ np.diag((TWO_PI * np.array([10002.0, 9998.0])) ** 2) @ axes.T
    k0 = native - structure_potential**2 * kp.sum(axis=0)  # so that 0 V gives the native modes
    return GyroTruth(
        M=np.eye(2),
        C=TWO_PI * 10000.0 * np.diag([1 / 10000.0, 1 / 12000.0]),
        K0=k0,
        Kp=kp,
        structure_potential=structure_potential,
        electrodes=("T1", "T2"),
        R=np.array([[1.0, 0.1], [-0.05, 0.95]]),
        velocity_pickoff=True,
    )


class ExampleGyro:
    """Simulated two-electrode example gyro (modes near 10 kHz, electrodes T1 and T2).

    Parameters
    ----------
    noise : float, default 1e-4
        Standard deviation of the complex noise per point, relative to the native peak.
    seed : int or None, default 0
        Seed of the noise generator.

    Raises
    ------
    ConfigError
        For an unknown option (named in the message) or a bad value.
    """

    name: ClassVar[str] = "example-gyro"
    description: ClassVar[str] = "Example simulated gyro (10 kHz, T1-T2)"

    def __init__(self, *, noise: float = 1e-4, seed: int | None = 0) -> None:
        if isinstance(noise, bool) or not isinstance(noise, (int, float)) or not noise >= 0:
            raise ConfigError(f"option 'noise' of device {self.name!r} must be >= 0, got {noise!r}")
        self.truth = example_truth()
        # The Device protocol's attributes.
        self.electrodes: tuple[str, ...] = tuple(self.truth.electrodes)
        self.bias_limits: tuple[float, float] = (-5.0, 5.0)
        self.structure_potential: float = self.truth.structure_potential
        self.band_hz: tuple[float, float] = (9960.0, 10040.0)
        native = np.zeros(len(self.electrodes))
        peak = np.abs(self.truth.response(native, self.truth.modal_frequencies_hz(native))).max()
        self._noise_std = float(noise) * float(peak)
        self._rng = np.random.default_rng(seed)

    def _checked(self, bias: Sequence[float]) -> np.ndarray:
        """Never apply a bias outside the limits, whoever asks (defence in depth)."""
        values = np.asarray(bias, dtype=float)
        low, high = self.bias_limits
        if values.shape != (len(self.electrodes),) or not np.all(
            (values >= low) & (values <= high)
        ):
            raise BiasLimitError(
                f"{self.name}: refusing bias {values.tolist()}: need one value per electrode "
                f"{self.electrodes} within [{low}, {high}] V"
            )
        return values

    def measure(self, bias: Sequence[float], frequencies_hz: np.ndarray) -> xr.DataArray:
        """Apply ``bias`` and return the complex 2×2 response at ``frequencies_hz`` (Hz)."""
        values = self._checked(bias)
        f = np.asarray(frequencies_hz, dtype=float)
        response = self.truth.response(values, f)
        noise = self._rng.standard_normal(response.shape) + 1j * self._rng.standard_normal(
            response.shape
        )
        response = response + self._noise_std / np.sqrt(2.0) * noise
        return xr.DataArray(
            response,
            dims=("frequency", "output", "input"),
            coords={"frequency": f, "output": ["y1", "y2"], "input": ["u1", "u2"]},
            attrs={"device": self.name, "units": "V/V"},
        )

    def true_modal_frequencies_hz(self, bias: Sequence[float]) -> np.ndarray:
        """Ground truth (simulated devices only): undamped modal frequencies, ascending (Hz)."""
        return self.truth.modal_frequencies_hz(self._checked(bias))
