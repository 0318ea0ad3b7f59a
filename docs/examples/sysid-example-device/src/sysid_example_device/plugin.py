"""The plugin module named by the ``sysid`` entry point in pyproject.toml."""

from __future__ import annotations

from collections.abc import Callable, Mapping

from sysid_core import hookimpl
from sysid_core.plugin.interfaces import Device
from sysid_example_device.device import ExampleGyro


@hookimpl
def sysid_devices() -> Mapping[str, Callable[..., Device]]:
    """Device names (for ``[device] name = ...``) and their factories."""
    return {"example-gyro": ExampleGyro}
