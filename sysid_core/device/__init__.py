"""Devices: the protocol a gyro bench follows, measuring through it, and simulated truths.

Lives here: the duck-typed device protocol and its checks (:mod:`.protocol`), the optional
capabilities a device states of its bench, read and checked once (:mod:`.capabilities`), one
checked measurement (:mod:`.measuring`) and the second-order gyro truths that simulated devices and
tests build on (:mod:`.simulation`).

May import: :mod:`sysid_core.errors`, :mod:`sysid_core.data`, :mod:`sysid_core.conic`,
:mod:`sysid_core.model`. Not :mod:`sysid_core.identification` or :mod:`sysid_core.tuning`.
"""

from sysid_core.device.capabilities import Capabilities, StatesCapabilities, read_capabilities
from sysid_core.device.protocol import (
    Device,
    ReportsProgress,
    SimulatedDevice,
    check_device,
)

__all__ = [
    "Capabilities",
    "Device",
    "ReportsProgress",
    "SimulatedDevice",
    "StatesCapabilities",
    "check_device",
    "read_capabilities",
]
