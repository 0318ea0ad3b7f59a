"""``[model] drift`` is parsed once into a typed policy: whether the run tracks the gyro (always,
on a clock, never) and which experimental drift terms its fit carries."""

from __future__ import annotations

import pytest

from sysid_core.errors import ConfigError
from sysid_core.run.config import parse_config
from sysid_core.run.driftpolicy import DRIFT_VALUES, DriftPolicy


@pytest.mark.parametrize(
    ("value", "on_a_clock", "without_one", "terms"),
    [
        ("auto", True, False, ()),
        ("track", True, True, ()),
        ("none", False, False, ()),
        ("common", False, False, ("common",)),
        ("offsets", False, False, ("offsets",)),
        ("trend", False, False, ("trend",)),
    ],
)
def test_each_value_says_when_the_run_tracks_and_what_its_fit_carries(
    value: str, on_a_clock: bool, without_one: bool, terms: tuple[str, ...]
) -> None:
    policy = parse_config(
        {"device": {"name": "cloverleaf"}, "model": {"drift": value}}
    ).model.policy
    assert policy == DriftPolicy.parse(value) and policy.value == value
    assert policy.tracking(clock=True) is on_a_clock
    assert policy.tracking(clock=False) is without_one
    assert policy.may_track is on_a_clock
    assert {t for t in ("common", "offsets", "trend") if getattr(policy, t)} == set(terms)


def test_the_values_are_the_configurations_and_nothing_else_is_taken() -> None:
    assert set(DRIFT_VALUES) == {"auto", "none", "common", "offsets", "trend", "track"}
    with pytest.raises(ValueError, match="not one of auto, none"):
        DriftPolicy.parse("tracking")
    with pytest.raises(ConfigError, match=r"\[model\] drift"):
        parse_config({"device": {"name": "cloverleaf"}, "model": {"drift": "tracking"}})
