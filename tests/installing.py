"""Install the test-only and example plugin packages the way a third party's are, but never into
the environment that runs the tests.

:func:`install` pip-installs a package (no dependencies) into a temporary ``--target`` folder,
once per test session, and puts that folder first on ``sys.path`` (this process) and on
``PYTHONPATH`` (subprocesses, :func:`environment`). The package's entry points are then found
like any installed plugin's; the folder is removed at the end of the session, and the
environment's own packages are never touched.
"""

from __future__ import annotations

import importlib
import importlib.metadata
import importlib.util
import os
import shutil
import subprocess
import sys
import tempfile
from pathlib import Path
from typing import Any

import pytest

__all__ = ["environment", "install", "remove_all", "run_python"]

OFFLINE_HINTS = (
    "No matching distribution",
    "Could not find a version",
    "Failed to establish a new connection",
    "Network is unreachable",
    "Temporary failure in name resolution",
)

_ROOT: Path | None = None
_DONE: dict[str, Path] = {}


def _can_build_without_isolation() -> bool:
    """setuptools builds wheels in place from 70.1 on; before that it needs the wheel package."""
    if importlib.util.find_spec("setuptools") is None:
        return False
    version = tuple(int(p) for p in importlib.metadata.version("setuptools").split(".")[:2])
    if version < (64, 0):
        return False
    return version >= (70, 1) or importlib.util.find_spec("wheel") is not None


def install(path: Path, distribution: str) -> Path:
    """Install the package at ``path`` into this session's plugin folder; return the folder.

    Skips the calling test when pip is missing or no package index is reachable (an isolated
    build needs setuptools from the index); fails it when pip fails otherwise.
    """
    global _ROOT
    if distribution in _DONE:
        return _DONE[distribution]
    if importlib.util.find_spec("pip") is None:
        pytest.skip(f"pip is not available to install {path}")
    if _ROOT is None:
        _ROOT = Path(tempfile.mkdtemp(prefix="sysid-test-plugins-"))
        sys.path.insert(0, str(_ROOT))
    build = Path(tempfile.mkdtemp(prefix="sysid-build-"))
    shutil.copytree(path, build / "src", ignore=shutil.ignore_patterns("build", "*.egg-info"))
    command = [sys.executable, "-m", "pip", "install", "--quiet", "--disable-pip-version-check"]
    command += ["--no-deps", "--target", str(_ROOT), "--upgrade"]
    if _can_build_without_isolation():
        command += ["--no-build-isolation"]
    command += [str(build / "src")]
    done = subprocess.run(command, capture_output=True, text=True, timeout=600, check=False)
    shutil.rmtree(build, ignore_errors=True)
    if done.returncode != 0:
        tail = "\n".join((done.stdout + done.stderr).strip().splitlines()[-15:])
        if any(hint in tail for hint in OFFLINE_HINTS):
            pytest.skip(f"cannot install {path} offline (no package index reachable):\n{tail}")
        pytest.fail(f"pip could not install {path}:\n{tail}")
    importlib.invalidate_caches()
    from sysid_core.plugin.registry import reset_registry

    reset_registry()  # the next lookup sees the new entry points
    _DONE[distribution] = _ROOT
    return _ROOT


def remove_all() -> None:
    """Take the session's plugin folder off ``sys.path`` and delete it."""
    global _ROOT
    if _ROOT is not None:
        if str(_ROOT) in sys.path:
            sys.path.remove(str(_ROOT))
        shutil.rmtree(_ROOT, ignore_errors=True)
        _ROOT = None
        _DONE.clear()
        importlib.invalidate_caches()
        from sysid_core.plugin.registry import reset_registry

        reset_registry()


def environment() -> dict[str, str]:
    """The environment for a subprocess that must load every plugin, the test ones included."""
    env = dict(os.environ)
    env.pop("SYSID_DISABLE_PLUGIN_AUTOLOAD", None)
    env.pop("SYSID_DEBUG", None)
    if _ROOT is not None:
        env["PYTHONPATH"] = os.pathsep.join([str(_ROOT), *filter(None, [env.get("PYTHONPATH")])])
    return env


def run_python(code: str) -> str:
    """Run ``code`` in a new Python process that sees the installed plugins; its stdout.

    Fails the calling test, with the process's output, if the code fails.
    """
    done = subprocess.run(
        [sys.executable, "-c", code],
        capture_output=True,
        text=True,
        timeout=120,
        env=environment(),
        check=False,
    )
    assert done.returncode == 0, done.stdout + done.stderr
    return done.stdout


def default_sigint() -> None:
    """``preexec_fn`` for a child that a test interrupts with SIGINT: Ctrl-C's default action.

    A process started in the background by a non-interactive shell (a CI runner's job) has
    SIGINT ignored, and its children inherit that: Python then installs no KeyboardInterrupt
    handler and the test's SIGINT would do nothing.
    """
    import signal

    signal.signal(signal.SIGINT, signal.SIG_DFL)


def start_sysid(*args: str, **kw: Any) -> subprocess.Popen[str]:
    """``python -m sysid_core.cli ARGS`` in the background with pipes, this environment, and
    SIGINT's default action (so a test can interrupt it)."""
    return subprocess.Popen(
        [sys.executable, "-m", "sysid_core.cli", *args],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
        env=environment(),
        preexec_fn=default_sigint,
        **kw,
    )
