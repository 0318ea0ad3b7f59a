"""The ``cloverleaf`` device: a simulated JPL-Boeing cloverleaf gyro."""

from __future__ import annotations

from typing import ClassVar

from sysid_simgyro.device import ParametrizedGyro

from sysid_cloverleaf.params import CloverleafParameters

__all__ = ["CloverleafGyro"]


class CloverleafGyro(ParametrizedGyro):
    """Simulated JPL-Boeing cloverleaf gyro (Kim & M'Closkey 2006), bias electrodes B1, B2, B3.

    Parameters
    ----------
    noise : float, default 1e-4
        Complex measurement noise per point, relative to the native resonant peak.
    feedthrough : float, default 0.0125
        Capacitive feedthrough at 4415 Hz relative to the native resonant peak.
    extra_modes : bool, default True
        Add the out-of-band translation (2.7 kHz) and flexural (5.6, 6.3 kHz) modes.
    dac_bits : int, default 16
        Bias DAC resolution over ±10 V; 0 applies biases exactly.
    seed : int or None, default 0
        Noise generator seed (``None``: fresh entropy).
    params : CloverleafParameters, optional
        Another physical parameter set (from Python only; the default is the calibration).

    Raises
    ------
    ConfigError
        For an unknown option (named in the message) or a bad value.
    """

    name: ClassVar[str] = "cloverleaf"
    description: ClassVar[str] = "Simulated JPL-Boeing cloverleaf gyro (4.4 kHz, B1-B3)"
    parameters_class: ClassVar[type[CloverleafParameters]] = CloverleafParameters
