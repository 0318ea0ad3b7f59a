"""Planning by the clock: tones per acquisition, the bench-time estimate, ``--from-model``.

Truths: the simulated bench's clock (settling ``settle_s`` after each bias change, ``dwell_s``
per acquisition of ``tones`` frequencies, each tone with √k the noise of a single one) and the
cloverleaf's exact degenerate bias; the judge is the TRUE split the run never sees.
"""

from __future__ import annotations

import dataclasses
import shutil
from pathlib import Path

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from sysid_cloverleaf import CloverleafGyro

from sysid_core import load_model, tune
from sysid_core.cli import main
from sysid_core.errors import ConfigError
from sysid_core.measure.lean import ANCHORS, RESOLVED_STEP, ModeGuess, mode_grid
from sysid_core.measure.modegrid import shaped_grid
from sysid_core.measure.sweeps import MIN_POINTS, SweepPlan, fewest_points

PLAN = SweepPlan((4385.0, 4445.0), 0.5, 6.0, 0.05, 1.0, 0.01, 20_000)
GOOD_LAB = {"temperature_ramp_k_per_h": 0.2, "temperature_walk_k_per_sqrt_h": 0.05}
CONFIG = {
    "device": {"name": "cloverleaf", "seed": 3},
    "tuning": {
        "criterion": "degenerate",
        "electrodes": ["B1", "B2"],
        "start_bias": [-4.0, 3.0, 0.0],
        "acceptance_hz": 0.001,
        "max_iterations": 4,
    },
}


def bench_gyro(seed: int, tones: int = 1) -> CloverleafGyro:
    return CloverleafGyro(
        seed=seed, bench={"clock": True, "seed": seed, "tones": tones, **GOOD_LAB}
    )


class Counting:
    """A device that counts its measurements and points (everything else is the gyro's)."""

    def __init__(self, gyro: CloverleafGyro) -> None:
        self.gyro = gyro
        self.sweeps: list[int] = []

    def __getattr__(self, name: str) -> object:
        return getattr(self.gyro, name)

    def measure(self, bias: object, frequencies_hz: np.ndarray) -> object:
        self.sweeps.append(int(np.size(frequencies_hz)))
        return self.gyro.measure(bias, frequencies_hz)


