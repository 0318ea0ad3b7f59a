"""The study: local and dask executors agree, results persist, bad studies are refused before
anything runs, failures are reported (exit status 1) and retried, killed workers lose nothing."""

from __future__ import annotations

import dataclasses
import json
import os
import signal
import subprocess
import sys
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from sysid_core import errors
from sysid_core.batch.study.runner import failure_message, load_study_config, plan_study, run_study

SMALL = """
[device]
name = "cloverleaf"
[model]
order = 1
[objective]
name = "least-squares"
[tuning]
electrodes = ["B1", "B2"]
start_bias = [0.0, 0.0, 0.0]
[experiment]
resolution_hz = 1.0
verify_resolution_hz = 0.02
refine_resolution_hz = 0.2
[study]
grid = [-3, 3]
structures = ["act"]
iterations = 2
"""


def _assert_close(a, b, abs_tol=1e-12):
    if isinstance(a, dict):
        assert a.keys() == b.keys()
        for k in a:
            _assert_close(a[k], b[k], abs_tol)
    elif isinstance(a, list):
        assert len(a) == len(b)
        for x, y in zip(a, b, strict=True):
            _assert_close(x, y, abs_tol)
    elif isinstance(a, float):
        assert a == pytest.approx(b, rel=1e-9, abs=abs_tol)
    else:
        assert a == b


def _cfg(tmp_path: Path, text: str = SMALL):
    path = tmp_path / "study.toml"
    path.write_text(text)
    return load_study_config(path)


def test_dask_and_local_executors_agree(tmp_path):
    cfg = _cfg(tmp_path)
    local = run_study(cfg, tmp_path / "local", executor="local", plots=False)
    dask = run_study(cfg, tmp_path / "dask", executor="dask", workers=2, plots=False)
    assert local["runs"] == dask["runs"] == 4
    # Identical up to floating-point summation order (BLAS threads differ between processes);
    # the summary rounds bias statistics to 1e-6 V, so a last digit may differ there.
    _assert_close(local["summary"], dask["summary"], abs_tol=1.01e-6)
    for key in ("least-squares-act-000", "least-squares-act-003"):
        a = json.loads((tmp_path / "local" / "results" / f"{key}.json").read_text())
        b = json.loads((tmp_path / "dask" / "results" / f"{key}.json").read_text())
        for ra, rb in zip(a["iterations"], b["iterations"], strict=True):
            ra.pop("fit_time_s"), rb.pop("fit_time_s")
            _assert_close(ra, rb)
    s = local["summary"]["least-squares"]["act"]["2"]
    assert s["runs"] == 4 and s["failed"] == 0
    # Two iterations from +-3 V tune the simulated cloverleaf to well under 300 mHz (true split).
    assert s["under_300mHz"] == 4
    assert np.allclose(s["mean_bias"], [2.04, 4.39], atol=0.2)


def test_rerun_skips_done_runs_and_writes_outputs(tmp_path, monkeypatch):
    cfg = _cfg(tmp_path)
    out = tmp_path / "s"
    first = run_study(cfg, out, executor="local", plots=True)
    assert (out / "results.nc").exists() and (out / "summary.json").exists()
    assert (out / "fig-least-squares-act-iter2.png").exists()
    import sysid_core.batch.study.execute as study_exec

    def boom(spec):
        raise AssertionError(f"run {spec.key} should not run again")

    monkeypatch.setattr(study_exec, "run_one", boom)
    again = run_study(cfg, out, executor="local", plots=False)
    assert again["summary"] == first["summary"]
    import xarray as xr

    ds = xr.open_dataset(out / "results.nc", engine="h5netcdf")
    assert ds["true_split_hz"].dims == ("objective", "model", "start", "iteration")
    assert ds.sizes["start"] == 4
    ds.close()


def _break_measurements_at(monkeypatch, tuned_start: list[float]) -> None:
    """Make the simulated cloverleaf fail when measuring at ``tuned_start`` (B1, B2)."""
    from sysid_cloverleaf.device import CloverleafGyro

    measure = CloverleafGyro.measure

    def broken(self, bias, frequencies_hz):
        if list(bias[:2]) == tuned_start:
            raise RuntimeError("lost the connection to the gyro")
        return measure(self, bias, frequencies_hz)

    monkeypatch.setattr(CloverleafGyro, "measure", broken)


