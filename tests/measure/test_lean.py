"""The lean protocol: points where the modes are, every sweep reused, the band after a miss."""

from __future__ import annotations

import dataclasses
import hashlib
from pathlib import Path
from typing import Any

import numpy as np
import pytest
import xarray as xr
from hypothesis import given, settings
from hypothesis import strategies as st
from sysid_cloverleaf import CloverleafGyro
from sysid_random_gyro import RandomGyro

from sysid_core.device.capabilities import Capabilities, read_capabilities
from sysid_core.errors import ConfigError, DeviceError, UnreachableTuningError
from sysid_core.measure import lean
from sysid_core.measure.evidence import local_steps
from sysid_core.measure.lean import ModeGuess, mode_grid, scout_grid
from sysid_core.measure.locating import QUIET_NOISE, probe_first, probe_points
from sysid_core.measure.modegrid import shaped_grid
from sysid_core.measure.sweeps import MIN_POINTS, SweepPlan
from sysid_core.run.config import ExperimentConfig, parse_config
from sysid_core.run.pipeline import TuningRun

PLAN = SweepPlan((4385.0, 4445.0), 0.5, 6.0, 0.05, 1.0, 0.01, 20_000)
MAIN_JOB = {
    "device": {"name": "cloverleaf", "seed": 1},
    "tuning": {
        "criterion": "degenerate",
        "electrodes": ["B1", "B2"],
        "start_bias": [0.0, 0.0, 0.0],
        "acceptance_hz": 0.001,
        "max_iterations": 4,
    },
    "experiment": {"band_hz": [4385.0, 4445.0]},
}


class Recording(CloverleafGyro):
    """A cloverleaf that records its measurements (bias, points) and may fail on the n-th;
    its noise depends only on (bias, grid), so a resumed run sees the same data."""

    def __init__(self, fail_on: int | None = None, **options: Any) -> None:
        super().__init__(**options)
        self.fail_on = fail_on
        self.calls: list[tuple[tuple[float, ...], int]] = []

    def measure(self, bias: Any, frequencies_hz: Any) -> xr.DataArray:
        f = np.asarray(frequencies_hz, dtype=float)
        self.calls.append((tuple(float(b) for b in bias), f.size))
        if self.fail_on is not None and len(self.calls) == self.fail_on:
            raise RuntimeError("lost the analyzer")
        key = hashlib.sha256(np.asarray(bias, dtype=float).tobytes() + f.tobytes()).digest()
        self._rng = np.random.default_rng(int.from_bytes(key[:8], "little"))
        return super().measure(bias, f)


def files(out: Path, folder: str) -> list[str]:
    return sorted(p.name for p in (out / folder).glob("*.nc") if "model" not in p.name)


# ------------------------------------------------------------------ where the points go
def test_mode_grid_is_dense_at_the_modes_and_sparse_elsewhere() -> None:
    """The default shape (a core of 2 bandwidths, 4 anchors; ``mode_grid`` may choose another)."""
    guess = ModeGuess.of([4424.0, 4429.0], [0.1, 0.12])
    f = shaped_grid(guess, PLAN)
    assert MIN_POINTS <= f.size <= 2 * (2 * lean.MAX_HALF_POINTS + 1) + lean.ANCHORS
    assert np.all(np.diff(f) > 0) and f[0] >= 4385.0 and f[-1] <= 4445.0
    # at each mode a step under its bandwidth; far points reach refine_span / 2 beyond
    bw = guess.bandwidth_hz
    step = np.maximum(
        bw / lean.POINTS_PER_BANDWIDTH, lean.CORE_BANDWIDTHS * bw / lean.MAX_HALF_POINTS
    )
    np.testing.assert_allclose(local_steps(f, guess.frequencies_hz, bw), step, rtol=1e-6)
    assert np.all(step < bw)
    assert f[0] == pytest.approx(4424.0 - 3.0) and f[-1] == pytest.approx(4429.0 + 3.0)
    # an uncertain guess spreads the same number of points wider
    wide = shaped_grid(ModeGuess.of([4424.0, 4429.0], [0.1, 0.12], 0.5), PLAN)
    assert wide.size == f.size
    assert np.ptp(wide[(wide > 4422) & (wide < 4426)]) > np.ptp(f[(f > 4422) & (f < 4426)])
    # two degenerate modes share one grid, still at least MIN_POINTS points
    both = mode_grid(ModeGuess.of([4430.0, 4430.0], [0.1, 0.1]), PLAN)
    assert both.size >= MIN_POINTS and np.unique(both).size == both.size


