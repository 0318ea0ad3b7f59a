"""A DAC too coarse for the acceptance is said, in the progress and in the status.

Truth: the cloverleaf with a 10-bit DAC (19.5 mV codes over ±10 V). Around the degenerate bias
no code of B1 and B2 brings the true split under the 1 mHz acceptance: the run cannot converge,
and it says why. With the default 16 bits it converges and says nothing of the DAC.
"""

from __future__ import annotations

import itertools
from pathlib import Path
from types import SimpleNamespace
from typing import Any

import numpy as np
import pytest
from sysid_cloverleaf import CloverleafGyro
from truths import cloverleaf_config, write_toml

from sysid_core.cli import main
from sysid_core.identification.splittrend import SplitForecast
from sysid_core.run.config import parse_config
from sysid_core.run.pipeline import TuningRun
from sysid_core.verdict.dacfloor import (
    DAC_FLOOR_SHARE,
    beyond_reach,
    budget_drift_hz,
    dac_floor,
    dac_reached,
    split_estimate,
)

ACCEPTANCE = 0.001


def best_code_around(gyro: CloverleafGyro, bias: np.ndarray) -> float:
    """The least true split over the DAC codes one step around ``bias`` (B1, B2)."""
    step = gyro.bias_resolution
    return min(
        gyro.true_split_hz(bias + np.array([d1 * step, d2 * step, 0.0]))
        for d1, d2 in itertools.product((-1, 0, 1), repeat=2)
    )


def config(iterations: int = 2) -> dict:
    return cloverleaf_config(ACCEPTANCE, iterations, experiment={"band_hz": [4385.0, 4445.0]})


def test_a_dac_too_coarse_for_the_acceptance_is_said(tmp_path: Path) -> None:
    gyro = CloverleafGyro(seed=1, dac_bits=10)
    lines: list[str] = []
    summary = TuningRun(
        parse_config(config()), tmp_path / "ten", device=gyro, plots=False, progress=lines.append
    ).run()
    said = [line for line in lines if "the DAC limits this answer" in line]
    assert not summary.converged and said
    assert "the DAC limits it: its best code there is predicted to leave" in summary.status
    # the truth agrees: no code one step around the final bias is within the acceptance
    assert best_code_around(gyro, summary.bias) > ACCEPTANCE
    # ... and with 16 bits nothing is said
    lines.clear()
    fine = TuningRun(
        parse_config(config()),
        tmp_path / "sixteen",
        device=CloverleafGyro(seed=1),
        plots=False,
        progress=lines.append,
    ).run()
    assert fine.converged and not any("DAC" in line for line in lines)


def test_the_dac_floor_needs_a_code_a_reachable_goal_and_a_sizeable_share() -> None:
    code = {"dac_code": {"predicted_split_hz_chosen": 0.0006}}
    assert dac_floor(code, 0.001) == 0.0006
    assert dac_floor(code, 0.0006 / DAC_FLOOR_SHARE * 1.01) is None
    assert dac_floor(code, None) is None
    assert dac_floor({}, 0.001) is None
    assert dac_floor({**code, "unreachable": "out of the limits"}, 0.001) is None


def test_a_goal_is_beyond_reach_out_of_the_limits_or_under_the_dacs_best_code() -> None:
    """What makes a run tuning a pair of its electrodes tune every one (pairing module)."""
    assert "out of reach" in str(beyond_reach({"unreachable": "best 3 mHz"}, 0.001))
    over = {"dac_code": {"predicted_split_hz_chosen": 0.0012}}
    assert "1.2 mHz" in str(beyond_reach(over, 0.001))
    assert beyond_reach(over, 0.0013) is None  # a sizeable share, but under the acceptance
    assert beyond_reach(over, None) is None
    assert beyond_reach({}, 0.001) is None


