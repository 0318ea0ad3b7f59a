"""``[model] drift`` is parsed once into a typed policy: whether the run tracks the gyro (always,
on a clock, never)."""

from __future__ import annotations

import pytest

from sysid_core.drift.policy import DRIFT_VALUES, REMOVED, DriftPolicy
from sysid_core.errors import ConfigError
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
