"""The public device contract (sysid_core.testing.DeviceContract) on the built-in devices."""

from __future__ import annotations

from collections.abc import Callable

from sysid_cloverleaf import CloverleafGyro
from sysid_post_resonator import PostResonatorGyro

from sysid_core.plugin.interfaces import Device
from sysid_core.testing import DeviceContract


class TestCloverleafContract(DeviceContract):
    checks_bias_limits = True

    def make_device(self) -> Device:
        return CloverleafGyro(seed=3)

    def device_factory(self) -> Callable[..., Device]:
        return CloverleafGyro


class TestPostResonatorContract(DeviceContract):
    checks_bias_limits = True

    def make_device(self) -> Device:
        return PostResonatorGyro(seed=4)

    def device_factory(self) -> Callable[..., Device]:
        return PostResonatorGyro


class TestCloverleafContractIdeal(TestCloverleafContract):
    """The contract holds without noise, feedthrough, extra modes and quantisation too."""

    repeat_tolerance = 0.0

    def make_device(self) -> Device:
        return CloverleafGyro(noise=0.0, feedthrough=0.0, extra_modes=False, dac_bits=0)
