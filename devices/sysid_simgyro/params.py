"""What a simulated gyro's parameter set provides, and how it becomes a :class:`GyroTruth`."""

from __future__ import annotations

import numpy as np

from sysid_core.device.simulation import GyroTruth, LowPass
from sysid_simgyro.effects import ExtraMode
from sysid_simgyro.physics import (
    TWO_PI,
    damping_matrix,
    lowpass_with_differential_phase,
    softening_stiffness,
)

__all__ = ["GyroParameterSet"]


class GyroParameterSet:
    """Mixin of the devices' frozen parameter dataclasses: builds the truth model.

    A subclass declares the fields annotated below (with its own defaults) and
    :meth:`stiffness`; everything else is shared. Units: unit modal mass, Hz-based tables
    (multiplied by (2π)² for stiffness).
    """

    structure_potential: float
    electrodes: tuple[str, ...]
    electrode_angles_deg: tuple[float, ...]
    electrode_gains_hz2: tuple[float, ...]
    minor: float
    q: tuple[float, float]
    damping_axis_deg: float
    omega_ref_hz: float
    pickoff: tuple[tuple[float, float], tuple[float, float]]
    velocity_pickoff: bool
    corner_hz: float
    gains: tuple[float, float]
    differential_phase_deg: float
    phase_reference_hz: float
    band_hz: tuple[float, float]
    bias_limits: tuple[float, float]
    feedthrough_shape: tuple[tuple[float, float], tuple[float, float]]
    feedthrough_reference_hz: float
    extra_modes: tuple[ExtraMode, ...]

    def stiffness(self) -> np.ndarray:
        """``K0`` in (rad/s)²."""
        raise NotImplementedError

    def electrode_stiffness(self) -> np.ndarray:
        """``K_p`` in (rad/s)²/V², shape ``(n_e, 2, 2)``."""
        return np.array(
            [
                softening_stiffness(g, th, self.minor)
                for g, th in zip(self.electrode_gains_hz2, self.electrode_angles_deg, strict=True)
            ]
        )

    def damping(self) -> np.ndarray:
        """``C`` in rad/s."""
        return damping_matrix(self.q, self.damping_axis_deg, TWO_PI * self.omega_ref_hz)

    def output_lowpass(self) -> LowPass:
        """``H_out``: the pick-off signal conditioning."""
        return lowpass_with_differential_phase(
            self.corner_hz, self.gains, self.differential_phase_deg, self.phase_reference_hz
        )

    def truth(self) -> GyroTruth:
        """The exact two-mode model of these parameters (actuators ``B = I``)."""
        return GyroTruth(
            M=np.eye(2),
            C=self.damping(),
            K0=self.stiffness(),
            Kp=self.electrode_stiffness(),
            structure_potential=self.structure_potential,
            electrodes=self.electrodes,
            R=np.asarray(self.pickoff, dtype=float),
            B=np.eye(2),
            velocity_pickoff=self.velocity_pickoff,
            h_out=self.output_lowpass(),
        )
