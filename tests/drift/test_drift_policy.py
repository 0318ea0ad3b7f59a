"""``[model] drift`` is parsed once into a typed policy: whether the run tracks the gyro (always,
on a clock, never), and how its forecast takes the split to move (``drift_split_hz_per_h``)."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from sysid_core.drift.looks import split_bound
from sysid_core.drift.policy import DRIFT_VALUES, REMOVED, DriftPolicy
from sysid_core.drift.tracker import Tracker
from sysid_core.errors import ConfigError
from sysid_core.identification.splittrend import LAB_TREND, forecast
from sysid_core.run.config import parse_config


@pytest.mark.parametrize(
    ("value", "on_a_clock", "without_one"),
    [("auto", True, False), ("track", True, True), ("none", False, False)],
)
def test_each_value_says_when_the_run_tracks(
    value: str, on_a_clock: bool, without_one: bool
) -> None:
    policy = parse_config(
        {"device": {"name": "cloverleaf"}, "model": {"drift": value}}
    ).model.policy
    assert policy == DriftPolicy.parse(value) and policy.value == value
    assert policy.tracking(clock=True) is on_a_clock
    assert policy.tracking(clock=False) is without_one
    assert policy.may_track is on_a_clock


def test_the_values_are_the_configurations_and_nothing_else_is_taken() -> None:
    assert set(DRIFT_VALUES) == {"auto", "none", "track"}
    with pytest.raises(ValueError, match="not one of auto, none, track"):
        DriftPolicy.parse("tracking")
    with pytest.raises(ConfigError, match=r"\[model\] drift"):
        parse_config({"device": {"name": "cloverleaf"}, "model": {"drift": "tracking"}})
    for former in REMOVED:
        with pytest.raises(ValueError, match="no longer a run policy"):
            DriftPolicy.parse(former)


def test_a_lab_sets_its_prior_on_the_splits_rate() -> None:
    """``[model] drift_split_hz_per_h`` replaces the stated trend's rate and nothing else."""
    policy = parse_config(
        {"device": {"name": "cloverleaf"}, "model": {"drift_split_hz_per_h": 0.02}}
    ).model.policy
    assert policy.trend == dataclasses.replace(LAB_TREND, rate_hz_per_s=0.02 / 3600.0)
    tracker = Tracker.of(policy, 1e-3)
    assert tracker is not None and tracker.trend is policy.trend
    assert DriftPolicy.parse("auto").trend is LAB_TREND
    for bad in (0, -0.1, float("inf"), "fast"):
        with pytest.raises(ConfigError, match="drift_split_hz_per_h"):
            parse_config({"device": {"name": "cloverleaf"}, "model": {"drift_split_hz_per_h": bad}})


def test_a_quiet_labs_prior_lets_a_first_look_show_a_long_window_holding() -> None:
    """One window 70 s long reads 0.25 ± 0.04 mHz; its forecast for its end 35 s after its middle.

    With the stated trend (1.8 mHz/min a component) the rate alone may move the split by
    1.05 mHz in those 35 s, and the bound is over an acceptance of 1 mHz; with a good lab's
    0.02 Hz/h (0.33 mHz/min) by 0.19 mHz, and it is under it. Each forecast's variance is the
    window's plus the rate's prior over the lever, ``σ_w² + (σ_r · 35 s)²``.
    """
    sigma_w, lever = 0.04e-3, 35.0
    vector = np.array([[0.25e-3, 0.0]])
    bounds = []
    for trend in (LAB_TREND, DriftPolicy.parse("auto", 0.02).trend):
        found = forecast([0.0], vector, [sigma_w**2], lever, trend)
        expected = sigma_w**2 + (trend.rate_hz_per_s * lever) ** 2
        assert found.variance_hz2 == pytest.approx(expected, rel=1e-6)
        bounds.append(split_bound(float(np.hypot(*found.vector_hz)), found.sigma_hz, 1))
    assert bounds[0] > 1e-3 > bounds[1]