def test_the_command_line_points_at_the_dac_not_at_more_iterations(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    tables = config()
    tables["device"] = {**tables["device"], "dac_bits": 10}
    path = write_toml(tmp_path / "coarse.toml", tables)
    code = main(["tune", str(path), "--out", str(tmp_path / "run"), "--no-plots"])
    last = capsys.readouterr().err.strip().splitlines()[-1]  # after the progress lines
    assert code == 1 and last.startswith("sysid: error: NOT converged")
    assert "the DAC limits it" in last and "a finer DAC, another tuned electrode" in last
    assert "max_iterations" not in last


def test_a_run_that_verifies_its_dac_floor_again_stops_there(tmp_path: Path) -> None:
    """The 10-bit cloverleaf with 8 iterations allowed: its second answer is the code its first
    verified, where the model predicts 9.76 mHz and the window measures 9.74 mHz (its interval
    well over the acceptance); the run stops there (before: it verified that code again until
    the cap, 8 iterations, 291 points)."""
    gyro = CloverleafGyro(seed=1, dac_bits=10)
    summary = TuningRun(parse_config(config(8)), tmp_path / "run", device=gyro, plots=False).run()
    assert not summary.converged and summary.iterations == 2
    assert "stopped: the DAC sets the floor" in summary.status
    # the truth agrees: no code one step around the final bias is within the acceptance
    assert best_code_around(gyro, summary.bias) > ACCEPTANCE


@pytest.mark.parametrize(
    ("again", "floor", "split", "stops"),
    [
        (True, 1.1e-3, 1.05e-3, True),  # the code again; the model and the windows agree
        (False, 1.1e-3, 1.05e-3, False),  # a new code: it may do better
        (True, None, 1.05e-3, False),  # the DAC does not limit the answer
        (True, 0.9e-3, 1.05e-3, False),  # the model says the code meets the goal
        (True, 1.1e-3, 0.95e-3, False),  # the windows' estimate is under: more may show it
        (True, 1.1e-3, None, False),  # the windows cannot tell
    ],
)
def test_the_dac_floor_stops_a_run_only_where_model_and_windows_agree(
    again: bool, floor: float | None, split: float | None, stops: bool
) -> None:
    why = dac_reached(again, floor, ACCEPTANCE, split)
    assert (why is not None) == stops
    if why is not None:
        assert "1.1 mHz" in why and "1.05 mHz" in why and "1 mHz" in why


def test_a_drift_of_the_floors_size_in_the_time_left_lets_the_run_go_on() -> None:
    """The best code is the one whose split is least: a drift of the floor's size or more
    within the budget may bring another code under the goal."""
    assert dac_reached(True, 1.1e-3, ACCEPTANCE, 1.05e-3, drift_hz=0.2e-3) is not None
    assert dac_reached(True, 1.1e-3, ACCEPTANCE, 1.05e-3, drift_hz=1.1e-3) is None
    assert dac_reached(True, 2.6e-3, 2e-3, 2.2e-3, drift_hz=0.24) is None  # 4 mHz/min, 1 h


def tracked(
    vector_hz: np.ndarray,
    sigma_hz: float,
    rate: tuple[float, float] = (0.0, 0.0),
    spread: float = 0.0,
) -> Any:
    """A tracker whose forecast at the window's end is ``vector_hz`` ± ``sigma_hz``, its rate
    ``rate`` ± ``spread`` (Hz/s, a component's standard deviation)."""
    found = SplitForecast(np.asarray(vector_hz, float), sigma_hz**2, np.array(rate), spread**2, 3)
    return SimpleNamespace(at_end=found)


def test_a_drift_the_windows_cannot_tell_from_none_is_no_reason_to_wait() -> None:
    """A good lab's gyro at its floor: a rate of 0.28 ± 0.98 mHz/min (a component's standard
    deviation) is no drift the windows see; 4 ± 0.5 mHz/min is, and over 290 windows 5.45 s
    apart it may move the split far more than a floor of a mHz."""
    end, afford, vector = (1.2e-3, 1.1e-3), (290, 5.45), np.array([1.1e-3, 0.0])
    unseen = tracked(vector, 1e-4, rate=(3.4e-6, -3.3e-6), spread=1.64e-5)
    assert budget_drift_hz(unseen, end, afford) == 0.0
    seen = tracked(vector, 1e-4, rate=(6.7e-5, 0.0), spread=8e-6)
    assert budget_drift_hz(seen, end, afford) == pytest.approx((6.7e-5 + 1.96 * 8e-6) * 290 * 5.45)
    assert budget_drift_hz(seen, None, afford) == budget_drift_hz(seen, end, None) == 0.0


def test_the_windows_estimate_is_the_forecasts_length_less_its_noise() -> None:
    """Truth: split vectors of known length, estimated with noise of known size. The length of
    a noisy estimate is too long on average; the estimate takes the noise's share out, so that
    a split on the goal is not read over it for the noise alone."""
    rng = np.random.default_rng(0)
    sigma = 0.3e-3
    for true in (0.0, 0.5e-3, 1.0e-3, 3.0e-3):
        vectors = np.array([true, 0.0]) + sigma * rng.standard_normal((20_000, 2))
        raw = np.hypot(*vectors.T)
        pairs = zip(raw, vectors, strict=True)
        est = np.array([split_estimate(None, (0.0, m), tracked(v, sigma)) for m, v in pairs])
        # unbiased in the square: E[|v|^2] = true^2 + 2 sigma^2; the clip at 0 only adds
        assert np.mean(est**2) >= true**2 - 4 * np.std(raw**2) / np.sqrt(raw.size)
        assert np.mean(raw) > true  # the length alone reads long
        if true >= 3 * sigma:  # resolved: the estimate is centred on the truth
            assert abs(np.median(est) - true) < 0.05 * true
    # noise alone: a window that cannot tell its split from nothing estimates under the goal
    assert split_estimate(None, (0.0, 0.9e-3), tracked(np.array([0.9e-3, 0.0]), 0.7e-3)) == 0.0
    # no noise: the forecast's length itself
    assert split_estimate(None, (0.0, 1.2e-3), tracked(np.array([1.2e-3, 0.0]), 0.0)) == 1.2e-3
