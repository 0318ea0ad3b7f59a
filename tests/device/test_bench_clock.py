"""The simulated bench's clock and drifts (``[device.bench]``), and time stamps through the toolkit.

Truths: the frozen device (no bench) and the analytic effect of each drift: a temperature ramp
moves both modes by ``tempco · ΔT · f``, charging is a bias offset, gain wander a per-sweep
complex factor. Time stamps (``time_s``) must survive the run folder and ``--resume``, response
files (CSV, MATLAB, netCDF), ``sysid import``/``export`` and the exchange device.
"""

from __future__ import annotations

import json
import shutil
from pathlib import Path

import numpy as np
import pytest
from sysid_cloverleaf import CloverleafGyro

from sysid_core import tune
from sysid_core.cli import main
from sysid_core.data import concat_experiments, load_dataset, point_times
from sysid_core.errors import ConfigError, FileFormatError
from sysid_core.formats.manifest import export_dataset, load_manifest
from sysid_core.formats.sweepfiles import read_sweep, write_sweep

F = np.linspace(4420.0, 4435.0, 31)
ZERO = [0.0, 0.0, 0.0]
MAIN_JOB = {
    "tuning": {"criterion": "degenerate", "electrodes": ["B1", "B2"], "start_bias": ZERO},
}


def gyro(**bench: object) -> CloverleafGyro:
    return CloverleafGyro(seed=1, bench={"clock": True, **bench})


def test_a_clock_without_drift_measures_what_the_frozen_bench_measures() -> None:
    frozen, timed = CloverleafGyro(seed=1), gyro()
    a, b = frozen.measure(ZERO, F), timed.measure(ZERO, F)
    assert "time_s" not in a.coords and frozen.time_s is None
    np.testing.assert_array_equal(a.values, b.values)
    # settling (3 τ, τ = Q/(π f) of the slowest mode) then one dwell (5 Q/ω) per point
    _, damped, q = frozen.true_modal_analysis(ZERO)
    tau = np.max(q / (np.pi * damped))
    assert timed.settle_s == pytest.approx(3 * tau) and timed.dwell_s == pytest.approx(2.5 * tau)
    t = b["time_s"].values
    np.testing.assert_allclose(t, timed.settle_s + timed.dwell_s * np.arange(1, F.size + 1))
    timed.measure(ZERO, F)  # the same bias: no settling
    assert timed.time_s == pytest.approx(t[-1] + F.size * timed.dwell_s)
    timed.measure([0.5, 0.0, 0.0], F)  # a new bias: settling again
    assert timed.time_s == pytest.approx(t[-1] + (2 * F.size) * timed.dwell_s + timed.settle_s)


def test_a_temperature_ramp_moves_both_modes_by_the_tempco() -> None:
    frozen, warm = CloverleafGyro(seed=1), gyro(temperature_ramp_k_per_h=1.0)
    for _ in range(4):
        warm.measure(ZERO, F)
    delta_t = warm.time_s / 3600.0
    expected = frozen.true_modal_frequencies_hz(ZERO) * (1 - 30e-6 * delta_t)
    np.testing.assert_allclose(warm.true_modal_frequencies_hz(ZERO), expected, rtol=1e-9)
    # the split moves with the differential coefficient: 2 ppm/K of 4.4 kHz per kelvin
    split = gyro(temperature_ramp_k_per_h=1.0, split_tempco_ppm_per_k=2.0)
    for _ in range(4):
        split.measure(ZERO, F)
    moved = np.diff(split.true_modal_frequencies_hz(ZERO))[0] - frozen.true_split_hz(ZERO)
    assert abs(moved) == pytest.approx(2e-6 * 4426 * split.time_s / 3600, rel=0.35)


def test_a_replica_gives_the_gyro_at_an_earlier_time_stamp() -> None:
    """The truth at a run's time stamp from a replica of its device (the same seeds), asked in
    order: with a ramp and charging (functions of the clock) it is the gyro the run saw then,
    to rounding; the split moved by charging in between."""
    drifts = {"temperature_ramp_k_per_h": 1.5, "charging_v_per_h": 0.5}
    run, replica = gyro(**drifts), gyro(**drifts)
    bias = [2.0, 4.4, 0.0]
    seen = []
    for _ in range(3):
        run.measure(bias, F)
        seen.append((run.time_s, run.true_split_hz(bias)))
    for t, split in seen:
        assert replica.true_split_hz(bias, at_s=t) == pytest.approx(split, rel=1e-9, abs=1e-12)
    assert abs(seen[-1][1] - seen[0][1]) > 1e-4  # the electrodes charged between the sweeps


