"""Install a test-only or example plugin package the way a third party's would be installed.

The package is pip-installed (a regular, non-editable install without dependencies) into the
running environment if it is not installed yet: it lands in site-packages, which is already on
``sys.path``, so this process and every later test can import it (an editable install would
work through a .pth file that only new processes read, and this process would then warn that
the plugin fails to load).
"""

from __future__ import annotations

import importlib.metadata
import importlib.util
import os
import subprocess
import sys
from pathlib import Path

import pytest

OFFLINE_HINTS = (
    "No matching distribution",
    "Could not find a version",
    "Failed to establish a new connection",
    "Network is unreachable",
    "Temporary failure in name resolution",
)


def installed(distribution: str) -> bool:
    """Whether ``distribution`` is installed in this environment."""
    try:
        importlib.metadata.distribution(distribution)
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


def install(path: Path, distribution: str) -> None:
    """pip-install the package at ``path`` unless ``distribution`` is installed already.

    Skips the calling test when pip is missing or no package index is reachable; fails it when
    pip fails otherwise. Resets the process-wide plugin registry so that it sees the package.
    """
    if installed(distribution):
        return
    if importlib.util.find_spec("pip") is None:
        pytest.skip(f"pip is not available to install {path}")
    command = [sys.executable, "-m", "pip", "install", "--quiet", "--disable-pip-version-check"]
    command += ["--no-deps"]
    if _can_build_without_isolation():
        command += ["--no-build-isolation"]
    command += [str(path)]
    done = subprocess.run(command, capture_output=True, text=True, timeout=600, check=False)
    if done.returncode != 0:
        tail = "\n".join((done.stdout + done.stderr).strip().splitlines()[-15:])
        if any(hint in tail for hint in OFFLINE_HINTS):
            pytest.skip(f"cannot install {path} offline (no package index reachable):\n{tail}")
        pytest.fail(f"pip could not install {path}:\n{tail}")
    importlib.invalidate_caches()
    from sysid_core.registry import reset_registry

    reset_registry()  # the next lookup sees the new entry point


def environment() -> dict[str, str]:
    """The environment for a subprocess that must load every installed plugin."""
    env = dict(os.environ)
    env.pop("SYSID_DISABLE_PLUGIN_AUTOLOAD", None)
    env.pop("SYSID_DEBUG", None)
    return env
