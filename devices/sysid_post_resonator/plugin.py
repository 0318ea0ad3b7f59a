"""Entry point of the ``post-resonator`` device (entry-point group ``sysid``)."""

from __future__ import annotations

from collections.abc import Callable, Mapping

from sysid_core import hookimpl
from sysid_core.plugin.interfaces import Device
from sysid_post_resonator.device import PostResonatorGyro


@hookimpl
def sysid_devices() -> Mapping[str, Callable[..., Device]]:
    """The simulated post-resonator gyro."""
    return {PostResonatorGyro.name: PostResonatorGyro}
