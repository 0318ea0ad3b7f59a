"""The third-party example in docs/examples/sysid-example-device installs and registers.

The example is pip-installed like a third party's package (see ``tests/installing.py``); the
checks run in subprocesses, as a user's program would.
"""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import pytest
from installing import environment, run_python

EXAMPLE = Path(__file__).resolve().parents[2] / "docs" / "examples" / "sysid-example-device"
DISTRIBUTION = "sysid-example-device"


def _environment() -> dict[str, str]:
    return environment()


@pytest.fixture(scope="module")
def example_installed(example_plugin: Path) -> None:
    """The example package, installed for this session only (see conftest.py)."""


def test_registry_lists_example_gyro_with_its_distribution(example_installed: None) -> None:
    out = run_python(
        "from sysid_core.plugin.registry import Registry\n"
        "registry = Registry()\n"
        "component = registry.get('device', 'example-gyro')\n"
        "print(component.distribution)\n"
        "print('example-gyro' in registry.names('device'))\n"
        "device = registry.create('device', 'example-gyro', seed=3)\n"
        "print(type(device).__name__, device.electrodes, device.bias_limits)\n"
    )
    lines = out.splitlines()
    assert lines[0] == DISTRIBUTION
    assert lines[1] == "True"
    assert lines[2] == "ExampleGyro ('T1', 'T2') (-5.0, 5.0)"


def test_example_contract_tests_pass(example_installed: None) -> None:
    done = subprocess.run(
        [sys.executable, "-m", "pytest", "-q", "-p", "no:cacheprovider", str(EXAMPLE / "tests")],
        capture_output=True,
        text=True,
        timeout=300,
        cwd=EXAMPLE,
        env=_environment(),
        check=False,
    )
    assert done.returncode == 0, done.stdout + done.stderr
    assert "passed" in done.stdout
