"""The ``post-resonator`` device: a simulated JPL post-resonator gyro."""

from __future__ import annotations

from typing import ClassVar

from sysid_simgyro.device import ParametrizedGyro

from sysid_post_resonator.params import PostResonatorParameters

__all__ = ["PostResonatorGyro"]


class PostResonatorGyro(ParametrizedGyro):
    """Simulated JPL post-resonator gyro (Bae et al. 2002; assumed parameters), electrodes B1-B4.

    Parameters
    ----------
    noise : float, default 1e-4
        Complex measurement noise per point, relative to the native resonant peak.
    feedthrough : float, default 0.0125
        Capacitive feedthrough at 3320 Hz relative to the native resonant peak.
    extra_modes : bool, default True
        Add the out-of-band translation (2.15 kHz) and flexural (4.45, 5.15 kHz) modes.
    dac_bits : int, default 16
        Bias DAC resolution over ±10 V; 0 applies biases exactly.
    seed : int or None, default 0
        Noise generator seed (``None``: fresh entropy).
    params : PostResonatorParameters, optional
        Another physical parameter set (from Python only).

    Raises
    ------
    ConfigError
        For an unknown option (named in the message) or a bad value.
    """

    name: ClassVar[str] = "post-resonator"
    description: ClassVar[str] = "Simulated JPL post-resonator gyro (3.3 kHz, B1-B4, assumed)"
    parameters_class: ClassVar[type[PostResonatorParameters]] = PostResonatorParameters
