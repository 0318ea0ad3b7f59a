"""examples/clock_population.py: the clocked study's options reach the runs they make."""

from __future__ import annotations

import importlib.util
import json
import sys
from pathlib import Path
from typing import Any

import pytest

ROOT = Path(__file__).resolve().parents[2]


def _script(monkeypatch: pytest.MonkeyPatch) -> Any:
    spec = importlib.util.spec_from_file_location(
        "clock_population", ROOT / "examples" / "clock_population.py"
    )
    assert spec is not None and spec.loader is not None
    module = importlib.util.module_from_spec(spec)
    monkeypatch.setitem(sys.modules, "clock_population", module)  # for its dataclasses
    spec.loader.exec_module(module)
    return module


def test_iterations_cap_every_run_of_the_population(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    """``--iterations 1``: a random gyro far from degenerate stops after one iteration.

    Gyro 205 with 8 tones starts about 0.3 Hz from degenerate at its first answer, so one
    iteration cannot converge: the run's own count of iterations is the cap, not the default 4.
    """
    script = _script(monkeypatch)
    out = tmp_path / "pop"
    argv = ["clock_population.py", "--gyro", "random", "--tones", "8", "--seeds", "205"]
    monkeypatch.setattr(sys, "argv", [*argv, "--iterations", "1", "--out", str(out)])
    script.main()
    (record,) = [json.loads(line) for line in (out / "runs.jsonl").read_text().splitlines()]
    assert "error" not in record
    assert record["iterations"] == 1
    config = json.loads((out / "run205" / "config.json").read_text())["config"]
    assert config["tuning"]["max_iterations"] == 1
    assert config["tuning"]["pair"] is True  # the default: the run may choose a pair
    printed = capsys.readouterr()
    assert "| random, 8 tone(s) |" in printed.out
    # where the clock went, in the gyro's own dwells: the purposes add up to the counted clock
    assert record["dwell_s"] > 0
    purposes = sum(record["bench_time_by_purpose_s"].values())
    parts = sum(record["bench_time_split_s"].values())
    assert purposes == pytest.approx(parts, rel=1e-9)
    assert 0 < purposes <= record["clock_s"]
    assert "dwells (bench clock / dwell_s), medians:" in printed.out
    assert "iteration 1:" not in printed.err  # the runs' own lines only with --verbose


def test_every_electrode_turns_the_pair_off_in_every_run(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    script = _script(monkeypatch)
    out = tmp_path / "pop"
    argv = ["clock_population.py", "--gyro", "random", "--tones", "8", "--seeds", "205"]
    flags = ["--iterations", "1", "--electrodes", "3", "--every-electrode", "--out", str(out)]
    monkeypatch.setattr(sys, "argv", [*argv, *flags])
    script.main()
    config = json.loads((out / "run205" / "config.json").read_text())["config"]
    assert config["tuning"]["pair"] is False


def test_verbose_prints_every_run_s_progress(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    script = _script(monkeypatch)
    out = tmp_path / "pop"
    argv = ["clock_population.py", "--gyro", "random", "--tones", "8", "--seeds", "205"]
    monkeypatch.setattr(sys, "argv", [*argv, "--iterations", "1", "--verbose", "--out", str(out)])
    script.main()
    assert "iteration 1: fitting" in capsys.readouterr().err


@pytest.mark.parametrize("value", ["0", "-2"])
def test_iterations_below_one_are_refused_with_the_value(
    value: str, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str], tmp_path: Path
) -> None:
    script = _script(monkeypatch)
    out = tmp_path / "never"
    monkeypatch.setattr(
        sys, "argv", ["clock_population.py", "--iterations", value, "--out", str(out)]
    )
    with pytest.raises(SystemExit) as exc:
        script.main()
    assert exc.value.code == 2
    assert f"--iterations must be at least 1, got {value}" in capsys.readouterr().err
    assert not out.exists()


def test_from_a_model_a_rise_inside_the_windows_noise_keeps_the_model(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    """Gyro 215 (22 kHz, 8 tones) from a previous model sits at its bench's floor: its windows
    measure the split to about ±3 mHz against an acceptance of 1 mHz. Its verified split rises
    inside that noise, which gives no rate: the run says so and verifies the model's next answer
    instead of measuring the local design (the code before measured it after such a rise: 3.52 to
    3.81 mHz, interval 0-10 mHz, in the study's run of four iterations)."""
    script = _script(monkeypatch)
    out = tmp_path / "pop"
    argv = ["clock_population.py", "--gyro", "random", "--tones", "8", "--seeds", "215"]
    argv += ["--from-model", "--iterations", "6", "--verbose", "--out", str(out)]
    monkeypatch.setattr(sys, "argv", argv)
    script.main()
    (record,) = [json.loads(line) for line in (out / "runs.jsonl").read_text().splitlines()]
    assert "error" not in record and record["iterations"] == 6
    err = capsys.readouterr().err
    assert "no rate to read, no local design; verifying the next answer" in err
    assert "measuring the local design" not in err
    # no design: each iteration's new biases are at most its last verification's (a design
    # around the bias would add four)
    summary = json.loads((out / "run215" / "summary.json").read_text())
    assert max(len(h["experiments"]) for h in summary["history"]) == 1
    assert record["true_end_split_hz"] < 0.002