def test_failed_run_is_reported_others_finish_and_a_rerun_retries_it(tmp_path, monkeypatch):
    import sysid_core.batch.study.execute as study_exec

    cfg = _cfg(tmp_path, SMALL.replace("iterations = 2", "iterations = 1"))
    out = tmp_path / "f"
    with monkeypatch.context() as m:
        _break_measurements_at(m, [3.0, -3.0])
        res = run_study(cfg, out, executor="local", plots=False)
    assert res["failed"] == len(res["failures"]) == 1
    failure = res["failures"][0]
    assert failure["key"] == "least-squares-act-002" and failure["start"][:2] == [3.0, -3.0]
    assert "DeviceError" in failure["error"] and "lost the connection" in failure["error"]
    assert res["summary"]["least-squares"]["act"]["1"]["runs"] == 3
    message = failure_message(res)
    assert message.startswith(
        "1 of 4 runs failed (first: least-squares-act-002 at start [3.0, -3.0]: DeviceError: "
    )
    assert f"results of the others are in {out}" in message and "\n" not in message
    assert (out / "summary.json").exists() and (out / "report.md").exists()
    saved = json.loads((out / "results" / "least-squares-act-002.json").read_text())
    assert "lost the connection" in saved["error"]

    ran = []
    run_one = study_exec.run_one
    monkeypatch.setattr(study_exec, "run_one", lambda spec: ran.append(spec.key) or run_one(spec))
    again = run_study(cfg, out, executor="local", plots=False)
    assert ran == ["least-squares-act-002"]  # only the failed run, not the three done ones
    assert again["failed"] == 0 and again["failures"] == [] and failure_message(again) == ""
    assert again["summary"]["least-squares"]["act"]["1"]["runs"] == 4
    saved = json.loads((out / "results" / "least-squares-act-002.json").read_text())
    assert saved["error"] is None and len(saved["iterations"]) == 1


_S, _G = 'structures = ["act"]', "grid = [-3, 3]"
BAD_STUDIES = [
    # (replace this, with this, what the message must say)
    (_S, 'structures = ["actt"]', "[study] structures: 'actt'"),
    (_S, "structures = []", "[study] structures is empty"),
    (_S, 'structures = ["act", "sen", "act"]', "[study] structures lists 'act' more"),
    (_S, _S + "\nobjectives = []", "[study] objectives is empty"),
    (_S, _S + '\nobjectives = ["minimax", "minimax"]', "[study] objectives lists 'minimax' more"),
    (_S, _S + '\nobjectives = ["minimax", "minmax"]', "[study] objectives: 'minmax'"),
    (_G, "starts = []", "[study] starts is empty"),
    (_G, "grid = []", "[study] grid is empty"),
    (_G, "grid = [-3, 3, -3]", "[study] grid lists -3.0 more"),
    (_G, "starts = [[1.0, 2.0], [1.0, 2.0]]", "[study] starts lists [1.0, 2.0] more"),
    (_G, "starts = [[0.0, 0.0], [12.0, 0.0]]", "[study] starts: start [12.0, 0.0] puts 12.0 V"),
    (_G, "grid = [-3, 10.5]", "[study] grid: start [-3.0, 10.5] puts 10.5 V"),
    (_G, "starts = [[1.0]]", "[study] starts: entry 0 ([1.0]) has 1 value"),
    (_G, "grid = [0]\nstarts = [[1.0, 1.0]]", "[study] has both starts and grid"),
    ("resolution_hz = 1.0", "resolution_hz = 1.0\nbias_step = 25.0", "bias_step = 25.0 V"),
    ("start_bias = [0.0, 0.0, 0.0]", "start_bias = [0, 0, 10.5]", "[tuning] start_bias: 10.5 V"),
    ('electrodes = ["B1", "B2"]', 'electrodes = ["B1", "B7"]', "[tuning] electrodes: ['B7']"),
    ('name = "cloverleaf"', 'name = "cloverleaf"\nnoize = 0.1', "unknown option 'noize'"),
    ("[experiment]", '[solver]\nname = "clarabell"\n[experiment]', "[solver]: 'clarabell'"),
]


