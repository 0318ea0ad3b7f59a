"""A run is bounded by its bench-time budget; the device's bench capabilities and clock are
checked once, before they are used.

Truths: the simulated cloverleaf's bench clock (settling and dwell per acquisition stated by the
device, time stamps on every point), so a run's bench time is known exactly; a budget is met when
the clock's span, plus the first settling and dwell, is no more than it.
"""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import numpy as np
import pytest
import xarray as xr
from sysid_cloverleaf import CloverleafGyro

from sysid_core import tune
from sysid_core.cli import main
from sysid_core.clock.budget import BUDGET_DWELLS, DEFAULT_MAX_ITERATIONS, Budget, spent_s
from sysid_core.device.capabilities import Capabilities, read_capabilities
from sysid_core.errors import BudgetSpentError, DeviceError, InvalidAnswerError
from sysid_core.measure.locating import probe_first
from sysid_core.run.config import parse_config
from sysid_core.run.pipeline import TuningRun

CONFIG: dict[str, Any] = {
    "device": {"name": "cloverleaf", "seed": 3},
    "tuning": {
        "criterion": "degenerate",
        "electrodes": ["B1", "B2"],
        "start_bias": [-4.0, 3.0, 0.0],
        "acceptance_hz": 0.001,
    },
}
GOOD_LAB = {"temperature_ramp_k_per_h": 0.2, "temperature_walk_k_per_sqrt_h": 0.05}


def clocked(seed: int = 3, tones: int = 8) -> CloverleafGyro:
    return CloverleafGyro(
        seed=seed, bench={"clock": True, "seed": seed, "tones": tones, **GOOD_LAB}
    )


def with_tuning(**tuning: object) -> dict[str, Any]:
    return {**CONFIG, "tuning": {**CONFIG["tuning"], **tuning}}


# ---------------------------------------------------------------- the budget's arithmetic
HOUR = 3600.0


def test_the_budget_counts_iterations_by_their_cost_not_by_the_cap() -> None:
    budget, cap = Budget(minutes=60.0), 50
    assert budget.cost_s() is None and budget.iterations_left(0, None, HOUR, cap) == 50
    budget.ended(1200.0)  # a first iteration: locating, design, verification
    assert budget.cost_s() == 1200.0 and budget.iterations_left(1, 1200.0, HOUR, cap) == 2
    budget.ended(1500.0)  # then verifications of 300 s
    budget.ended(1800.0)
    assert budget.cost_s() == pytest.approx(300.0)
    assert budget.iterations_left(3, 1800.0, HOUR, cap) == 6
    assert budget.left_now(1800.0, HOUR, cap) == 6
    # the cap still caps
    assert Budget(60.0, ends_s=[1200.0, 1500.0, 1800.0]).left_now(1800.0, HOUR, cap=4) == 1
    # an iteration of unknown bench time: the cap alone decides
    assert Budget(60.0, ends_s=[None]).left_now(None, HOUR, cap=9) == 8


def test_the_cap_is_the_configured_one_else_its_default() -> None:
    assert Budget(None, iterations=7).cap == 7
    assert Budget(None).cap == DEFAULT_MAX_ITERATIONS == 300


def test_the_default_budget_is_an_hour_or_the_gyros_own_time() -> None:
    unset, set_ = Budget(minutes=None), Budget(minutes=25.0)
    assert unset.limit_s(None) == HOUR and unset.limit_s(2.0) == HOUR  # a fast gyro
    # a slow one: 1200 dwells of 40 s (5 Q/ω of a 2 kHz mode with Q = 100 000), 13.3 hours
    assert unset.limit_s(40.0) == pytest.approx(BUDGET_DWELLS * 40.0)
    assert BUDGET_DWELLS * 40.0 == pytest.approx(13.33 * HOUR, rel=1e-3)
    assert set_.limit_s(40.0) == 25 * 60.0  # what the lab set stands


def test_a_measurement_that_would_end_past_the_budget_is_refused() -> None:
    budget, limit = Budget(minutes=10.0), 600.0
    assert budget.refuse(None, 1e9, limit) is None  # nothing tells what was spent
    assert budget.refuse(500.0, 100.0, limit) is None
    why = budget.refuse(500.0, 100.5, limit)
    assert why is not None and "budget of 10 min ([tuning] max_bench_minutes)" in why
    assert budget.refuse(600.0, None, limit) is not None  # spent, whatever it costs
    assert budget.describe(150.0, limit) == "bench time 2.5 of 10 min (7.5 left)"
    assert budget.describe(3000.0, 72_000.0) == "bench time 50 of 1200 min (1150 left)"