def test_a_later_start_meets_the_same_drifts_later() -> None:
    """``start_s``: the clock starts there, the ramp and the charging as if they had run that
    long; the gyro is the one a bench started at zero has at that time."""
    drifts = {"temperature_ramp_k_per_h": 1.0, "charging_v_per_h": 0.5}
    late, early = gyro(start_s=600.0, **drifts), gyro(**drifts)
    t = late.measure(ZERO, F)["time_s"].values
    np.testing.assert_allclose(t, 600.0 + late.settle_s + late.dwell_s * np.arange(1, F.size + 1))
    np.testing.assert_allclose(
        late.true_modal_frequencies_hz(ZERO),
        early.true_modal_frequencies_hz(ZERO, at_s=late.time_s),
        rtol=1e-12,
    )
    # the ramp alone: both modes moved by -30 ppm/K of the kelvins since zero, not since start
    warm = gyro(start_s=600.0, temperature_ramp_k_per_h=1.0)
    warm.measure(ZERO, F)
    expected = CloverleafGyro(seed=1).true_modal_frequencies_hz(ZERO)
    expected = expected * (1 - 30e-6 * warm.time_s / 3600.0)
    np.testing.assert_allclose(warm.true_modal_frequencies_hz(ZERO), expected, rtol=1e-9)
    assert warm.time_s > 600.0


def test_charging_is_a_bias_offset_and_gain_wander_a_factor_per_sweep() -> None:
    charged = CloverleafGyro(seed=1, dac_bits=0, bench={"clock": True, "charging_v_per_h": 3.6})
    frozen = CloverleafGyro(seed=1, dac_bits=0)
    for _ in range(3):
        charged.measure(ZERO, F)
    offset = 3.6 * charged.time_s / 3600.0  # volts on every electrode by now
    np.testing.assert_allclose(
        charged.true_modal_frequencies_hz(ZERO),
        frozen.true_modal_frequencies_hz([offset] * 3),
        rtol=1e-12,
    )
    wander = CloverleafGyro(
        seed=1, noise=0.0, bench={"clock": True, "gain_wander": 0.01, "seed": 3}
    )
    still = CloverleafGyro(seed=1, noise=0.0)
    ratios = [
        (wander.measure(ZERO, F).values / still.measure(ZERO, F).values).ravel() for _ in range(200)
    ]
    per_sweep = np.array([r.mean() for r in ratios])
    assert max(np.ptp(np.abs(r)) for r in ratios) < 1e-9  # one factor per sweep
    assert np.std(np.abs(per_sweep)) == pytest.approx(0.01, rel=0.2)


@pytest.mark.parametrize(
    ("bench", "message"),
    [
        ({"clok": True}, "unknown key 'clok'"),
        ({"temperature_ramp_k_per_h": 1.0}, "no clock"),
        ({"clock": True, "temperature_walk_k_per_sqrt_h": -1.0}, "must be >= 0"),
        ({"clock": "yes"}, "true or false"),
        ({"clock": True, "charging_v_per_h": [0.1, 0.2]}, "one per electrode"),
        ({"start_s": 600.0}, "sets start_s but no clock"),
        ({"clock": True, "start_s": -1.0}, "start_s .* must be >= 0"),
        ("fast", "table of bench settings"),
    ],
)
def test_bad_bench_settings_name_the_key(bench: object, message: str) -> None:
    with pytest.raises(ConfigError, match=message):
        CloverleafGyro(seed=1, bench=bench)  # type: ignore[arg-type]


