"""The third-party example in docs/examples/sysid-example-device installs and registers.

The example is pip-installed (a regular, non-editable install without dependencies) into the
running environment if it is not installed yet: it lands in site-packages, which is already on
``sys.path``, so this process and every later test can import it (an editable install would
work through a .pth file that only new processes read, and this process would then warn that
the plugin fails to load). The checks run in subprocesses, as a user's program would.
"""

from __future__ import annotations

import importlib.metadata
import importlib.util
import os
import subprocess
import sys
from pathlib import Path

import pytest

EXAMPLE = Path(__file__).resolve().parents[1] / "docs" / "examples" / "sysid-example-device"
DISTRIBUTION = "sysid-example-device"
OFFLINE_HINTS = (
    "No matching distribution",
    "Could not find a version",
    "Failed to establish a new connection",
    "Network is unreachable",
    "Temporary failure in name resolution",
)


def _installed() -> bool:
    try:
        importlib.metadata.distribution(DISTRIBUTION)
    except importlib.metadata.PackageNotFoundError:
        return False
    return True


def _can_build_without_isolation() -> bool:
    """setuptools builds wheels in place from 70.1 on; before that it needs the wheel package."""
    if importlib.util.find_spec("setuptools") is None:
        return False
    version = tuple(int(p) for p in importlib.metadata.version("setuptools").split(".")[:2])
    if version < (64, 0):
        return False
    return version >= (70, 1) or importlib.util.find_spec("wheel") is not None


def _environment() -> dict[str, str]:
    env = dict(os.environ)
    env.pop("SYSID_DISABLE_PLUGIN_AUTOLOAD", None)
    return env


@pytest.fixture(scope="module")
def example_installed() -> None:
    if _installed():
        return
    if importlib.util.find_spec("pip") is None:
        pytest.skip(f"pip is not available to install {EXAMPLE}")
    command = [sys.executable, "-m", "pip", "install", "--quiet", "--disable-pip-version-check"]
    command += ["--no-deps"]
    if _can_build_without_isolation():
        command += ["--no-build-isolation"]
    command += [str(EXAMPLE)]
    done = subprocess.run(command, capture_output=True, text=True, timeout=600, check=False)
    if done.returncode != 0:
        tail = "\n".join((done.stdout + done.stderr).strip().splitlines()[-15:])
        if any(hint in tail for hint in OFFLINE_HINTS):
            pytest.skip(f"cannot install the example offline (no package index reachable):\n{tail}")
        pytest.fail(f"pip could not install {EXAMPLE}:\n{tail}")
    importlib.invalidate_caches()
    from sysid_core.registry import reset_registry

    reset_registry()  # the next lookup sees the new entry point


def _run(code: str) -> str:
    done = subprocess.run(
        [sys.executable, "-c", code],
        capture_output=True,
        text=True,
        timeout=120,
        env=_environment(),
        check=False,
    )
    assert done.returncode == 0, done.stdout + done.stderr
    return done.stdout


def test_registry_lists_example_gyro_with_its_distribution(example_installed: None) -> None:
    out = _run(
        "from sysid_core.registry import Registry\n"
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
