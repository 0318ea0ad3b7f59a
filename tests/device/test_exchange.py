"""The ``exchange`` device, answered by the example operator in a background process.

The operator (``examples/exchange_operator.py``) answers each request from the simulated
cloverleaf; with the same seed it sees the same measurement sequence as the built-in
``cloverleaf`` device, so the run must end at the same bias.
"""

from __future__ import annotations

import json
import re
import subprocess
import sys
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from installing import environment
from truths import write_toml

from sysid_core.cli import main
from sysid_core.errors import BiasLimitError, DeviceError
from sysid_core.measure.lean import LOCATE_POINTS
from sysid_core.run.config import parse_config
from sysid_core.run.pipeline import TuningRun

ROOT = Path(__file__).resolve().parents[2]
OPERATOR = ROOT / "examples" / "exchange_operator.py"
TABLES: dict[str, Any] = {
    "model": {"stiffness": "linear"},  # one-sided design: 3 requests per iteration
    "tuning": {
        "criterion": "degenerate",
        "electrodes": ["B1", "B2"],
        "start_bias": [0.0, 0.0, 0.0],
        "max_iterations": 2,
    },
    "experiment": {"resolution_hz": 1.0, "verify_resolution_hz": 0.02},
}


def exchange(folder: Path, **options: Any) -> dict[str, Any]:
    device = {
        "name": "exchange",
        "dir": str(folder),
        "electrodes": ["B1", "B2", "B3"],
        "bias_limits": [-10.0, 10.0],
        "structure_potential": 15.58,
        "band_hz": [4385.0, 4445.0],
        "wait_s": 30.0,
        "poll_s": 0.02,
        **options,
    }
    return {"device": device, **TABLES}


#: Every operator a test started: one still running when its test ends (a failed assertion
#: before its ``stop``) is killed then, not left answering into a deleted folder.
_SPAWNED: list[subprocess.Popen[str]] = []


@pytest.fixture(autouse=True)
def _no_operator_outlives_its_test() -> Iterator[None]:
    yield
    while _SPAWNED:
        proc = _SPAWNED.pop()
        if proc.poll() is None:
            proc.kill()
            proc.communicate(timeout=30)


def operator(folder: Path, *args: str) -> subprocess.Popen[str]:
    """The example operator on ``folder``, returned once it is answering.

    Its first line says so: a run started earlier would wait for it, and a short ``wait_s``
    would time out on a loaded machine while the operator imports its libraries.
    """
    command = [sys.executable, str(OPERATOR), "--dir", str(folder), "--seed", "1", *args]
    proc = subprocess.Popen(
        command, env=environment(), stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True
    )
    _SPAWNED.append(proc)
    assert proc.stdout is not None
    first = proc.stdout.readline()
    assert first.startswith("operator: answering"), first + proc.communicate(timeout=30)[0]
    return proc


def stop(proc: subprocess.Popen[str]) -> str:
    proc.kill()
    out, _ = proc.communicate(timeout=30)
    return out


@pytest.fixture(scope="module")
def reference(tmp_path_factory: pytest.TempPathFactory) -> np.ndarray:
    """The same tuning with the built-in cloverleaf, seed 1."""
    cfg = parse_config({"device": {"name": "cloverleaf", "seed": 1}, **TABLES})
    out = tmp_path_factory.mktemp("reference") / "run"
    return np.asarray(TuningRun(cfg, out, plots=False).run().bias)


def test_answered_by_an_operator_it_tunes_like_the_built_in_device(
    tmp_path: Path, reference: np.ndarray, capsys: pytest.CaptureFixture[str]
) -> None:
    """A full ``sysid tune`` through files ends at the built-in device's bias (seed 1)."""
    folder = tmp_path / "exchange"
    cfg = write_toml(tmp_path / "exchange.toml", exchange(folder))
    proc = operator(folder)
    try:
        code = main(["tune", str(cfg), "--out", str(tmp_path / "run"), "--json", "--no-plots"])
    finally:
        log = stop(proc)
    captured = capsys.readouterr()
    assert code == 0, captured.err
    result = json.loads(captured.out.strip().splitlines()[-1])
    np.testing.assert_allclose(result["bias"], reference, rtol=0, atol=1e-3)
    assert result["converged"] and result["device"] == "exchange"
    first = json.loads((folder / "request-0001.json").read_text())
    assert first["id"] == 1 and first["electrodes"] == ["B1", "B2", "B3"]
    assert first["bias_v"] == [0.0, 0.0, 0.0] and len(first["frequencies_hz"]) == LOCATE_POINTS
    assert result["experiments"] == len(list(folder.glob("response-*.csv"))), log


