"""Faults of the process: exit statuses, Ctrl-C, pipes.

Exit status 0 only on success, 2 for usage errors, 130 on Ctrl-C (with how to resume, also while
the program starts), 1 with one line ``sysid: error: ...`` otherwise; output piped to a file is
whole. The real CLI runs in a subprocess where the process matters.
"""

from __future__ import annotations

import json
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest
from faulting import (
    one_error_line,
    start,
    sysid,
    tables,
    wait_for,
)
from installing import environment
from truths import write_toml


@pytest.mark.parametrize(
    ("args", "expect"),
    [
        (["fit"], "Missing argument"),
        (["fit", "x.nc", "--order", "abc"], "--order"),
        (["frobnicate"], "No such command"),
    ],
)
def test_usage_errors_exit_2_with_usage(args: list[str], expect: str) -> None:
    done = sysid(*args)
    assert done.returncode == 2, done.stderr
    assert "Usage:" in done.stderr and expect in done.stderr
    assert "internal error" not in done.stderr and "Traceback" not in done.stderr


def test_version_and_success_exit_0() -> None:
    done = sysid("--version")
    assert done.returncode == 0 and done.stdout.startswith("sysid ")


def test_ctrl_c_exits_130_with_how_to_resume_and_resume_works(tmp_path: Path) -> None:
    once = tmp_path / "fault-fired"
    cfg = write_toml(
        tmp_path / "c.toml",
        tables(device={"fault": "slow", "on_call": 2, "hang_s": 60, "once_file": str(once)}),
    )
    out = tmp_path / "run"
    proc = start(["tune", str(cfg), "--out", str(out), "--no-plots"])
    wait_for(out / "iter01" / "exp0.nc", proc)
    wait_for(once, proc)  # now inside the slow measurement
    proc.send_signal(signal.SIGINT)
    try:  # generous: on a loaded machine the interpreter may take a while to get scheduled
        _, err = proc.communicate(timeout=90)
    finally:
        if proc.poll() is None:  # never leak the process into later tests
            proc.kill()
            proc.communicate()
    assert proc.returncode == 130, err
    last = err.strip().splitlines()[-1]
    assert last.startswith("sysid: interrupted") and "--resume" in last, err
    assert "Traceback" not in err
    done = sysid("tune", str(cfg), "--out", str(out), "--no-plots", "--resume")
    last = done.stderr.strip().splitlines()[-1]
    assert done.returncode == 0 or "error: NOT converged" in last, done.stderr  # it finished
    assert "measured earlier" in done.stderr
    assert json.loads((out / "summary.json").read_text())["iterations"] == 1


@pytest.mark.parametrize("delay_s", [0.3, 0.8])
def test_ctrl_c_while_the_program_starts_is_one_line_not_a_traceback(delay_s: float) -> None:
    """The ``sysid`` script interrupted during its imports (numpy, xarray, the plugins): one
    line, the interrupt's exit status, no traceback (sysid_core._launch)."""
    from installing import default_sigint

    script = Path(sys.executable).parent / "sysid"
    if not script.exists():
        pytest.skip("no sysid script next to this interpreter")
    proc = subprocess.Popen(
        [str(script), "--help"],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
        env=environment(),
        preexec_fn=default_sigint,
    )
    time.sleep(delay_s)
    proc.send_signal(signal.SIGINT)
    _, err = proc.communicate(timeout=60)
    if proc.returncode == 0:
        pytest.skip("the program had started before the interrupt (a fast machine)")
    assert proc.returncode in (130, -signal.SIGINT), err
    assert "Traceback" not in err and err.strip().splitlines() == [
        "sysid: interrupted while starting; nothing was done"
    ], err


def test_a_failure_is_one_line_and_exit_1(tmp_path: Path) -> None:
    cfg = write_toml(tmp_path / "c.toml", tables(device={"fault": "raise", "on_call": 2}))
    done = sysid("tune", str(cfg), "--out", str(tmp_path / "run"), "--no-plots")
    assert done.returncode == 1
    line = one_error_line(done.stderr)
    assert "lost the connection to the analyzer" in line


def test_piped_output_is_not_cut() -> None:
    done = sysid("plugins")
    assert done.returncode == 0
    assert "…" not in done.stdout
    listed = json.loads(sysid("plugins", "--json").stdout)["components"]
    rows = done.stdout.splitlines()
    for c in listed:
        wanted = (f" {c['kind']} ", f" {c['name']} ", c["distribution"], c["description"])
        assert any(all(w in row for w in wanted) for row in rows), (c, done.stdout)
