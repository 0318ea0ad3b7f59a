"""examples/clock_plot.py: every clocked run's time to 1 mHz, one row per population."""

from __future__ import annotations

import importlib.util
import json
import math
import sys
from pathlib import Path
from typing import Any

import pytest

ROOT = Path(__file__).resolve().parents[2]


def _script() -> Any:
    sys.path.insert(0, str(ROOT / "examples"))  # clock_plot reads with population_plot
    spec = importlib.util.spec_from_file_location("clock_plot", ROOT / "examples" / "clock_plot.py")
    assert spec is not None and spec.loader is not None
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def _write(path: Path, minutes: list[float | None]) -> Path:
    path.mkdir()
    lines = [
        json.dumps({"seed": k, "time_to_target_s": None if m is None else 60.0 * m})
        for k, m in enumerate(minutes)
    ]
    (path / "runs.jsonl").write_text("\n".join([*lines, json.dumps({"seed": 99, "error": "x"})]))
    return path


def test_the_medians_are_the_tables_and_never_counts_as_infinite(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    """The lower median of an even count, as clock_population's table; a run that never got
    there is an infinite time (a row whose median run never got there says so); a run with an
    error is left out; the figure is written and the command line says the medians."""
    script = _script()
    one = _write(tmp_path / "one", [4.0, 6.0, 30.0, None])
    two = _write(tmp_path / "two", [3.0, None, None])
    out = tmp_path / "clock.png"
    medians = script.plot_clock(
        {"one": script.read_runs(one), "two": script.read_runs(two)}, out, [5.0]
    )
    assert medians[0] == pytest.approx(6.0) and math.isinf(medians[1])
    assert out.stat().st_size > 10_000
    monkeypatch.setattr(sys, "argv", ["clock_plot.py", str(one), str(two), "--out", str(out)])
    script.main()
    assert "one 6.0, two never" in capsys.readouterr().out
    monkeypatch.setattr(sys, "argv", ["clock_plot.py", str(tmp_path / "none")])
    with pytest.raises(SystemExit, match=r"no runs\.jsonl"):
        script.main()
