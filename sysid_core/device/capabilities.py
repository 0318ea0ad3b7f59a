"""A device's optional capabilities: declared once, read and checked once, before measuring.

Beside the attributes every device has (:class:`~sysid_core.device.protocol.Device`), a device
may state what it knows of its own bench. Each is optional; a device that does not have the
attribute, or has it set to ``None``, does not state it and the run falls back to the
configuration or to an estimate (:mod:`sysid_core.clock.benchtime`). A device that states one
with a value it cannot mean (a ``tones`` of 0, a negative or NaN ``dwell_s``) is refused before
the first measurement, in one line naming the attribute, instead of being silently ignored.

============================  ===========  =================================================
attribute                     type         what it states
============================  ===========  =================================================
``tones``                     int >= 1     frequencies one acquisition measures at once
``dwell_s``                   float > 0    seconds per acquisition (the device has a clock)
``settle_s``                  float >= 0   seconds the gyro needs after a bias change
``points_per_frequency``      int >= 1     measurements per frequency point (e.g. 2 for an
                                           analyzer that drives its two inputs in turn)
``bias_resolution``           float > 0    the DAC's step in volts
============================  ===========  =================================================

A device may also offer optional methods (:data:`OPTIONAL_METHODS`: ``applied_bias(bias)``,
the bias its DAC really applies; ``close()``, made safe at the end of a run) and name the model
structure it follows (``structure``, for a study's ``structures = "auto"``).

This module is the only place that looks for any of them on a device: :func:`read_capabilities`
(:class:`~sysid_core.device.measuring.GuardedDevice` calls it once and keeps the result as its
``capabilities``), :func:`optional_method` and :func:`named_structure`;
``tests/test_architecture.py`` fails on a ``getattr`` on a device anywhere else.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any, Protocol, runtime_checkable

import numpy as np

from sysid_core.errors import DeviceError

__all__ = [
    "CAPABILITIES",
    "OPTIONAL_METHODS",
    "Capabilities",
    "StatesCapabilities",
    "named_structure",
    "optional_method",
    "read_capabilities",
]

#: The optional methods a device may offer, and what each does.
OPTIONAL_METHODS: dict[str, str] = {
    "applied_bias": "applied_bias(bias): the bias the device's DAC really applies for bias",
    "close": "close(): make the bench safe and release it when the run ends",
}


@runtime_checkable
class StatesCapabilities(Protocol):
    """The optional capabilities a device may state (each may also be absent or ``None``).

    Attributes
    ----------
    tones : int
        Frequencies one acquisition measures at once (a lock-in with several demodulators, a
        multisine); at least 1.
    dwell_s : float
        Seconds per acquisition; a device that states it has a clock. Positive and finite.
    settle_s : float
        Seconds the gyro needs after a bias change before a measurement is valid; finite, >= 0.
    points_per_frequency : int
        Measurements the device makes per frequency point; at least 1.
    bias_resolution : float
        The DAC's step in volts; positive and finite.
    """

    tones: int | None
    dwell_s: float | None
    settle_s: float | None
    points_per_frequency: int | None
    bias_resolution: float | None


@dataclass(frozen=True)
class Capabilities:
    """What a device stated of its bench, checked (``None``: not stated)."""

    tones: int | None = None
    dwell_s: float | None = None
    settle_s: float | None = None
    points_per_frequency: int | None = None
    bias_resolution: float | None = None

    @property
    def clock(self) -> bool:
        """The device states its dwell per acquisition: a point costs seconds of a clock."""
        return self.dwell_s is not None

    @property
    def per_frequency(self) -> int:
        """Measurements per frequency point (1 unless stated)."""
        return self.points_per_frequency or 1


def _whole(value: Any) -> int | None:
    if isinstance(value, bool) or not isinstance(value, (int, np.integer)):
        return None
    return int(value) if value >= 1 else None


def _seconds(value: Any, zero: bool) -> float | None:
    if isinstance(value, bool):
        return None
    try:
        x = float(value)
    except (TypeError, ValueError):
        return None
    return x if math.isfinite(x) and (x > 0 or (zero and x == 0)) else None


#: Each capability: its rule (the checked value, or None if the value breaks it) and what the
#: rule says, for the message.
CAPABILITIES: dict[str, tuple[Callable[[Any], int | float | None], str]] = {
    "tones": (_whole, "a whole number >= 1 (frequencies per acquisition)"),
    "dwell_s": (lambda v: _seconds(v, zero=False), "a finite number of seconds > 0"),
    "settle_s": (lambda v: _seconds(v, zero=True), "a finite number of seconds >= 0"),
    "points_per_frequency": (_whole, "a whole number >= 1 (measurements per frequency)"),
    "bias_resolution": (lambda v: _seconds(v, zero=False), "a finite number of volts > 0"),
}


def read_capabilities(device: object, name: str = "device") -> Capabilities:
    """The capabilities ``device`` states, each checked against its rule.

    Raises
    ------
    DeviceError
        Naming the device, the attribute, the value and what it must be.
    """
    found: dict[str, Any] = {}
    for attr, (rule, must) in CAPABILITIES.items():
        value = getattr(device, attr, None)
        if value is None:
            continue
        checked = rule(value)
        if checked is None:
            raise DeviceError(
                f"device {name!r}: {attr!r} must be {must} or absent, got {value!r} "
                "(see docs/writing-a-device.md)"
            )
        found[attr] = checked
    return Capabilities(**found)


def optional_method(device: object, name: str) -> Callable[..., Any] | None:
    """The optional method ``name`` of ``device`` (:data:`OPTIONAL_METHODS`), or None."""
    if name not in OPTIONAL_METHODS:
        raise ValueError(
            f"{name!r} is not an optional device method ({', '.join(OPTIONAL_METHODS)})"
        )
    method = getattr(device, name, None)
    return method if callable(method) else None


def named_structure(device: object) -> str | None:
    """The model structure ``device`` names (its ``structure`` attribute), or None."""
    name = getattr(device, "structure", None)
    return name if isinstance(name, str) and name else None