def test_bench_time_spent_is_the_clock_else_the_estimate() -> None:
    assert spent_s(100.0, 10, 2, 5.0, 7.0) == pytest.approx(112.0)  # span + settle + dwell
    assert spent_s(None, 10, 2, 5.0, 7.0) == pytest.approx(64.0)  # 10 x 5 + 2 x 7
    assert spent_s(None, 10, 2, 5.0, None) == pytest.approx(50.0)
    assert spent_s(None, 10, 2, None, 7.0) is None


# ---------------------------------------------------------------- runs under a budget
def test_a_run_stops_at_its_budget_with_its_last_verified_answer(tmp_path: Path) -> None:
    # an acceptance no run reaches: only the budget ends it
    first = tune(
        with_tuning(acceptance_hz=1e-7, max_iterations=1),
        tmp_path / "one",
        plots=False,
        device=clocked(),
    )
    one_s = first.bench_time_s
    assert one_s is not None and first.stopped is None
    # ten seconds more than one iteration: the budget ends the run before a second window could
    # show the DAC's floor at a code verified twice (sysid_core.verdict.dacfloor)
    limit_min = (one_s + 10.0) / 60.0
    lines: list[str] = []
    run = TuningRun(
        parse_config(with_tuning(acceptance_hz=1e-7, max_bench_minutes=limit_min)),
        tmp_path / "budget",
        device=clocked(),
        plots=False,
        progress=lines.append,
    )
    summary = run.run()
    assert not summary.converged and summary.stopped is not None
    assert "bench-time budget" in summary.stopped and "stopped" in summary.status
    assert summary.bench_time_s is not None and summary.bench_time_s <= 60.0 * limit_min
    assert summary.bench_time_source == "clock"
    # the first iteration is the same run; its answer is the one the run ends with
    assert summary.iterations >= 1
    on_disk = json.loads((tmp_path / "budget" / "summary.json").read_text())
    assert on_disk["stopped"] == summary.stopped and on_disk["bench_budget_s"] == 60 * limit_min
    assert on_disk["bias"] == summary.bias
    # every iteration says what it spent of the budget, and the stop says why
    spent = [line for line in lines if "bench time" in line and f"of {limit_min:.3g} min" in line]
    assert len(spent) == summary.iterations
    assert any("stopped: the bench-time budget" in line for line in lines)


