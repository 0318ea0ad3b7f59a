"""Shared machinery of the built-in simulated gyros (``cloverleaf``, ``post-resonator``).

:class:`SimulatedGyro` wraps an exact :class:`sysid_core.device.simulation.GyroTruth` and adds what
a real measurement has and the identified model class does not: complex measurement noise,
parasitic capacitive feedthrough proportional to frequency, out-of-band structural modes and DAC
quantisation of the applied bias. It refuses (``BiasLimitError``) any bias outside its limits.

Modules
-------
physics
    Stiffness, damping and signal-conditioning building blocks of a parameter set.
effects
    :class:`ExtraMode`, :func:`quantize_bias`, :func:`peak_magnitude`.
options
    Validation of factory options (``ConfigError`` naming the option).
device
    :class:`SimulatedGyro`.

This package registers no device itself; ``sysid_cloverleaf`` and ``sysid_post_resonator`` do.
"""

from __future__ import annotations

from sysid_simgyro.device import SimulatedGyro
from sysid_simgyro.effects import ExtraMode, peak_magnitude, quantize_bias
from sysid_simgyro.options import COMMON_OPTIONS

__all__ = ["COMMON_OPTIONS", "ExtraMode", "SimulatedGyro", "peak_magnitude", "quantize_bias"]
