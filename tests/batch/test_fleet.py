"""``sysid tune-fleet``: many gyros on a local dask cluster, one failing, the others tuned."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from sysid_core.batch.fleet import load_fleet, run_fleet
from sysid_core.cli import main
from sysid_core.errors import ConfigError, RunFolderError
from sysid_core.plugin.registry import get_registry

BASE = """
[device]
name = "cloverleaf"

[tuning]
criterion = "degenerate"
electrodes = ["B1", "B2"]
start_bias = [0.0, 0.0, 0.0]
max_iterations = 3

[experiment]
band_hz = [4385.0, 4445.0]
"""

# A bench that never answers: the exchange device gives up after 1 s.
SILENT = """
[device]
name = "exchange"
dir = "{dir}"
electrodes = ["B1", "B2", "B3"]
bias_limits = [-10.0, 10.0]
structure_potential = 15.58
band_hz = [4385.0, 4445.0]
wait_s = 1.0
poll_s = 0.05

[tuning]
criterion = "degenerate"
electrodes = ["B1", "B2"]
start_bias = [0.0, 0.0, 0.0]
"""


def fleet_file(tmp_path: Path) -> Path:
    (tmp_path / "base.toml").write_text(BASE)
    (tmp_path / "silent.toml").write_text(SILENT.format(dir=tmp_path / "silent-bench"))
    path = tmp_path / "fleet.toml"
    path.write_text(
        'config = "base.toml"\n'
        "seeds = [1, 2]\n"
        '[[gyro]]\nname = "sn-7"\ndevice = { seed = 7, noise = 2e-4 }\n'
        '[[gyro]]\nname = "silent"\nconfig = "silent.toml"\n'
    )
    return path


def true_answer(seed: int) -> np.ndarray:
    """The bias that makes the simulated cloverleaf's TRUE modes degenerate (B1, B2)."""
    dev: Any = get_registry().device("cloverleaf", seed=seed)
    return np.asarray(dev.truth.degenerate_bias((0, 1), bias=np.zeros(3)), dtype=float)[:2]


@pytest.fixture(scope="module")
def fleet_run(tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, list[dict[str, Any]]]:
    tmp = tmp_path_factory.mktemp("fleet")
    out = tmp / "out"
    lines: list[str] = []
    results = run_fleet(
        fleet_file(tmp), out, workers=2, plots=False, progress=lambda d, t, m: lines.append(m)
    )
    return out, results


def test_a_failing_gyro_does_not_stop_the_others(
    fleet_run: tuple[Path, list[dict[str, Any]]],
) -> None:
    out, results = fleet_run
    assert [r["name"] for r in results] == ["seed-1", "seed-2", "sn-7", "silent"]
    failed = results[3]
    assert failed["error"].startswith("DeviceError") and "no answer" in failed["error"]
    for r, seed in zip(results[:3], (1, 2, 7), strict=True):
        assert r["error"] is None and r["converged"], r
        assert (out / r["name"] / "summary.json").exists()
        # each gyro tuned to its own TRUE answer, within the acceptance's bias scale
        assert np.max(np.abs(np.asarray(r["bias"][:2]) - true_answer(seed))) < 0.02, r["bias"]
        assert r["split_hz"] <= 0.010
        assert r["points"] > 0
    table = (out / "fleet.md").read_text()
    assert "FAILED" in table and table.count("| converged |") == 3
    saved = json.loads((out / "fleet.json").read_text())["gyros"]
    assert [g["name"] for g in saved] == ["seed-1", "seed-2", "sn-7", "silent"]


def test_resume_keeps_the_converged_gyros(
    fleet_run: tuple[Path, list[dict[str, Any]]], tmp_path: Path
) -> None:
    out, first = fleet_run
    fleet = out.parent / "fleet.toml"
    with pytest.raises(RunFolderError, match="--resume"):
        run_fleet(fleet, out, workers=1, plots=False)
    again = run_fleet(fleet, out, resume=True, workers=1, plots=False)
    for before, after in zip(first[:3], again[:3], strict=True):
        assert after["bias"] == before["bias"] and after["time_s"] == 0.0  # kept, not re-run
    assert again[3]["error"]


def test_cli_reports_one_line_and_fails(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    fleet = fleet_file(tmp_path)
    code = main(
        [
            "tune-fleet",
            str(fleet),
            "--out",
            str(tmp_path / "o"),
            "--json",
            "--workers",
            "2",
            "--no-plots",
        ]
    )
    captured = capsys.readouterr()
    assert code == 1
    line = json.loads(captured.out.strip().splitlines()[-1])
    assert line["converged"] == 3 and line["failed"] == 1
    assert captured.err.strip().splitlines() == [
        "sysid: error: 1 of 4 gyro(s) did not converge or failed (silent); see "
        f"{tmp_path / 'o'}/fleet.md, continue with --resume"
    ]


def test_bad_fleet_files_are_refused(tmp_path: Path) -> None:
    (tmp_path / "base.toml").write_text(BASE)
    bad = tmp_path / "bad.toml"
    bad.write_text('config = "base.toml"\n[[gyro]]\nname = "a b"\n')
    with pytest.raises(ConfigError, match=r"gyro\.0\.name"):
        load_fleet(bad)
    bad.write_text('config = "base.toml"\nseeds = [1, 1]\n')
    with pytest.raises(ConfigError, match="seed-1 appear more than once"):
        load_fleet(bad)
    bad.write_text('config = "base.toml"\n')
    with pytest.raises(ConfigError, match="no gyros"):
        load_fleet(bad)
    # a gyro with a bad option is reported as its own failure, not the fleet's
    bad.write_text(
        'config = "base.toml"\nseeds = [1]\n[[gyro]]\nname = "x"\ndevice = { nose = 1 }\n'
    )
    names, configs = load_fleet(bad)
    assert names == ["seed-1", "x"]
    assert isinstance(configs[0], dict) and "nose" in str(configs[1])