@pytest.mark.parametrize(("old", "new", "says"), BAD_STUDIES)
def test_every_run_is_checked_before_any_starts_and_nothing_is_written(tmp_path, old, new, says):
    cfg = _cfg(tmp_path, SMALL.replace(old, new))
    out = tmp_path / "out"
    with pytest.raises(errors.ConfigError) as info:
        run_study(cfg, out, executor="local", plots=False)
    assert says in str(info.value)
    assert "\n" not in str(info.value)
    assert not out.exists()


def _sysid(*args: str | Path) -> subprocess.CompletedProcess[str]:
    env = {**os.environ, "COLUMNS": "200"}
    return subprocess.run(
        [sys.executable, "-m", "sysid_core.cli", *map(str, args)],
        capture_output=True,
        text=True,
        timeout=120,
        env=env,
    )


@pytest.mark.parametrize(("old", "new", "says"), [BAD_STUDIES[i] for i in (0, 6, 10)])
def test_cli_refuses_a_bad_study_with_exit_status_1(tmp_path, old, new, says):
    cfg = tmp_path / "bad.toml"
    cfg.write_text(SMALL.replace(old, new))
    out = tmp_path / "out"
    proc = _sysid("study", cfg, "--out", out, "--executor", "local", "--no-plots")
    assert proc.returncode == 1, proc.stderr
    lines = proc.stderr.splitlines()
    assert len(lines) == 1 and lines[0].startswith("sysid: error: "), proc.stderr
    assert says in lines[0]
    assert not out.exists()


def test_cli_exits_1_when_runs_failed_after_writing_every_output(tmp_path):
    # A device that never answers in time: every run fails while measuring.
    cfg = tmp_path / "slow.toml"
    cfg.write_text(
        SMALL.replace("iterations = 2", "iterations = 1").replace(
            "[experiment]", "[experiment]\ntimeout_s = 1e-6"
        )
    )
    out = tmp_path / "out"
    proc = _sysid("study", cfg, "--out", out, "--executor", "local", "--no-plots", "--json")
    assert proc.returncode == 1, proc.stderr
    lines = proc.stderr.splitlines()
    assert len(lines) == 1, proc.stderr
    assert lines[0].startswith(
        "sysid: error: 4 of 4 runs failed (first: least-squares-act-000 at start [-3.0, -3.0]: "
        "DeviceError: "
    )
    assert "1e-06 s" in lines[0] and "no run succeeded" in lines[0]
    assert lines[0].endswith("re-run the same command to retry the failed ones")
    report = json.loads(proc.stdout.splitlines()[-1])  # printed before the error
    assert report["failed"] == 4
    for name in ("study.json", "results.nc", "summary.json", "report.md"):
        assert (out / name).exists(), name
    assert len(list((out / "results").glob("*.json"))) == 4


def test_cli_partial_failure_then_rerun_retries_it(tmp_path, monkeypatch, capsys):
    import sysid_core.batch.study.execute as study_exec
    from sysid_core.cli import main

    cfg = tmp_path / "study.toml"
    cfg.write_text(SMALL.replace("iterations = 2", "iterations = 1"))
    out = tmp_path / "out"
    argv = ["study", str(cfg), "--out", str(out), "--executor", "local", "--no-plots", "--json"]
    with monkeypatch.context() as m:
        _break_measurements_at(m, [-3.0, 3.0])
        assert main(argv) == 1
    captured = capsys.readouterr()
    lines = captured.err.splitlines()
    assert len(lines) == 1 and lines[0].startswith(
        "sysid: error: 1 of 4 runs failed (first: least-squares-act-001 at start [-3.0, 3.0]: "
        "DeviceError: "
    )
    assert f"results of the others are in {out}" in captured.err
    assert json.loads(captured.out.splitlines()[-1])["failed"] == 1

    ran = []
    run_one = study_exec.run_one
    monkeypatch.setattr(study_exec, "run_one", lambda spec: ran.append(spec.key) or run_one(spec))
    assert main(argv) == 0
    captured = capsys.readouterr()
    assert ran == ["least-squares-act-001"] and captured.err == ""
    assert json.loads(captured.out.splitlines()[-1])["failed"] == 0