def test_a_window_for_modes_of_a_vanishing_bandwidth_stays_bounded() -> None:
    """A model's mode far too narrow (1e-9 Hz) does not ask for a window it cannot afford.

    The resolving grid is counted before it is made (it was 5e8 points, 3.8 GiB, for a 2 kHz
    gyro's verification); the coarse grid stands.
    """
    plan = dataclasses.replace(PLAN, tones=8)
    guess = ModeGuess.of([4424.0, 4429.0], [1e-9, 0.12], 0.5)
    f = mode_grid(guess, plan, resolve=True)
    assert MIN_POINTS <= f.size <= 2 * (2 * lean.MAX_HALF_POINTS + 1) + lean.ANCHORS


def test_scout_and_band_edges() -> None:
    near = scout_grid(ModeGuess.of([4424.0, 4429.0], [0.1, 0.1]), PLAN)
    assert near[0] == pytest.approx(4424.0 - 2.5) and near[-1] <= 4429.0 + 2.5 + 1e-9
    # a split so wide that the windows would cover most of the band: the band itself, widened
    # to hold the windows (the band follows the modes, SweepPlan.following)
    far = scout_grid(ModeGuess.of([4395.0, 4435.0], [0.1, 0.1]), PLAN)
    np.testing.assert_allclose(np.diff(far), np.diff(far)[0])  # one even band sweep
    assert far[0] <= PLAN.band_hz[0] and far[-1] >= PLAN.band_hz[1]
    assert far.size <= PLAN.band().size + 1  # of no more points than the band's
    # modes at the band's edge: the grid holds both sides of them, outside the band too
    edge = mode_grid(ModeGuess.of([4385.5, 4390.0], [0.1, 0.1]), PLAN)
    assert edge[0] < 4385.0 and edge[0] >= 4385.5 - lean.anchor_reach(np.array([0.1]), PLAN) - 1
    # a degenerate pair at the edge: its grid and far points on both sides, beyond the band
    corner = mode_grid(ModeGuess.of([4444.8, 4444.8], [0.1, 0.1]), PLAN)
    assert corner.size >= MIN_POINTS and corner[-1] > 4445.0
    assert np.sum(np.abs(corner - 4444.8) <= 0.2) >= 2 * lean.MAX_HALF_POINTS + 1


@settings(max_examples=50, deadline=None)
@given(
    start=st.floats(1000.0, 30_000.0),
    step=st.floats(0.001, 2.0),
    n=st.integers(11, 200),
    where=st.floats(0.1, 0.9),
    bw=st.floats(0.001, 5.0),
)
def test_local_step_of_an_even_grid_is_its_step(
    start: float, step: float, n: int, where: float, bw: float
) -> None:
    f = start + step * np.arange(n)
    mode = start + where * step * (n - 1)
    got = local_steps(f, np.array([mode, mode]), np.array([bw, bw]))
    np.testing.assert_allclose(got, step, rtol=1e-6)


# ------------------------------------------------------------------ runs
@pytest.fixture(scope="module")
def lean_run(tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, Any, Recording]:
    out = tmp_path_factory.mktemp("lean") / "run"
    dev = Recording(seed=1)
    summary = TuningRun(parse_config(MAIN_JOB), out, device=dev, plots=False).run()
    return out, summary, dev


def test_lean_run_tunes_on_few_points(lean_run: tuple[Path, Any, Recording]) -> None:
    out, summary, dev = lean_run
    assert summary.converged and summary.split_hz <= 0.001
    assert dev.true_split_hz(summary.bias) <= 0.001  # the truth, not the measurement
    # the band once (61 points, to locate), then only around the modes
    assert dev.calls[0][1] == lean.LOCATE_POINTS
    assert all(n <= 30 for _, n in dev.calls[1:])
    assert summary.points == sum(n for _, n in dev.calls) < 200
    assert files(out, "iter01") == [f"exp{j}.nc" for j in range(5)] + ["verify.nc"]
    # later iterations reuse every sweep: they measure only their verification
    for rec in summary.history[1:]:
        assert files(out, f"iter{rec.iteration:02d}") == ["verify.nc"]


