"""Entry point of the ``visa`` device (entry-point group ``sysid``)."""

from __future__ import annotations

from collections.abc import Callable, Mapping

from sysid_core.device import Device
from sysid_core.hookspec import hookimpl
from sysid_visa.device import VisaDevice


@hookimpl
def sysid_devices() -> Mapping[str, Callable[..., Device]]:
    """The PyVISA bench device."""
    return {VisaDevice.name: VisaDevice}
