"""Entry point of the ``cloverleaf`` device (entry-point group ``sysid``)."""

from __future__ import annotations

from collections.abc import Callable, Mapping

from sysid_cloverleaf.device import CloverleafGyro
from sysid_core import hookimpl
from sysid_core.plugin.interfaces import Device


@hookimpl
def sysid_devices() -> Mapping[str, Callable[..., Device]]:
    """The simulated cloverleaf gyro."""
    return {CloverleafGyro.name: CloverleafGyro}