def probing(**tuning: Any) -> dict[str, Any]:
    """The main job with ``[experiment] probe = true`` (and ``tuning`` changed)."""
    return {
        **MAIN_JOB,
        "tuning": {**MAIN_JOB["tuning"], **tuning},
        "experiment": {**MAIN_JOB["experiment"], "probe": True},
    }


def test_a_probe_on_a_quiet_bench_is_the_locating_sweep_and_the_design_one_sided(
    lean_run: tuple[Path, Any, Recording], tmp_path: Path
) -> None:
    dev = Recording(seed=1)
    lines: list[str] = []
    run = TuningRun(
        parse_config(probing()), tmp_path, device=dev, plots=False, progress=lines.append
    )
    summary = run.run()
    assert summary.converged and dev.true_split_hz(summary.bias) <= 0.001
    said = [line for line in lines if line.startswith("iter01/exp0.nc: a probe of 16 points")]
    assert said and "stands as the locating sweep" in said[0]
    assert said[0].endswith(": a quiet bench")
    # 16 of the 61 locating points find the bench quiet: they stand as the locating sweep, and
    # the first design is one-sided (3 biases); the scouts step as the probe did (6 points)
    assert (
        [n for _, n in dev.calls[:3]]
        == [
            probe_points(lean.LOCATE_POINTS),
            lean.QUIET_SCOUT_POINTS,
            lean.QUIET_SCOUT_POINTS,
        ]
        == [16, 6, 6]
    )
    names = files(tmp_path, "iter01")
    assert names[:3] == ["exp0.nc", "exp1.nc", "exp2.nc"]
    assert not [f for f in names if f.startswith(("exp0-", "exp3"))]
    assert summary.points < 0.7 * lean_run[1].points


def test_a_probe_on_a_noisy_bench_stands_as_the_locating_sweep_but_the_design_is_two_sided(
    tmp_path: Path,
) -> None:
    """At 50 dB the probe's noise is over QUIET_NOISE, yet it shows both modes: it locates
    them (no locating band follows it), the scouts step as it did, and the first design steps
    each electrode both ways. (Scouts at the locating step, a quarter of the probe's, held 13
    and 22 points here.)"""
    dev = Recording(seed=1, noise=3e-3)
    lines: list[str] = []
    run = TuningRun(
        parse_config(probing(max_iterations=1)),
        tmp_path,
        device=dev,
        plots=False,
        progress=lines.append,
    )
    run.run()
    assert dev.calls[0][1] == 16
    said = [line for line in lines if "exp0.nc: a probe of 16 points over the band" in line]
    assert said and "stands as the locating sweep" in said[0]
    assert said[0].endswith(": not a quiet bench")
    assert float(said[0].split("its noise is ")[1].split("%")[0]) / 100 > QUIET_NOISE
    names = set(files(tmp_path, "iter01"))
    assert {"exp0.nc", "exp3.nc", "exp4.nc"} <= names  # two-sided: 2 n + 1 biases
    assert "exp0-locate.nc" not in names  # no locating band at the probe's bias
    # the scouts (+1 V on each electrode) at the probe's step: its floor of 8 points, both found
    scouts = [n for bias, n in dev.calls[1:5] if max(bias) > 0]
    assert scouts == [lean.SCOUT_MIN_POINTS] * 2, dev.calls
    assert not [f for f in names if f.startswith("exp") and "-" in f], names  # no fallbacks
    # the probe is fitted with every other sweep of the iteration
    sweeps = len([f for f in names if f.startswith("exp")])
    assert any(line.endswith(f"model to {sweeps} sweeps") for line in lines), lines


class Timed:
    """Something that states a dwell per acquisition, or not."""

    def __init__(self, dwell_s: object) -> None:
        self.dwell_s = dwell_s


