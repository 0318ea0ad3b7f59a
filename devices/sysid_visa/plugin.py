"""Entry point of the ``visa`` device (entry-point group ``sysid``)."""

from __future__ import annotations

from collections.abc import Callable, Mapping

from sysid_core import hookimpl
from sysid_core.device import Device
from sysid_visa.cli import instrument_sim_cmd
from sysid_visa.device import VisaDevice


@hookimpl
def sysid_devices() -> Mapping[str, Callable[..., Device]]:
    """The PyVISA bench device."""
    return {VisaDevice.name: VisaDevice}


@hookimpl
def sysid_cli_commands() -> Mapping[str, Callable[..., None]]:
    """``sysid instrument-sim``: simulated instruments for the device."""
    return {"instrument-sim": instrument_sim_cmd}
