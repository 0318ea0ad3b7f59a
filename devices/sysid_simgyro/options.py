"""Validation of the keyword options a simulated device's factory receives from a config file.

Every check raises :class:`sysid_core.errors.ConfigError` naming the device and the option.
"""

from __future__ import annotations

import math
from typing import Any

from sysid_core.errors import ConfigError

__all__ = [
    "COMMON_OPTIONS",
    "as_bool",
    "as_dac_bits",
    "as_fraction",
    "as_seed",
]

#: Options every simulated gyro takes (see :class:`sysid_simgyro.device.SimulatedGyro`).
COMMON_OPTIONS: tuple[str, ...] = (
    "noise",
    "feedthrough",
    "extra_modes",
    "dac_bits",
    "seed",
    "bench",
)


def _is_number(value: Any) -> bool:
    return isinstance(value, (int, float)) and not isinstance(value, bool)


def as_fraction(device: str, option: str, value: Any) -> float:
    """A finite, non-negative number (a level relative to the resonant peak)."""
    if not _is_number(value) or not math.isfinite(value) or value < 0:
        raise ConfigError(
            f"option {option!r} of device {device!r} must be a finite number >= 0 (a fraction "
            f"of the resonant peak), got {value!r}"
        )
    return float(value)


def as_bool(device: str, option: str, value: Any) -> bool:
    """A boolean (``true``/``false`` in TOML)."""
    if not isinstance(value, bool):
        raise ConfigError(
            f"option {option!r} of device {device!r} must be true or false, got {value!r}"
        )
    return value


def as_dac_bits(device: str, option: str, value: Any) -> int:
    """An integer from 0 (no quantisation) to 32."""
    if isinstance(value, bool) or not isinstance(value, int) or not 0 <= value <= 32:
        raise ConfigError(
            f"option {option!r} of device {device!r} must be an integer from 0 (no quantisation) "
            f"to 32, got {value!r}"
        )
    return int(value)


def as_seed(device: str, option: str, value: Any) -> int | None:
    """A non-negative integer, or ``None`` for fresh entropy from the operating system."""
    if value is None:
        return None
    if isinstance(value, bool) or not isinstance(value, int) or value < 0:
        raise ConfigError(
            f"option {option!r} of device {device!r} must be a non-negative integer, got {value!r}"
        )
    return int(value)
