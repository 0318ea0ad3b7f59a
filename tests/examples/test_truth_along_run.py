"""examples/truth_along_run.py: a replica of a population run's device gives the run's truth."""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np
import pytest

ROOT = Path(__file__).resolve().parents[2]


def test_a_replica_reads_the_truth_the_run_ended_with(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """Random gyro 110 (23.7 kHz) at a good lab's drift, 3 iterations: each verified window's
    measured split is within a few mHz of the replica's true split at its middle, and the last
    one's true split is the true split the run ended with (the good lab's walk, 0.05 K/√h,
    moves it by far less than 0.3 mHz in the seconds between)."""
    monkeypatch.syspath_prepend(str(ROOT / "examples"))
    import drift_population
    import truth_along_run

    record = drift_population.one(110, "good", "track", tmp_path, iterations=3)
    found = truth_along_run.rows(tmp_path / "gyro110", 110, "good")
    verified = [r for r in found if r["verification"] == "verified"]
    assert verified and found[-1] is verified[-1]
    for r in verified:
        assert abs(r["measured_mhz"] - r["true_mhz"]) < 3.0
    assert verified[-1]["true_mhz"] == pytest.approx(record["true_end_split_hz"] * 1e3, abs=0.3)
    assert found[0]["true_earlier_mhz"] is None and verified[-1]["true_earlier_mhz"] is not None
    # the fit's slopes of the split in B1 and B2 at the last answer are the truth's, and the
    # truth's are measured on the replica, not copied from the fit
    last = truth_along_run.slopes(tmp_path / "gyro110", 110, "good")[-1]
    size = np.linalg.norm(last["true"])
    assert np.linalg.norm(last["model"] - last["true"]) < 0.2 * size
    assert not np.array_equal(last["model"], last["true"])
    # --coverage: every verdict's forecast bound beside the replica's truth at its window's end;
    # the last is the run's converged end, its truth the one the run ended with
    verdicts = truth_along_run.coverage(tmp_path, "good")
    assert [v["iteration"] for v in verdicts] == [r["iteration"] for r in verified]
    end = verdicts[-1]
    assert end["converged"] is record["converged"]
    assert end["true_mhz"] == pytest.approx(record["true_end_split_hz"] * 1e3, abs=0.3)
    assert end["limit_mhz"] == 2.0 and (end["bound_mhz"] <= 2.0) is end["converged"]
    table = truth_along_run.coverage_table(verdicts)
    assert table[0].startswith("| bound (mHz) |") and any(
        r.startswith("| 0-1 | 1 |") for r in table
    )
    converged = sum(v["converged"] for v in verdicts)
    assert table[-1].endswith(f"{converged} verdicts converged; 0 with the truth over the limit")
    # the population's progress line says the same end
    line = drift_population.progress(record, 3, 24)
    assert line.startswith("[3/24] gyro 110: 23.7 kHz")
    assert f"{record['true_end_split_hz'] * 1e3:.3g} mHz at the end" in line
    for name in ("drift_population", "truth_along_run", "window_replay"):
        sys.modules.pop(name, None)


def test_a_population_starts_later_into_its_drifts(monkeypatch: pytest.MonkeyPatch) -> None:
    """``--start-min``: the same gyro and drifts, the bench's clock started that much later."""
    monkeypatch.syspath_prepend(str(ROOT / "examples"))
    import drift_population

    late, options = drift_population.make_device(101, "lab", start_min=10.0)
    early, _ = drift_population.make_device(101, "lab")
    assert options["bench"]["start_s"] == 600.0
    bias = [0.0] * len(late.electrodes)
    t = late.measure(bias, [1000.0])["time_s"].values
    assert t[0] > 600.0 and early.measure(bias, [1000.0])["time_s"].values[0] < 600.0
    sys.modules.pop("drift_population", None)
