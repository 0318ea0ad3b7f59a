"""Entry point of the ``random-gyro`` device (entry-point group ``sysid``)."""

from __future__ import annotations

from collections.abc import Callable, Mapping

from sysid_core import hookimpl
from sysid_core.plugin.interfaces import Device
from sysid_random_gyro.device import RandomGyro


@hookimpl
def sysid_devices() -> Mapping[str, Callable[..., Device]]:
    """The seeded random simulated gyro."""
    return {RandomGyro.name: RandomGyro}