def test_a_run_on_a_clock_tunes_as_before_and_reports_the_clock(tmp_path: Path) -> None:
    """Drift-free, the clock changes nothing but the time stamps and the bench time, with the
    same first look at the band (``probe = "auto"`` probes only the device with a clock).
    (With the probe this run measures a fine verification window, which a clock widens by how
    far the modes may have moved since the coarse one: 22 points instead of 18.)"""
    job = {**MAIN_JOB, "experiment": {"probe": False}}
    frozen = tune({"device": {"name": "cloverleaf", "seed": 1}, **job}, tmp_path / "a")
    timed = tune(
        {"device": {"name": "cloverleaf", "seed": 1, "bench": {"clock": True}}, **job},
        tmp_path / "b",
        plots=False,
    )
    assert timed.bias == frozen.bias and timed.split_hz == pytest.approx(frozen.split_hz)
    assert frozen.bench_time_source == "estimate" and timed.bench_time_source == "clock"
    stamps = [point_times(load_dataset(p), 0) for p in sorted((tmp_path / "b").rglob("*.nc"))]
    stamps = [t for t in stamps if t is not None]
    assert len(stamps) >= timed.experiments
    span = max(t.max() for t in stamps) - min(t.min() for t in stamps)
    # the span of the stamps, plus the settling and the acquisition before the first one
    gyro = CloverleafGyro(seed=1, bench={"clock": True})
    assert timed.bench_time_s == pytest.approx(span + gyro.settle_s + gyro.dwell_s)
    # more than points × dwell: every bias change costs its settling too
    assert timed.bench_time_s > 0.9 * timed.points * timed.dwell_s
    summary = json.loads((tmp_path / "b" / "summary.json").read_text())
    assert summary["bench_time_source"] == "clock"


def test_time_stamps_survive_resume(tmp_path: Path) -> None:
    config = {"device": {"name": "cloverleaf", "seed": 1, "bench": {"clock": True}}, **MAIN_JOB}
    first = tune(config, tmp_path / "run", plots=False)
    again_dir = tmp_path / "again"
    shutil.copytree(tmp_path / "run", again_dir)
    (again_dir / "summary.json").unlink()
    again = tune(config, again_dir, resume=True, plots=False)
    assert again.bench_time_s == pytest.approx(first.bench_time_s)
    assert again.bench_time_source == "clock"


@pytest.mark.parametrize("suffix", [".csv", ".mat", ".nc"])
def test_time_stamps_survive_response_files(tmp_path: Path, suffix: str) -> None:
    sweep = gyro().measure(ZERO, F)
    path = write_sweep(tmp_path / f"s{suffix}", sweep)
    back = read_sweep(path)
    np.testing.assert_array_equal(back["time_s"].values, sweep["time_s"].values)
    np.testing.assert_array_equal(back.values, sweep.values)
    if suffix == ".csv":
        text = path.read_text().splitlines()
        assert text[0] == "# response_units: V/V" and text[1].endswith(",time_s")
        bad = tmp_path / "bad.csv"
        bad.write_text("\n".join([*text[:2], text[2].rsplit(",", 1)[0] + ",nan", *text[3:]]))
        with pytest.raises(FileFormatError, match=r"line 3: time_s nan"):
            read_sweep(bad)


@pytest.mark.parametrize("fmt", ["csv", "mat", "nc"])
def test_time_stamps_survive_import_and_export(tmp_path: Path, fmt: str) -> None:
    config = {"device": {"name": "cloverleaf", "seed": 1, "bench": {"clock": True}}, **MAIN_JOB}
    config["tuning"] = {**MAIN_JOB["tuning"], "max_iterations": 1}
    tune(config, tmp_path / "run", plots=False)
    parts = [load_dataset(p) for p in sorted((tmp_path / "run" / "iter01").glob("exp*.nc"))]
    ds = concat_experiments(parts).sel(electrode=["B1", "B2"])
    manifest = export_dataset(ds, tmp_path / "out", fmt)
    back = load_manifest(manifest)
    assert main(["import", str(manifest), "--out", str(tmp_path / "d.nc")]) == 0
    imported = load_dataset(tmp_path / "d.nc")
    for k in range(ds.sizes["experiment"]):
        assert point_times(ds, k) is not None
        np.testing.assert_array_equal(point_times(back, k), point_times(ds, k))
        np.testing.assert_array_equal(point_times(imported, k), point_times(ds, k))