def test_a_four_tone_device_measures_sixteen_points_in_four_acquisitions() -> None:
    one = CloverleafGyro(seed=1, bench={"clock": True})
    four = CloverleafGyro(seed=1, bench={"clock": True, "tones": 4})
    f = np.linspace(4425.0, 4435.0, 16)
    a, b = one.measure([0.0, 0.0, 0.0], f), four.measure([0.0, 0.0, 0.0], f)
    assert four.tones == 4
    # settling, then 4 acquisitions of 4 tones: the stamps step once every 4 points
    expected = four.settle_s + four.dwell_s * (np.arange(16) // 4 + 1)
    np.testing.assert_allclose(b["time_s"].values, expected)
    assert four.time_s == pytest.approx(four.settle_s + 4 * four.dwell_s)
    assert one.time_s == pytest.approx(one.settle_s + 16 * one.dwell_s)
    # the same gyro, each tone with √4 = 2 times the noise of a single tone
    noise_one = a.values - one.noiseless_response([0.0, 0.0, 0.0], f)
    noise_four = b.values - four.noiseless_response([0.0, 0.0, 0.0], f)
    ratio = np.std(noise_four) / np.std(noise_one)
    assert 1.6 < ratio < 2.5  # 64 complex draws each: the ratio of two std within ±20 %


def test_the_tone_count_is_checked() -> None:
    with pytest.raises(ConfigError, match="tones"):
        CloverleafGyro(bench={"clock": True, "tones": 0})


def test_with_tones_a_mode_grid_fills_whole_acquisitions() -> None:
    known = ModeGuess.of([4428.0, 4432.0], [0.08, 0.08])  # the default shape's grids
    one = shaped_grid(known, PLAN)
    eight = shaped_grid(known, dataclasses.replace(PLAN, tones=8))
    assert one.size == 18  # 7 per mode, 4 anchors
    # 18 points would spill 2 into a third acquisition: 2 of the nearer anchors are dropped
    assert eight.size == 16 and set(eight) <= set(one)
    assert one.size - eight.size <= ANCHORS // 2
    # a verification grid around uncertain modes resolves them in one sweep when one more
    # acquisition pays for it; without tones it stays coarse (a fine sweep follows)
    uncertain = ModeGuess.of([4428.0, 4432.0], [0.08, 0.08], 0.08)
    coarse = shaped_grid(uncertain, PLAN, resolve=True)
    fine = shaped_grid(uncertain, dataclasses.replace(PLAN, tones=8), resolve=True)
    near = lambda g: np.diff(g[np.abs(g - 4428.0) < 0.4])  # noqa: E731
    assert near(coarse).max() > RESOLVED_STEP * 0.08
    assert near(fine).max() <= RESOLVED_STEP * 0.08 + 1e-9
    assert -(-fine.size // 8) <= -(-coarse.size // 8) + 1


@settings(max_examples=60, deadline=None)
@given(
    tones=st.integers(1, 16),
    split=st.floats(0.0, 20.0),
    bw=st.floats(0.005, 0.5),
    sigma=st.floats(0.0, 1.0),
    resolve=st.booleans(),
)
def test_a_mode_grid_keeps_its_floor_and_its_band_whatever_the_tones(
    tones: int, split: float, bw: float, sigma: float, resolve: bool
) -> None:
    plan = dataclasses.replace(PLAN, tones=tones)
    guess = ModeGuess.of([4420.0, 4420.0 + split], [bw, bw], sigma)
    chosen = mode_grid(guess, plan, resolve=resolve)  # whatever the shape chosen
    assert chosen.size >= min(MIN_POINTS, fewest_points(tones))
    assert np.all(np.diff(chosen) > 0)
    assert chosen[0] >= PLAN.band_hz[0] and chosen[-1] <= PLAN.band_hz[1]
    grid = shaped_grid(guess, plan, resolve=resolve)
    assert grid.size >= min(MIN_POINTS, fewest_points(tones))
    assert np.all(np.diff(grid) > 0)
    assert grid[0] >= PLAN.band_hz[0] and grid[-1] <= PLAN.band_hz[1]
    one = shaped_grid(guess, PLAN, resolve=resolve)
    # never more acquisitions than the one-tone grid would need, plus one to resolve
    assert -(-grid.size // tones) <= -(-one.size // tones) + 1


def test_the_bench_time_estimate_follows_the_clock(tmp_path: Path) -> None:
    for tones in (1, 8):
        gyro = bench_gyro(3, tones)
        result = tune(CONFIG, tmp_path / f"t{tones}", plots=False, device=gyro)
        summary = result.as_dict()
        assert summary["bench_time_source"] == "clock"
        estimate, clock = summary["bench_time_estimate_s"], summary["bench_time_s"]
        # the clock's span starts at the first point: the estimate counts the first settling
        assert abs(estimate - clock) <= 0.1 * clock
        # one tone: an acquisition per point; eight: several points per acquisition
        if tones == 1:
            assert summary["acquisitions"] == result.points
        else:
            assert summary["acquisitions"] < result.points
        assert summary["settle_s"] == pytest.approx(gyro.settle_s)


def test_from_a_previous_model_no_locating_sweep_and_no_design(tmp_path: Path) -> None:
    first = tune(CONFIG, tmp_path / "first", plots=False, device=bench_gyro(3))
    model = tmp_path / "first" / f"iter{first.iterations:02d}" / "model.nc"
    config = {**CONFIG, "tuning": {**CONFIG["tuning"], "start_bias": [1.0, 5.0, 0.0]}}
    gyro = Counting(bench_gyro(4))
    result = tune(config, tmp_path / "again", plots=False, device=gyro, from_model=model)
    assert result.converged
    assert gyro.gyro.true_split_hz(result.bias) <= 0.001
    # one grid at the start and one verification per iteration: no locating sweep,
    # no design of five biases
    assert max(gyro.sweeps) < 40 and len(gyro.sweeps) == 1 + result.iterations
    # fewer points and less time than a run from nothing, even one that found its bench quiet
    # and took the probe for its locating sweep (54 points and 9.7 minutes against 78 and 14.2)
    assert result.points < first.points and result.bench_time_s < 0.8 * first.bench_time_s
    # the same from the command line, with a wrong model refused in one line
    assert load_model(model).electrodes == ["B1", "B2"]


def test_a_model_that_does_not_help_falls_back_to_the_design(tmp_path: Path) -> None:
    first = tune(CONFIG, tmp_path / "first", plots=False, device=bench_gyro(3))
    model = load_model(tmp_path / "first" / f"iter{first.iterations:02d}" / "model.nc")
    # a model whose bias law is off by a third: its answers do not bring the split down
    wrong = dataclasses.replace(model, Kp=1.33 * np.asarray(model.Kp))
    gyro = Counting(bench_gyro(5))
    result = tune(CONFIG, tmp_path / "wrong", plots=False, device=gyro, from_model=wrong)
    assert gyro.gyro.true_split_hz(result.bias) <= 0.002
    assert len(gyro.sweeps) > 1 + result.iterations  # the local design was measured


class Unsettled(Counting):
    """A clocked gyro that does not state its settling (``settle_s = None``)."""

    settle_s = None


def test_from_a_previous_model_the_settling_is_the_devices_else_the_configurations(
    tmp_path: Path,
) -> None:
    """The anchored model is moved ahead by the settling after the bias change: the device's
    when it states one, else ``[experiment] settle_s`` (a run from a model has no Q of its own
    to estimate one from), else nothing."""
    first = tune(CONFIG, tmp_path / "first", plots=False, device=bench_gyro(3))
    model = tmp_path / "first" / f"iter{first.iterations:02d}" / "model.nc"
    one = {**CONFIG, "tuning": {**CONFIG["tuning"], "max_iterations": 1}}
    ahead = {}
    for name, device, experiment in [
        ("device", Counting(bench_gyro(4)), {"settle_s": 123.0}),
        ("config", Unsettled(bench_gyro(4)), {"settle_s": 123.0}),
        ("none", Unsettled(bench_gyro(4)), {}),
    ]:
        config = {**one, "experiment": experiment}
        tune(config, tmp_path / name, plots=False, device=device, from_model=model)
        ahead[name] = load_model(tmp_path / name / "iter01" / "model.nc").meta[
            "drift_anchor_ahead_s"
        ]
    assert ahead["device"] == pytest.approx(bench_gyro(4).settle_s)
    assert ahead["config"] == pytest.approx(123.0) and ahead["none"] == 0.0


def test_the_cli_takes_a_model_and_refuses_one_of_other_electrodes(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    first = tune(CONFIG, tmp_path / "first", plots=False, device=bench_gyro(3))
    model = tmp_path / "first" / f"iter{first.iterations:02d}" / "model.nc"
    cfg = tmp_path / "three.toml"
    cfg.write_text(
        '[device]\nname = "cloverleaf"\n[tuning]\ncriterion = "degenerate"\n'
        'electrodes = ["B1", "B2", "B3"]\n'
    )
    code = main(["tune", str(cfg), "--out", str(tmp_path / "x"), "--from-model", str(model)])
    err = capsys.readouterr().err
    assert code == 1 and "--from-model" in err and "B3" in err and "Traceback" not in err
    shutil.rmtree(tmp_path / "x", ignore_errors=True)
    code = main(["tune", str(cfg), "--out", str(tmp_path / "y"), "--from-model", "/no/model.nc"])
    assert code == 1 and "Traceback" not in capsys.readouterr().err
