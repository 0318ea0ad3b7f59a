"""Run the toolkit's device contract on example-gyro, plus the device's own checks."""

from __future__ import annotations

from collections.abc import Callable

import numpy as np
from sysid_example_device import ExampleGyro

from sysid_core.plugin.interfaces import Device
from sysid_core.testing import DeviceContract


class TestExampleGyro(DeviceContract):
    checks_bias_limits = True  # ExampleGyro refuses out-of-limit biases itself

    def make_device(self) -> Device:
        return ExampleGyro(seed=1)

    def device_factory(self) -> Callable[..., Device]:
        return ExampleGyro


def test_tunable_inside_its_limits() -> None:
    gyro = ExampleGyro()
    bias = gyro.truth.degenerate_bias((0, 1))
    low, high = gyro.bias_limits
    assert np.all((bias > low) & (bias < high))
    split = np.diff(gyro.true_modal_frequencies_hz(bias))[0]
    assert split < 1e-6