def test_cut_off_run_restarts_and_nothing_else_is_deleted(tmp_path):
    import sysid_core.batch.study.execute as study_exec

    cfg = _cfg(tmp_path, SMALL.replace("iterations = 2", "iterations = 1"))
    out = tmp_path / "s"
    run_study(cfg, out, executor="local", plots=False)
    # Cut off: the run's folder holds a half-done run, its result was never written.
    (out / "results" / "least-squares-act-001.json").unlink()
    (out / "runs" / "least-squares-act-001" / "half-written.nc").write_text("x")
    res = run_study(cfg, out, executor="local", plots=False)
    assert res["failed"] == 0
    assert not (out / "runs" / "least-squares-act-001" / "half-written.nc").exists()
    assert (out / "results" / "least-squares-act-001.json").exists()

    # A spec pointing anywhere else (a folder not under a study's runs/, or a link) is refused.
    spec = plan_study(cfg, out).specs[1]
    elsewhere = tmp_path / "precious" / spec.key
    elsewhere.mkdir(parents=True)
    (elsewhere / "keep.txt").write_text("keep")
    link = out / "runs" / "link"
    link.symlink_to(elsewhere)
    for target in (elsewhere, link):
        res = study_exec.run_one(dataclasses.replace(spec, out=str(target)))
        assert "refusing to delete" in res["error"]
    assert (elsewhere / "keep.txt").read_text() == "keep"


@pytest.mark.parametrize("allowed_failures", [3, 0], ids=["rescheduled", "killed-worker"])
def test_killed_worker_loses_no_result(tmp_path, allowed_failures):
    """A worker process killed (SIGKILL) mid-study: the study finishes, no result is lost.

    With dask's default, the dead worker's runs go to another worker; when dask gives up on
    them (``allowed-failures = 0``) they are recorded as failed and a re-run completes them.
    """
    import dask
    from dask.distributed import Client, LocalCluster

    cfg = _cfg(tmp_path, SMALL.replace("iterations = 2", "iterations = 1"))
    out = tmp_path / "k"
    killed: dict[str, Any] = {}
    with dask.config.set({"distributed.scheduler.allowed-failures": allowed_failures}):
        with (
            LocalCluster(
                n_workers=2, threads_per_worker=1, processes=True, dashboard_address=":0"
            ) as cluster,
            Client(cluster) as client,
        ):
            pids = sorted(client.run(os.getpid).values())

            def progress(done: int, total: int, message: str) -> None:
                if done == 1 and not killed:  # the first result is in: kill a busy worker
                    first = next((out / "results").glob("*.json"))
                    killed.update(pid=pids[0], first=first, saved=first.read_text())
                    os.kill(pids[0], signal.SIGKILL)

            res = run_study(cfg, out, progress=progress, plots=False, client=client)
    assert killed and killed["first"].read_text() == killed["saved"]  # kept as it was
    files = sorted(p.stem for p in (out / "results").glob("*.json"))
    assert files == [f"least-squares-act-{i:03d}" for i in range(4)]  # none lost
    if allowed_failures:
        assert res["failed"] == 0
    else:
        assert res["failed"] >= 1
        assert all("KilledWorker" in f["error"] for f in res["failures"])
        res = run_study(cfg, out, executor="local", plots=False)  # the re-run completes them
        assert res["failed"] == 0
    results = [json.loads((out / "results" / f"{k}.json").read_text()) for k in files]
    assert all(r["error"] is None and len(r["iterations"]) == 1 for r in results)
    assert res["summary"]["least-squares"]["act"]["1"]["runs"] == 4


def test_unknown_study_key_is_named(tmp_path):
    with pytest.raises(errors.ConfigError, match="unknown key 'gird' in \\[study\\]"):
        _cfg(tmp_path, SMALL.replace("grid =", "gird ="))
