"""``benchmarks/bench_time.py``: points to a target split, per run and per protocol."""

from __future__ import annotations

import json
import sys
from pathlib import Path
from typing import Any

import pytest

from sysid_core.batch.study.runner import load_study_config, plan_study

ROOT = Path(__file__).resolve().parents[2]
sys.path.insert(0, str(ROOT / "benchmarks"))

import bench_time  # noqa: E402


def result(index: int, splits_mhz: list[float], points: list[int], dwell: float) -> dict[str, Any]:
    return {
        "key": f"x-{index:03d}",
        "index": index,
        "seed": 0,
        "start": [0.0, float(index)],
        "error": None,
        "points": points[-1],
        "bench_time_s": points[-1] * dwell,
        "iterations": [
            {"iteration": k + 1, "true_split_hz": s * 1e-3, "points": p}
            for k, (s, p) in enumerate(zip(splits_mhz, points, strict=True))
        ],
    }


def study(folder: Path, results: list[dict[str, Any]]) -> Path:
    (folder / "results").mkdir(parents=True)
    for r in results:
        (folder / "results" / f"{r['key']}.json").write_text(json.dumps(r))
    return folder


def test_points_to_the_target_and_the_comparison(tmp_path: Path) -> None:
    ref = study(
        tmp_path / "ref",
        [
            result(0, [5.0, 0.5, 0.1], [400, 800, 1200], 10.0),
            result(1, [5.0, 2.0], [400, 800], 10.0),
        ],
    )
    new = study(
        tmp_path / "new",
        [
            result(0, [0.8, 0.1], [150, 170], 10.0),
            result(1, [3.0, 1.5, 0.9], [150, 900, 1000], 10.0),
        ],
    )
    assert (
        bench_time.to_target(json.loads((new / "results" / "x-001.json").read_text()), 1e-3)[
            "points"
        ]
        == 1000
    )
    rows, _ = bench_time.summarize([ref, new], "ref", 1e-3)
    r, n = rows
    assert (r["reached"], n["reached"]) == (1, 2)
    # start 0: 150 against 800; start 1: 1000 against all 800 of a run that never got there
    assert (n["median_points"], n["max_points"]) == (575.0, 1000.0)
    assert n["worse_than_reference"] == 1
    assert n["median_bench_time_s"] == pytest.approx(5750.0)
    table = bench_time.markdown(rows, "ref", 1e-3)
    assert "| new | 2/2 | 575 / 1000 |" in table and "× ref" in table


@pytest.mark.parametrize("path", sorted((ROOT / "examples" / "bench-time").glob("*.toml")))
def test_the_bench_time_studies_plan(path: Path, tmp_path: Path) -> None:
    """Every study of docs/bench-time.md is valid (checked as `sysid study` checks it)."""
    plan = plan_study(load_study_config(path), tmp_path / "out")
    assert len(plan.specs) in (49, 100)
