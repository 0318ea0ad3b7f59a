"""A simulated cloverleaf gyro with injectable faults, for sysid-toolkit's fault tests."""

from sysid_faulty_device.device import FAULTS, FaultyGyro

__all__ = ["FAULTS", "FaultyGyro"]
