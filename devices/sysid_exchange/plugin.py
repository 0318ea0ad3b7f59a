"""Entry point of the ``exchange`` device (entry-point group ``sysid``)."""

from __future__ import annotations

from collections.abc import Callable, Mapping

from sysid_core import hookimpl
from sysid_core.device.protocol import Device
from sysid_exchange.device import ExchangeDevice


@hookimpl
def sysid_devices() -> Mapping[str, Callable[..., Device]]:
    """The file-exchange device."""
    return {ExchangeDevice.name: ExchangeDevice}
