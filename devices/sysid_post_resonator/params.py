"""The post-resonator gyro's parameter set (assumed values; see the package docstring).

Bae, Hayworth, Yee, Shcheglov and Wiberg, "High performance MEMS micro-gyroscope", Proc. SPIE
4755 (2002). Its published figures were not available to us, so every number here is an
assumption chosen to be plausible for a post-resonator gyro of that family, not a calibration.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from sysid_simgyro.effects import ExtraMode
from sysid_simgyro.params import GyroParameterSet
from sysid_simgyro.physics import stiffness_from_modes

__all__ = ["POST_RESONATOR_EXTRA_MODES", "PostResonatorParameters"]

#: Out-of-band modes (assumed): the post's translation ("bounce") mode below the band and two
#: flexural modes of the plate above it.
POST_RESONATOR_EXTRA_MODES: tuple[ExtraMode, ...] = (
    ExtraMode(2150.0, 2500.0, (1.0, 0.9), (1.0, 1.05), 3e-3, "translation along the post"),
    ExtraMode(4450.0, 2000.0, (-0.7, 1.0), (1.0, 0.5), 1.5e-3, "first flexural mode"),
    ExtraMode(5150.0, 2000.0, (1.0, -0.2), (0.4, 1.0), 8e-4, "second flexural mode"),
)


@dataclass(frozen=True)
class PostResonatorParameters(GyroParameterSet):
    """Physical parameters of the simulated JPL post-resonator gyro (all assumed).

    Unlike the cloverleaf, ``K0`` is specified through its consequence, the native state (all
    biases 0 V): modes ``native_modes_hz`` with the stiffer one along ``native_axis_deg``.
    ``K0 = K_native − v_gyro² Σ K_p``.

    Parameters
    ----------
    structure_potential : float
        ``v_gyro`` = 12 V (above the DAC range: ``v_p = v_gyro − δv > 0`` for every allowed bias).
    native_modes_hz : pair of float
        Native modes: 3318.4 and 3321.6 Hz (split 3.2 Hz); the first along ``native_axis_deg``.
    native_axis_deg : float
        Axis of the native mode ``native_modes_hz[0]``: 112° (so the stiffer mode, 3321.6 Hz, is
        along 22°).
    electrodes, electrode_angles_deg, electrode_gains_hz2, minor
        Four bias electrodes B1..B4 at 0.3°, 45.8°, 89.6°, 135.4° (two orthogonal pairs with
        small misalignments), softening 180, 172, 185, 176 Hz²/V², cross-axis ratio 0.05.
    q, damping_axis_deg, omega_ref_hz
        Q 18 000 and 22 000 along damping axes at −15°, reference 3320 Hz.
    pickoff, velocity_pickoff
        ``R`` = [[1.02, −0.12], [0.18, 0.95]], velocity (capacitive) pick-off.
    corner_hz, gains, differential_phase_deg, phase_reference_hz
        Output low-passes: 25 kHz gain 1.0; channel 2 gain 0.98 lagging by 0.5° at 3320 Hz.
    band_hz, bias_limits
        (3290, 3350) Hz; ±10 V DAC.
    feedthrough_shape, feedthrough_reference_hz
        Relative parasitic capacitances [[0.9, 0.3], [0.25, 1.0]], level specified at 3320 Hz.
    extra_modes
        :data:`POST_RESONATOR_EXTRA_MODES`.
    """

    structure_potential: float = 12.0
    native_modes_hz: tuple[float, float] = (3318.4, 3321.6)
    native_axis_deg: float = 112.0
    electrodes: tuple[str, ...] = ("B1", "B2", "B3", "B4")
    electrode_angles_deg: tuple[float, ...] = (0.3, 45.8, 89.6, 135.4)
    electrode_gains_hz2: tuple[float, ...] = (180.0, 172.0, 185.0, 176.0)
    minor: float = 0.05
    q: tuple[float, float] = (18000.0, 22000.0)
    damping_axis_deg: float = -15.0
    omega_ref_hz: float = 3320.0
    pickoff: tuple[tuple[float, float], tuple[float, float]] = ((1.02, -0.12), (0.18, 0.95))
    velocity_pickoff: bool = True
    corner_hz: float = 25000.0
    gains: tuple[float, float] = (1.0, 0.98)
    differential_phase_deg: float = 0.5
    phase_reference_hz: float = 3320.0
    band_hz: tuple[float, float] = (3290.0, 3350.0)
    bias_limits: tuple[float, float] = (-10.0, 10.0)
    feedthrough_shape: tuple[tuple[float, float], tuple[float, float]] = ((0.9, 0.3), (0.25, 1.0))
    feedthrough_reference_hz: float = 3320.0
    extra_modes: tuple[ExtraMode, ...] = POST_RESONATOR_EXTRA_MODES

    def native_stiffness(self) -> np.ndarray:
        """Total stiffness (rad/s)² in the native state (every bias 0 V)."""
        return stiffness_from_modes(self.native_modes_hz, self.native_axis_deg)

    def stiffness(self) -> np.ndarray:
        """``K0`` in (rad/s)²: the native stiffness less the electrodes' softening at 0 V."""
        return (
            self.native_stiffness()
            - self.structure_potential** 2 * self.electrode_stiffness().sum(axis=0)
        )
