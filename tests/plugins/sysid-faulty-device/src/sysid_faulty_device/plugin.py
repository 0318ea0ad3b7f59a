"""Entry point of the ``faulty-gyro`` device."""

from sysid_core import hookimpl
from sysid_faulty_device.device import FaultyGyro


@hookimpl
def sysid_devices():
    """The faulty gyro."""
    return {"faulty-gyro": FaultyGyro}
