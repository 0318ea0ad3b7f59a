"""Bench time: every run counts the frequency points it measured and turns them into seconds
with a per-point dwell (the device's figure, the configuration's, or 5 Q/ω from the data)."""

from __future__ import annotations

import json
import re
from pathlib import Path

import numpy as np
import pytest
from sysid_cloverleaf import CloverleafGyro
from truths import cloverleaf_config

from sysid_core.data.schema import load_dataset
from sysid_core.model.modal import modal_analysis
from sysid_core.run.config import parse_config
from sysid_core.run.pipeline import TuningRun
from sysid_core.run.summary import RunSummary

MEASUREMENT = re.compile(r"(exp\d+|verify(-\d+)?)\.nc")


def _config(**experiment: float) -> dict:
    return cloverleaf_config(
        1e-12,
        2,
        experiment={"resolution_hz": 1.0, "verify_resolution_hz": 0.02, **experiment},
    )


def _points_on_disk(out: Path) -> int:
    files = [p for p in out.rglob("*.nc") if MEASUREMENT.fullmatch(p.name)]
    return sum(int(load_dataset(p).sizes["frequency"]) for p in files)


class TimedCloverleaf(CloverleafGyro):
    """An analyzer that says 2 s per point and drives the two inputs one after the other."""

    dwell_s = 2.0
    points_per_frequency = 2


def test_points_and_bench_time_with_the_devices_own_dwell(tmp_path: Path) -> None:
    out = tmp_path / "run"
    summary = TuningRun(
        parse_config(_config()), out, device=TimedCloverleaf(seed=1), plots=False
    ).run()
    on_disk = _points_on_disk(out)
    assert on_disk > 0 and summary.points == 2 * on_disk
    assert summary.dwell_source == "device" and summary.dwell_s == 2.0
    _settling_counted(summary, 2.0 * summary.points)
    saved = json.loads((out / "summary.json").read_text())
    assert saved["points"] == summary.points and saved["bench_time_s"] == summary.bench_time_s


def test_the_configs_dwell_and_the_estimate_from_the_data(tmp_path: Path) -> None:
    configured = TuningRun(parse_config(_config(dwell_s=3.0)), tmp_path / "a", plots=False).run()
    assert configured.dwell_source == "config"
    assert configured.points == _points_on_disk(tmp_path / "a")
    _settling_counted(configured, 3.0 * configured.points)
    estimated = TuningRun(parse_config(_config()), tmp_path / "b", plots=False).run()
    assert estimated.dwell_source == "estimated 5 Q/ω"
    truth = CloverleafGyro(seed=1).truth
    undamped, _, q = modal_analysis(truth.M, truth.C, truth.stiffness([0.0, 0.0, 0.0]))
    expected = 5 * float(np.max(q)) / (2 * np.pi * float(np.min(undamped)))
    assert estimated.dwell_s == pytest.approx(expected, rel=0.2)  # the fitted Q, not the truth
    _settling_counted(estimated, estimated.points * estimated.dwell_s)
    # the settling estimated from the fitted Q: 3 time constants 2Q/ω of the slowest mode
    slowest = float(np.max(q / (np.pi * undamped)))
    assert estimated.settle_s == pytest.approx(3 * slowest, rel=0.2)
    with_settle = TuningRun(
        parse_config(_config(dwell_s=3.0, settle_s=7.0)), tmp_path / "c", plots=False
    ).run()
    assert (with_settle.settle_s, with_settle.settle_source) == (7.0, "config")


def _settling_counted(summary: RunSummary, acquiring_s: float) -> None:
    """The estimate is the acquisitions' time plus a whole number (>= 1) of settlings, the
    settling estimated from the fitted model when neither the device nor the config says."""
    assert summary.settle_source == "estimated 3 τ" and summary.settle_s > 0
    changes = (summary.bench_time_s - acquiring_s) / summary.settle_s
    assert changes >= 1 - 1e-9 and changes == pytest.approx(round(changes), abs=1e-6)