def test_the_probe_by_default_only_where_the_device_has_a_clock() -> None:
    assert ExperimentConfig().probe == "auto"
    assert probe_first("auto", read_capabilities(Timed(10.2)))
    for no_clock in (Timed(None), object()):
        assert not probe_first("auto", read_capabilities(no_clock))
    # a dwell a device cannot mean is refused, not taken for "no clock"
    for bad in (Timed(0.0), Timed(float("nan")), Timed("x")):
        with pytest.raises(DeviceError, match="'dwell_s' must be"):
            read_capabilities(bad)
    caps = read_capabilities(Timed(10.2))
    assert probe_first(True, Capabilities()) and not probe_first(False, caps)
    with pytest.raises(ConfigError, match=r'probe = \'yes\': must be true, false or "auto"'):
        parse_config({**MAIN_JOB, "experiment": {"probe": "yes"}})
    with pytest.raises(ConfigError, match='must be true, false or "auto"'):
        parse_config({**MAIN_JOB, "experiment": {"probe": 1}})


def test_a_clocked_device_is_probed_by_default_and_one_without_a_clock_is_not(
    tmp_path: Path,
) -> None:
    config = parse_config({**MAIN_JOB, "tuning": {**MAIN_JOB["tuning"], "max_iterations": 1}})
    frozen = Recording(seed=1)
    TuningRun(config, tmp_path / "frozen", device=frozen, plots=False).run()
    clocked = Recording(seed=1, bench={"clock": True, "seed": 1})
    assert clocked.dwell_s > 0 and getattr(frozen, "dwell_s", None) is None
    lines: list[str] = []
    TuningRun(
        config, tmp_path / "clocked", device=clocked, plots=False, progress=lines.append
    ).run()
    # the same configuration: the whole locating sweep without a clock, the probe with one
    assert frozen.calls[0][1] == lean.LOCATE_POINTS and clocked.calls[0][1] == 16
    assert any(line.startswith("iter01/exp0.nc: a probe of 16 points") for line in lines)


def test_a_locating_sweep_no_larger_than_a_probe_is_judged_itself(tmp_path: Path) -> None:
    config = probing(max_iterations=1)
    config["experiment"]["locate_points"] = 16
    dev = Recording(seed=1)
    TuningRun(parse_config(config), tmp_path, device=dev, plots=False).run()
    assert dev.calls[0][1] == 16  # no probe before it; quiet, so the design is one-sided
    names = files(tmp_path, "iter01")
    assert [f for f in names if f.startswith("exp") and "-" not in f] == [
        "exp0.nc",
        "exp1.nc",
        "exp2.nc",
    ]
    assert probe_points(16) == probe_points(41) == 16 and probe_points(121) == 31


def test_a_v2_gyro_tunes_on_fewer_points_with_the_linear_law(
    lean_run: tuple[Path, Any, Recording], tmp_path: Path
) -> None:
    # the cloverleaf's electrodes follow v²: the linear law needs a one-sided design (3 biases,
    # not 5); locate_points sets the locating sweep
    config = {
        **MAIN_JOB,
        "model": {"stiffness": "linear"},
        "experiment": {**MAIN_JOB["experiment"], "locate_points": 21},
    }
    dev = Recording(seed=1)
    summary = TuningRun(parse_config(config), tmp_path, device=dev, plots=False).run()
    assert summary.converged and dev.true_split_hz(summary.bias) <= 0.001
    assert dev.calls[0][1] == 21
    assert files(tmp_path, "iter01")[:3] == ["exp0.nc", "exp1.nc", "exp2.nc"]
    assert "exp3.nc" not in files(tmp_path, "iter01")
    assert summary.points < lean_run[1].points
    assert ExperimentConfig().locate_points == lean.LOCATE_POINTS


def test_the_locate_points_are_checked() -> None:
    bad = {**MAIN_JOB, "experiment": {**MAIN_JOB["experiment"], "locate_points": 5}}
    with pytest.raises(ConfigError, match="locate_points"):
        parse_config(bad)


def test_lean_resume_replays_the_same_choices(
    lean_run: tuple[Path, Any, Recording], tmp_path: Path
) -> None:
    _, reference, ref_dev = lean_run
    out = tmp_path / "run"
    cfg = parse_config(MAIN_JOB)
    with pytest.raises(DeviceError, match="lost the analyzer"):
        TuningRun(cfg, out, device=Recording(fail_on=4, seed=1), plots=False).run()
    dev = Recording(seed=1)
    resumed = TuningRun(cfg, out, resume=True, device=dev, plots=False).run()
    assert dev.calls == ref_dev.calls[3:]  # the 3 saved sweeps are read, the rest measured
    assert resumed.bias == reference.bias and resumed.points == reference.points


