"""examples/population_plot.py: a population's true end splits and bench times in one figure."""

from __future__ import annotations

import importlib.util
import json
import sys
from pathlib import Path
from typing import Any

import pytest

ROOT = Path(__file__).resolve().parents[2]


def _script() -> Any:
    spec = importlib.util.spec_from_file_location(
        "population_plot", ROOT / "examples" / "population_plot.py"
    )
    assert spec is not None and spec.loader is not None
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def _record(seed: int, khz: float, split_mhz: float, converged: bool) -> dict[str, object]:
    return {
        "seed": seed,
        "frequency_hz": khz * 1e3,
        "true_end_split_hz": split_mhz * 1e-3,
        "measured_split_hz": split_mhz * 1e-3,
        "converged": converged,
        "points": 300,
        "bench_time_s": 3600.0 / khz,
    }


def test_the_figure_counts_the_runs_within_the_acceptance(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    """Two populations, one run with an error: 3 of 5 within 2 mHz, the figure written, and the
    command line says so in one line; a folder without runs.jsonl is refused in one line."""
    script = _script()
    first = tmp_path / "lab-101"
    first.mkdir()
    records = [
        _record(101, 1.5, 17.0, False),
        _record(102, 20.0, 0.8, True),
        {"seed": 103, "error": "x"},
    ]
    (first / "runs.jsonl").write_text("".join(json.dumps(r) + "\n" for r in records))
    second = tmp_path / "lab-301.jsonl"
    second.write_text(
        json.dumps(_record(301, 8.0, 1.9, False))
        + "\n"
        + json.dumps(_record(302, 3.0, 0.4, True))
        + "\n"
    )
    out = tmp_path / "pop.png"
    within, total = script.plot_population(
        {"101": script.read_runs(first), "301": script.read_runs(second)}, out
    )
    assert (within, total) == (3, 5)
    assert out.stat().st_size > 10_000  # a drawn figure, not an empty canvas
    monkeypatch.setattr(
        sys, "argv", ["population_plot.py", str(first), "--out", str(out), "--acceptance", "20"]
    )
    script.main()
    assert capsys.readouterr().out.strip().startswith("2 of 3 runs end within 20 mHz")
    monkeypatch.setattr(sys, "argv", ["population_plot.py", str(tmp_path / "none")])
    with pytest.raises(SystemExit, match=r"no runs\.jsonl"):
        script.main()
