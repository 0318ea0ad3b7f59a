"""sysid-example-device: an example third-party device plugin for sysid-toolkit.

Provides the device ``example-gyro`` (:class:`ExampleGyro`) through the ``sysid`` entry point.
"""

from __future__ import annotations

from sysid_example_device.device import ExampleGyro, example_truth

__all__ = ["ExampleGyro", "example_truth"]