def test_a_probed_run_resumes_with_the_same_choices(tmp_path: Path) -> None:
    # a noisy bench: the probe is measured, then the locating sweep; a resumed run reads both
    # back and makes the same choices (interrupted in the design)
    cfg = parse_config(probing(max_iterations=1))
    ref = Recording(seed=1, noise=3e-3)
    reference = TuningRun(cfg, tmp_path / "ref", device=ref, plots=False).run()
    out = tmp_path / "run"
    with pytest.raises(DeviceError, match="lost the analyzer"):
        TuningRun(cfg, out, device=Recording(fail_on=4, seed=1, noise=3e-3), plots=False).run()
    dev = Recording(seed=1, noise=3e-3)
    resumed = TuningRun(cfg, out, resume=True, device=dev, plots=False).run()
    assert dev.calls == ref.calls[3:]  # the probe, the locating sweep and a scout are read
    assert resumed.bias == reference.bias and resumed.points == reference.points


def test_a_missed_guess_falls_back_to_the_band(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """Scouts far too narrow: the modes are not in them; the locating band finds them."""
    monkeypatch.setattr(lean, "SCOUT_SPLITS", 0.0)
    monkeypatch.setattr(lean, "SCOUT_BANDWIDTHS", 0.5)
    dev = Recording(seed=1)
    messages: list[str] = []
    cfg = parse_config({**MAIN_JOB, "tuning": {**MAIN_JOB["tuning"], "acceptance_hz": 0.01}})
    summary = TuningRun(cfg, tmp_path, device=dev, plots=False, progress=messages.append).run()
    assert summary.converged and dev.true_split_hz(summary.bias) <= 0.01
    assert "exp1-locate.nc" in files(tmp_path, "iter01")
    assert any("exp1.nc: the sweep does not show both modes" in m for m in messages)


def test_a_law_that_holds_only_locally_gets_a_local_design(tmp_path: Path) -> None:
    """Random gyro 0's bias law is not v²: a model of all sweeps misses the verification,
    so the run measures the local design (0.25 V) and fits the sweeps near the bias."""
    gyro = RandomGyro(seed=0)
    cfg = parse_config(
        {
            "device": {"name": "random-gyro", "seed": 0},
            "model": {"structure": gyro.structure},
            "tuning": {
                "criterion": "degenerate",
                "electrodes": ["B1", "B2"],
                "start_bias": [0.0] * len(gyro.electrodes),
                "acceptance_hz": 0.002,
                "max_iterations": 4,
            },
            "experiment": {"bias_step": 3.0},
        }
    )
    messages: list[str] = []
    summary = TuningRun(cfg, tmp_path, plots=False, progress=messages.append).run()
    local = [m for m in messages if "fitting the sweeps near the bias from now on" in m]
    assert local
    later = [
        r.iteration
        for r in summary.history[1:]
        if len(files(tmp_path, f"iter{r.iteration:02d}")) > 2
    ]
    assert later  # some later iteration measured a design, not only its verification
    assert summary.converged and gyro.true_split_hz(summary.bias) < 0.002 + 0.001
    assert summary.points < 600


def test_a_move_to_the_best_reachable_bias_is_identified_there(tmp_path: Path) -> None:
    dev = Recording(seed=1)
    cfg = parse_config(
        {
            "device": {"name": "cloverleaf", "seed": 1},
            "model": {"stiffness": "linear"},
            "tuning": {"criterion": "target", "target_hz": 4460.0, "max_iterations": 3},
        }
    )
    with pytest.raises(UnreachableTuningError, match="4460"):
        TuningRun(cfg, tmp_path, device=dev, plots=False).run()
    # the first answer moved the run: the fit of every sweep answers next (no design), and finds
    # the same best reachable bias; the local design around it is measured at the third
    assert not any(name.startswith("exp") for name in files(tmp_path, "iter02"))
    assert "exp1.nc" in files(tmp_path, "iter03")  # the local design around the new bias
    moved = np.array(dev.calls[-1][0])
    assert np.max(np.abs(moved - np.array(dev.calls[-2][0]))) <= 0.25 + 1e-9