def test_the_command_line_says_where_the_budget_stopped_the_run(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    first = tune(
        with_tuning(acceptance_hz=1e-7, max_iterations=1),
        tmp_path / "one",
        plots=False,
        device=clocked(),
    )
    assert first.bench_time_s is not None
    config = tmp_path / "c.toml"
    config.write_text(
        '[device]\nname = "cloverleaf"\nseed = 3\n[device.bench]\nclock = true\nseed = 3\n'
        "tones = 8\ntemperature_ramp_k_per_h = 0.2\ntemperature_walk_k_per_sqrt_h = 0.05\n"
        '[tuning]\ncriterion = "degenerate"\nelectrodes = ["B1", "B2"]\n'
        "start_bias = [-4.0, 3.0, 0.0]\nacceptance_hz = 1e-7\n"
        f"max_bench_minutes = {(first.bench_time_s + 10.0) / 60.0}\n"
    )
    code = main(["tune", str(config), "--out", str(tmp_path / "cli"), "--no-plots"])
    captured = capsys.readouterr()
    assert code == 1
    # the progress prints the key as written (it is text, not console markup)
    lines = captured.err.splitlines()
    stop = [line for line in lines if ": stopped: the bench-time" in line]
    assert len(stop) == 1 and "([tuning] max_bench_minutes) is spent" in stop[0], stop
    assert "stopped: the bench-time budget of" in captured.out
    assert lines[-1].startswith("sysid: error: NOT converged") and "budget" in lines[-1]


def test_a_budget_spent_before_any_answer_is_an_error_in_one_line(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    with pytest.raises(BudgetSpentError, match="before a first answer was verified"):
        tune(with_tuning(max_bench_minutes=0.5), tmp_path / "api", plots=False, device=clocked())
    config = tmp_path / "c.toml"
    config.write_text(
        '[device]\nname = "cloverleaf"\nseed = 3\n[device.bench]\nclock = true\ntones = 8\n'
        '[tuning]\ncriterion = "degenerate"\nelectrodes = ["B1", "B2"]\n'
        "start_bias = [-4.0, 3.0, 0.0]\nmax_bench_minutes = 0.5\n"
    )
    code = main(["tune", str(config), "--out", str(tmp_path / "cli"), "--no-plots"])
    err = capsys.readouterr().err.strip().splitlines()
    assert code != 0 and len(err) == 1 and "max_bench_minutes" in err[0], err
    assert "Traceback" not in err[0]


def test_raising_the_cap_changes_no_verdict(tmp_path: Path) -> None:
    """The same run with a cap of 6 and of 50 iterations (and the same budget) measures the same
    points and ends at the same bias: the cap is not a horizon."""
    ends = []
    for cap in (6, 50):
        result = tune(
            with_tuning(max_iterations=cap),
            tmp_path / f"cap{cap}",
            plots=False,
            device=clocked(tones=1),
        )
        ends.append((result.points, result.iterations, result.bias))
    assert ends[0][2] == ends[1][2] and ends[0][:2] == ends[1][:2]
    assert ends[0][1] < 6  # it ended before either cap


def test_a_run_on_a_clock_draws_its_split_over_the_bench_clock(tmp_path: Path) -> None:
    result = tune(with_tuning(max_iterations=2), tmp_path / "clock", device=clocked())
    times = [h.bench_time_s for h in result.history]
    assert all(t is not None for t in times) and times == sorted(times)
    assert times[-1] == pytest.approx(result.bench_time_s)
    verified = [h for h in result.history if h.verification == "verified"]
    assert verified and all(
        h.measured_split_ci_hz is not None
        and h.measured_split_ci_hz[0] <= h.measured_split_hz <= h.measured_split_ci_hz[1]
        for h in verified
    )
    assert (tmp_path / "clock" / "drift.png").stat().st_size > 10_000
    # without a clock there is no bench clock to draw the split over
    tune(with_tuning(max_iterations=1), tmp_path / "frozen", device=CloverleafGyro(seed=3))
    assert not (tmp_path / "frozen" / "drift.png").exists()
    assert (tmp_path / "frozen" / "bias_path.png").exists()


# ---------------------------------------------------------------- capabilities, once
class Stating:
    """A cloverleaf that states a capability of its own."""

    def __init__(self, **caps: object) -> None:
        self.gyro = CloverleafGyro(seed=3)
        self.__dict__.update(caps)

    def __getattr__(self, name: str) -> object:
        return getattr(self.gyro, name)


@pytest.mark.parametrize(
    ("attr", "value", "must"),
    [
        ("tones", 0, "whole number >= 1"),
        ("tones", 2.5, "whole number >= 1"),
        ("tones", True, "whole number >= 1"),
        ("dwell_s", float("nan"), "seconds > 0"),
        ("dwell_s", -1.0, "seconds > 0"),
        ("dwell_s", "fast", "seconds > 0"),
        ("settle_s", -0.1, "seconds >= 0"),
        ("settle_s", float("inf"), "seconds >= 0"),
        ("points_per_frequency", 0, "whole number >= 1"),
        ("bias_resolution", 0.0, "volts > 0"),
    ],
)
def test_a_capability_a_device_cannot_mean_is_refused_before_anything_is_measured(
    tmp_path: Path, attr: str, value: object, must: str
) -> None:
    device = Stating(**{attr: value})
    with pytest.raises(DeviceError, match=rf"'{attr}' must be a .*{must}.* got") as caught:
        TuningRun(parse_config(CONFIG), tmp_path / "run", device=device, plots=False)
    assert "\n" not in str(caught.value)
    assert not (tmp_path / "run").exists()  # nothing measured, nothing written


def test_capabilities_absent_or_none_are_not_stated() -> None:
    assert read_capabilities(object()) == Capabilities()
    caps = read_capabilities(Stating(tones=4, dwell_s=None, settle_s=0.0, bias_resolution=1e-3))
    assert caps == Capabilities(tones=4, settle_s=0.0, bias_resolution=1e-3)
    assert not caps.clock and caps.per_frequency == 1
    assert read_capabilities(clocked()).clock
    # the probe follows the clock the device states
    assert probe_first("auto", Capabilities(dwell_s=10.2))
    assert not probe_first("auto", Capabilities())
    assert probe_first(True, Capabilities()) and not probe_first(False, Capabilities(dwell_s=1.0))


# ---------------------------------------------------------------- the clock, checked once
class Rewinding:
    """A clocked cloverleaf whose clock jumps back by ``back_s`` at its ``at``-th measurement,
    or whose stamps there are NaN."""

    def __init__(self, at: int, back_s: float = 0.0, nan: bool = False) -> None:
        self.gyro = clocked(tones=8)
        self.at, self.back_s, self.nan, self.calls = at, back_s, nan, 0

    def __getattr__(self, name: str) -> object:
        return getattr(self.gyro, name)

    def measure(self, bias: object, frequencies_hz: np.ndarray) -> xr.DataArray:
        self.calls += 1
        da = self.gyro.measure(bias, frequencies_hz)
        if self.calls == self.at:
            t = da["time_s"].values - self.back_s
            da = da.assign_coords(time_s=("frequency", np.full_like(t, np.nan) if self.nan else t))
        return da


@pytest.mark.parametrize(
    ("device", "message"),
    [
        (Rewinding(at=3, back_s=1e6), "its clock ran backwards"),
        (Rewinding(at=2, nan=True), "time_s stamps must be finite"),
    ],
)
def test_time_stamps_that_go_backwards_or_are_not_finite_are_refused_in_one_line(
    tmp_path: Path, device: Rewinding, message: str
) -> None:
    with pytest.raises(InvalidAnswerError, match=message) as caught:
        tune(CONFIG, tmp_path / "run", plots=False, device=device)
    assert "\n" not in str(caught.value)
    # the refused answer is kept aside, the earlier measurements stay on disk
    assert list((tmp_path / "run" / "rejected").iterdir())
    assert len(list((tmp_path / "run" / "iter01").glob("*.nc"))) == device.at - 1


def test_the_timeline_shows_the_windows_forecast_and_a_far_budget_in_words() -> None:
    """drift.png: each tracked verification's forecast bound (the verdict's goal) is drawn at
    its time; a budget far past the run is named in the legend, not drawn as a line."""
    from types import SimpleNamespace

    from sysid_core.run.timeline import timeline_figure
    from sysid_core.verdict.judgement import END_GOAL

    def record(it: int, t: float, split: float, bound: float) -> SimpleNamespace:
        goals = [{"name": END_GOAL, "value_hz": bound, "limit_hz": 0.002, "met": bound <= 0.002}]
        return SimpleNamespace(
            iteration=it,
            bench_time_s=t,
            tuning={},
            measured_split_hz=split,
            measured_split_ci_hz=None,
            goals=goals,
        )

    history = [record(1, 120.0, 0.08, 0.09), record(2, 300.0, 0.0009, 0.0016)]
    fig = timeline_figure(history, 0.002, budget_s=3600.0)  # type: ignore[arg-type]
    ax = fig.axes[0]
    forecast = [ln for ln in ax.lines if ln.get_label().startswith("the windows' forecast")]
    assert len(forecast) == 1
    np.testing.assert_allclose(forecast[0].get_xdata(), [2.0, 5.0])
    np.testing.assert_allclose(forecast[0].get_ydata(), [90.0, 1.6])
    labels = [t.get_text() for t in ax.get_legend().get_texts()]
    assert "budget 60 min (not reached)" in labels
    near = timeline_figure(history, 0.002, budget_s=600.0)  # type: ignore[arg-type]
    assert "budget 10 min" in [t.get_text() for t in near.axes[0].get_legend().get_texts()]


@pytest.mark.parametrize(
    ("name", "purpose"),
    [
        ("exp3.nc", "design"),
        ("exp0-locate.nc", "locating"),
        ("verify.nc", "verification"),
        ("verify-fine2.nc", "verification"),
        ("verify-band.nc", "locating"),
        ("verify-pass2.nc", "repeats"),
        ("window-again.nc", "repeats"),
        ("probe.nc", "locating"),
        ("notes.nc", "other"),
    ],
)
def test_each_measurement_has_a_purpose(name: str, purpose: str) -> None:
    from sysid_core.clock.bench import PURPOSES, purpose_of

    assert purpose_of(name) == purpose and purpose in PURPOSES


def test_the_summary_says_where_the_bench_time_went(tmp_path: Path) -> None:
    """On a clock: the time by purpose and as settling against acquiring both add up to the span
    of the run's time stamps, and the progress says it; without a clock, nothing is claimed."""
    lines: list[str] = []
    result = tune(
        with_tuning(max_iterations=2),
        tmp_path / "clock",
        device=clocked(),
        plots=False,
        progress=lines.append,
    )
    summary = json.loads((tmp_path / "clock" / "summary.json").read_text())
    parts, split = summary["bench_time_by_purpose_s"], summary["bench_time_split_s"]
    assert parts["design"] > 0 and parts["verification"] > 0
    times = [t for h in result.history for t in [h.bench_time_s] if t is not None]
    span = sum(split.values())
    assert sum(parts.values()) == pytest.approx(span, rel=1e-12)
    assert 0 < span <= times[-1]
    assert any("of it settling" in line and "design" in line for line in lines)
    frozen = tune(with_tuning(max_iterations=1), tmp_path / "frozen", device=CloverleafGyro(seed=3))
    assert frozen.as_dict()["bench_time_by_purpose_s"] is None