def test_progress_says_which_biases_to_set_and_which_file_to_write(tmp_path: Path) -> None:
    folder = tmp_path / "exchange"
    proc = operator(folder, "--stop-after", "1")
    said: list[str] = []
    try:
        cfg = parse_config(exchange(folder, wait_s=2.0))
        with pytest.raises(DeviceError):
            TuningRun(cfg, tmp_path / "run", plots=False, progress=said.append).run()
    finally:
        stop(proc)
    first = next(m for m in said if m.startswith("exchange: request-0001.json"))
    assert (
        f"set B1 = 0 V, B2 = 0 V, B3 = 0 V, measure 4385-4445 Hz ({LOCATE_POINTS} points)" in first
    )
    # the built-in formats first; a format plugin installed for another test may add its own
    assert re.search(
        rf"write response-0001\.csv \(or \.s2p, \.mat, \.nc[^)]*\) in {re.escape(str(folder))}",
        first,
    )


def test_a_malformed_answer_is_rejected_and_may_be_written_again(
    tmp_path: Path, reference: np.ndarray
) -> None:
    folder = tmp_path / "exchange"
    proc = operator(folder, "--malformed", "2")
    said: list[str] = []
    try:
        cfg = parse_config(exchange(folder))
        summary = TuningRun(cfg, tmp_path / "run", plots=False, progress=said.append).run()
    finally:
        stop(proc)
    np.testing.assert_allclose(summary.bias, reference, rtol=0, atol=1e-3)
    kept = sorted(p.name for p in (folder / "rejected").iterdir())
    assert kept == ["response-0002.csv.1", "response-0002.csv.1.txt"]
    assert "no imaginary-part" in (folder / "rejected" / "response-0002.csv.1.txt").read_text()
    assert any("response-0002.csv rejected" in m for m in said)


def test_an_error_file_ends_the_run_with_its_text(tmp_path: Path) -> None:
    folder = tmp_path / "exchange"
    proc = operator(folder, "--error", "3")
    try:
        cfg = parse_config(exchange(folder))
        with pytest.raises(DeviceError, match="overload on input 2"):
            TuningRun(cfg, tmp_path / "run", plots=False).run()
    finally:
        stop(proc)
    assert sorted(p.name for p in (tmp_path / "run" / "iter01").glob("*.nc")) == [
        "exp0.nc",
        "exp1.nc",
    ]


def test_no_answer_within_wait_s_then_resume_reuses_the_late_answer(
    tmp_path: Path, reference: np.ndarray
) -> None:
    folder = tmp_path / "exchange"
    proc = operator(folder, "--stop-after", "3")
    cfg = parse_config(exchange(folder, wait_s=3.0))
    with pytest.raises(DeviceError, match=r"no answer to request-0004\.json"):
        TuningRun(cfg, tmp_path / "run", plots=False).run()
    assert stop(proc).count("wrote response") == 3
    # The bench answers request 4 while no run is going, then the run is resumed.
    late = operator(folder, "--stop-after", "1")
    late.communicate(timeout=60)
    assert (folder / "response-0004.csv").exists()
    resumed = operator(folder)
    try:
        summary = TuningRun(cfg, tmp_path / "run", resume=True, plots=False).run()
    finally:
        stop(resumed)
    requests = sorted(p.name for p in folder.glob("request-*.json"))
    assert requests == [f"request-{k:04d}.json" for k in range(1, len(requests) + 1)]
    assert summary.experiments == len(requests)  # no request was written twice
    np.testing.assert_allclose(summary.bias, reference, rtol=0, atol=1e-3)


def test_bias_limits_are_checked_before_a_request_is_written(tmp_path: Path) -> None:
    folder = tmp_path / "exchange"
    tables = exchange(folder)
    tables["tuning"] = {**tables["tuning"], "start_bias": [0.0, 12.0, 0.0]}
    with pytest.raises(BiasLimitError, match=r"12\.0 V"):
        TuningRun(parse_config(tables), tmp_path / "run", plots=False)
    assert not folder.exists()


def test_answers_with_time_stamps_give_the_run_its_clock(tmp_path: Path) -> None:
    """An answer file's ``time_s`` column (§3.2) reaches the run: saved with each experiment,
    and the bench time is the clock's span."""
    folder = tmp_path / "exchange"
    tables = exchange(folder)
    tables["tuning"] = {**tables["tuning"], "max_iterations": 1}
    cfg = write_toml(tmp_path / "exchange.toml", tables)
    proc = operator(folder, "--clock")
    try:
        code = main(["tune", str(cfg), "--out", str(tmp_path / "run"), "--no-plots"])
    finally:
        log = stop(proc)
    assert code == 0, log
    header = (folder / "response-0001.csv").read_text().splitlines()[1]
    assert header.endswith(",time_s")
    summary = json.loads((tmp_path / "run" / "summary.json").read_text())
    assert summary["bench_time_source"] == "clock" and summary["bench_time_s"] > 0
    from sysid_core.data import load_dataset, point_times

    first = load_dataset(tmp_path / "run" / "iter01" / "exp0.nc")
    assert point_times(first, 0) is not None
