"""The cloverleaf gyro's parameter set (calibration in ``docs/cloverleaf.md``).

Every default below is either a figure of the calibration (fitted to the numbers Section III of
Kim & M'Closkey 2006 publishes) or a design choice documented as such; see the package docstring
for the table.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from sysid_simgyro.effects import ExtraMode
from sysid_simgyro.params import GyroParameterSet
from sysid_simgyro.physics import TWO_PI

__all__ = ["CLOVERLEAF_EXTRA_MODES", "CloverleafParameters"]

#: Out-of-band modes of the cloverleaf (design choice after the paper's Fig. 2): the large
#: translation mode along the post near 2.7 kHz and two flexural modes above 5 kHz.
CLOVERLEAF_EXTRA_MODES: tuple[ExtraMode, ...] = (
    ExtraMode(2700.0, 3000.0, (1.0, 0.85), (1.0, 1.1), 3e-3, "translation along the post"),
    ExtraMode(5600.0, 2000.0, (0.6, -1.0), (1.0, -0.4), 1e-3, "first flexural mode"),
    ExtraMode(6300.0, 2000.0, (1.0, 0.3), (-0.5, 1.0), 6e-4, "second flexural mode"),
)


@dataclass(frozen=True)
class CloverleafParameters(GyroParameterSet):
    """Physical parameters of the simulated JPL-Boeing cloverleaf gyro.

    Unit modal mass; stiffness tables in Hz² (multiplied by (2π)² to get (rad/s)²).

    Parameters
    ----------
    structure_potential : float
        ``v_gyro`` (V). Calibration: 15.58 V.
    k0_hz2 : 2×2 tuple
        Mechanical stiffness ``K0 / (2π)²`` (Hz²). Calibration.
    electrodes : tuple of str
        Bias electrode names, the paper's E_B1..E_B3.
    electrode_angles_deg, electrode_gains_hz2 : tuple of float
        ``θ_p`` and ``g_p`` of ``K_p = −(2π)² g_p (n_p n_pᵀ + minor · m_p m_pᵀ)``. Calibration.
    minor : float
        Cross-axis softening ratio of every electrode. Calibration: 0.05.
    q : pair of float
        Quality factors along the principal damping axes. Design choice: 45 000 and 60 000.
    damping_axis_deg : float
        First principal damping axis. Design choice: 60° (stiffness axes are near 33°).
    omega_ref_hz : float
        Reference frequency of the damping matrix. Design choice: 4427 Hz.
    pickoff : 2×2 tuple
        ``R`` (non-collocation). Design choice.
    velocity_pickoff : bool
        The sense electrodes measure velocity (paper, Section III-A).
    corner_hz, gains, differential_phase_deg, phase_reference_hz
        Output low-passes: channel 1 corner 20 kHz, gains 1.0 and 0.97; channel 2's corner
        (≈ 18.47 kHz) is computed so that it lags by exactly 1.000° at 4430 Hz. Design choice
        matching the paper's "about 1°".
    band_hz : pair of float
        Band of the two modes: the paper's 4385–4445 Hz.
    bias_limits : pair of float
        DAC range ±10 V.
    feedthrough_shape : 2×2 tuple
        Relative parasitic capacitances from actuator to pick-off electrodes. Design choice.
    feedthrough_reference_hz : float
        Where the feedthrough level is specified: 4415 Hz (band centre).
    extra_modes : tuple of ExtraMode
        :data:`CLOVERLEAF_EXTRA_MODES`.
    """

    structure_potential: float = 15.58
    k0_hz2: tuple[tuple[float, float], tuple[float, float]] = (
        (19706390.62, 21303.38),
        (21303.38, 19724860.06),
    )
    electrodes: tuple[str, ...] = ("B1", "B2", "B3")
    electrode_angles_deg: tuple[float, ...] = (0.0, 45.0, 90.51)
    electrode_gains_hz2: tuple[float, ...] = (290.39, 368.39, 299.44)
    minor: float = 0.05
    q: tuple[float, float] = (45000.0, 60000.0)
    damping_axis_deg: float = 60.0
    omega_ref_hz: float = 4427.0
    pickoff: tuple[tuple[float, float], tuple[float, float]] = ((0.97, 0.23), (-0.15, 1.04))
    velocity_pickoff: bool = True
    corner_hz: float = 20000.0
    gains: tuple[float, float] = (1.0, 0.97)
    differential_phase_deg: float = 1.0
    phase_reference_hz: float = 4430.0
    band_hz: tuple[float, float] = (4385.0, 4445.0)
    bias_limits: tuple[float, float] = (-10.0, 10.0)
    feedthrough_shape: tuple[tuple[float, float], tuple[float, float]] = ((1.0, 0.35), (0.55, 0.8))
    feedthrough_reference_hz: float = 4415.0
    extra_modes: tuple[ExtraMode, ...] = CLOVERLEAF_EXTRA_MODES

    def stiffness(self) -> np.ndarray:
        """``K0`` in (rad/s)²."""
        return TWO_PI**2 * np.asarray(self.k0_hz2, dtype=float)
