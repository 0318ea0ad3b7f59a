"""The split's drift of examples/window_floor.py against the bench's own drifts.

Truth: random gyro 108 (18.4 kHz) on benches with a clock. Without a drift the split at the
degenerate bias stays zero; with charging alone it moves, in proportion to the charging rate
(the split's drift is linear in a small change of the effective bias); and the temperature's
ramp alone does not move it: the simulated bench scales the whole stiffness with the
temperature, so a degenerate pair stays degenerate (docs/drift.md).
"""

from __future__ import annotations

import sys
from pathlib import Path

import pytest

from sysid_core.plugin.registry import get_registry

sys.path.insert(0, str(Path(__file__).resolve().parents[2] / "examples"))

from window_floor import split_drift_mhz_per_min


def gyro(**bench: float) -> object:
    return get_registry().device("random-gyro", seed=108, bench={"clock": True, **bench})


def test_the_split_stays_at_zero_on_a_bench_without_drift() -> None:
    assert abs(split_drift_mhz_per_min(gyro(), 600.0)) < 1e-3


def test_the_split_drifts_in_proportion_to_the_charging() -> None:
    one = split_drift_mhz_per_min(gyro(charging_v_per_h=0.015), 600.0)
    two = split_drift_mhz_per_min(gyro(charging_v_per_h=0.030), 600.0)
    assert one > 0.1  # mHz per minute: the lab's 15 mV/h on an 18 kHz gyro
    assert two / one == pytest.approx(2.0, rel=0.05)


def test_a_common_temperature_ramp_does_not_move_the_split() -> None:
    assert abs(split_drift_mhz_per_min(gyro(temperature_ramp_k_per_h=1.5), 600.0)) < 1e-3
