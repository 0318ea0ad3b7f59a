"""Small versions of the studies in docs/paper-reproduction.md and docs/random-gyro-study.md,
from their own example files (slow: run with ``-m slow``)."""

from __future__ import annotations

import tomllib
from pathlib import Path

import pytest
from truths import write_toml

from sysid_core.batch.study.runner import load_study_config, run_study

ROOT = Path(__file__).resolve().parents[2]


def _small(tmp_path: Path, name: str, study: dict[str, object]) -> Path:
    """The example study ``name`` with ``study`` replacing some of its ``[study]`` keys."""
    data = tomllib.loads((ROOT / "examples" / name).read_text())
    data["study"].update(study)
    return write_toml(tmp_path / name.replace("/", "-"), data)


@pytest.mark.slow
def test_small_cloverleaf_study_with_the_defaults(tmp_path: Path) -> None:
    """Four far starts, both structures: the second iteration is under 1 mHz everywhere and
    the first iteration's regions cover the true degenerate bias."""
    cfg = load_study_config(
        _small(tmp_path, "study-default.toml", {"grid": [-9, 9], "structures": ["act", "sen"]})
    )
    full = run_study(cfg, tmp_path / "out", executor="local", plots=False)
    assert full["failed"] == 0
    for model in ("act", "sen"):
        per_it = full["summary"]["least-squares"][model]
        assert per_it["2"]["split_percentiles_hz"]["100"] < 0.001
        assert per_it["1"]["bias_coverage"] >= 0.75  # 4 runs: at most one miss


@pytest.mark.slow
@pytest.mark.parametrize("name", ["study-random-degenerate.toml", "study-random-min-max.toml"])
def test_small_random_gyro_studies(tmp_path: Path, name: str) -> None:
    """Six random gyros: every run completes and the third iteration is better than the first
    for every gyro."""
    cfg = load_study_config(_small(tmp_path, name, {"gyros": 6}))
    full = run_study(cfg, tmp_path / "out", executor="local", plots=False)
    assert full["failed"] == 0
    per_it = full["summary"]["least-squares"]["auto"]
    assert per_it["3"]["runs"] == 6
    assert per_it["3"]["split_percentiles_hz"]["100"] < per_it["1"]["split_percentiles_hz"]["10"]


@pytest.mark.slow
def test_small_bench_time_comparison(tmp_path: Path) -> None:
    """Four far starts with the full and the lean protocol (docs/bench-time.md): the lean one
    reaches 1 mHz on every start with fewer points."""
    import sys

    sys.path.insert(0, str(ROOT / "benchmarks"))
    import bench_time

    folders = []
    for name in ("full", "lean"):
        cfg = load_study_config(_small(tmp_path, f"bench-time/{name}.toml", {"grid": [-9, 9]}))
        out = tmp_path / name
        assert run_study(cfg, out, executor="local", plots=False)["failed"] == 0
        folders.append(out)
    rows, _ = bench_time.summarize(folders, "full", 1e-3)
    full, lean = rows
    assert lean["reached"] == lean["runs"] == 4 and lean["worse_than_reference"] == 0
    assert lean["max_points"] < full["median_points"]
