"""Helpers of the fault tests: a configuration for the faulty device, the CLI in a subprocess.

Not a test module: the fault tests of every kind import it.
"""

from __future__ import annotations

import subprocess
import sys
import time
from pathlib import Path
from typing import Any

import pytest
from installing import environment, start_sysid

EXAMPLE_DATA = Path(__file__).resolve().parents[2] / "examples" / "cloverleaf-3exp.nc"
FAST = {"resolution_hz": 1.0, "verify_resolution_hz": 0.02}
TUNE = {"criterion": "degenerate", "electrodes": ["B1", "B2"], "start_bias": [0.0, 0.0, 0.0]}


def tables(
    device: dict[str, Any] | None = None,
    tuning: dict[str, Any] | None = None,
    experiment: dict[str, Any] | None = None,
    **more: dict[str, Any],
) -> dict[str, dict[str, Any]]:
    return {
        "device": {"name": "faulty-gyro", "seed": 1, **(device or {})},
        "tuning": {**TUNE, "max_iterations": 1, **(tuning or {})},
        "experiment": {**FAST, **(experiment or {})},
        **more,
    }


def sysid(*args: str, timeout: float = 120, **kw: Any) -> subprocess.CompletedProcess[str]:
    return subprocess.run(
        [sys.executable, "-m", "sysid_core.cli", *args],
        capture_output=True,
        text=True,
        timeout=timeout,
        env=environment(),
        check=False,
        **kw,
    )


def one_error_line(stderr: str) -> str:
    lines = [x for x in stderr.strip().splitlines() if x.strip()]
    assert "Traceback" not in stderr, stderr
    assert lines and lines[-1].startswith("sysid: error: "), stderr
    return lines[-1]


def start(args: list[str], **kw: Any) -> subprocess.Popen[str]:
    return start_sysid(*args, **kw)  # SIGINT reaches it even if this runs in the background


def wait_for(path: Path, proc: subprocess.Popen[str], timeout: float = 60) -> None:
    t0 = time.monotonic()
    while not path.exists():
        if proc.poll() is not None:
            pytest.fail(f"the process ended early: {proc.communicate()}")
        if time.monotonic() - t0 > timeout:
            proc.kill()
            pytest.fail(f"{path} did not appear within {timeout} s")
        time.sleep(0.05)
