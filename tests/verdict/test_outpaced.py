"""A split that drifts by the acceptance within half a window stops the run, not converged.

The case: random gyro 319 (2.1 kHz) on the uncontrolled lab's bench (±1.5 K/h, 0.5 K/√h,
charging, analyzer wander, 60 dB), tracked: its fourth verification once measured 0.30 mHz while
its true split went from 0.27 to 1.53 mHz within the window; the drift goal said 2.47 mHz. The
run went on, and its last four iterations drifted it to 8.1 mHz.
"""

from __future__ import annotations

from pathlib import Path

import pytest

from sysid_core import tune
from sysid_core.plugin.registry import get_registry
from sysid_core.tuning.criteria import Goal
from sysid_core.verdict.judgement import DRIFT_GOAL, outpaced

ACCEPTANCE = 0.002


def _goals(split: float, drift_term: float, others_met: bool = True) -> list[Goal]:
    return [
        Goal("split", split, ACCEPTANCE),
        Goal("split 95 % upper bound", split + (0.001 if others_met else 0.01), 2 * ACCEPTANCE),
        Goal(DRIFT_GOAL, split + drift_term, ACCEPTANCE),
    ]


def test_a_drift_of_the_acceptance_in_half_a_window_stops_the_run() -> None:
    why = outpaced(_goals(0.0003, 0.00217), 0.0003, ACCEPTANCE, half_s=210.0)
    assert why is not None and "2.17 mHz in half a window" in why and "mHz/min" in why
    # 1.7 mHz of room at 2.17 mHz per 210 s: 164 s
    assert "holds about 2.7 min" in why


@pytest.mark.parametrize(
    ("split", "term", "others_met"),
    [
        (0.0008, 0.0015, True),  # a smaller split could still meet the goal: go on
        (0.0003, 0.0010, True),  # the drift goal is met: converged, not stopped
        (0.0003, 0.0030, False),  # another goal is not met either: go on
    ],
)
def test_otherwise_the_run_goes_on(split: float, term: float, others_met: bool) -> None:
    assert outpaced(_goals(split, term, others_met), split, ACCEPTANCE) is None


def test_no_drift_goal_no_stop() -> None:
    assert outpaced([Goal("split", 0.003, ACCEPTANCE)], 0.003, ACCEPTANCE) is None


def test_a_stop_ends_the_run_there_not_converged(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """The loop obeys the verdict's stop: the run ends at that iteration, not converged, with the
    reason in its notes and its progress. (Random gyro 319 in the uncontrolled lab once stopped
    so at its fourth iteration; since the local design is measured only where it pays, its run
    takes another path and ends converged at 1.75 mHz true, so the stop is forced here.)"""
    import sysid_core.run.pipeline as pipeline

    real = pipeline.verdict
    why = "the drift outruns the verification: forced by the test"

    def stopping(*args: object, **kwargs: object) -> tuple[list[Goal], bool, str | None]:
        goals, _, _ = real(*args, **kwargs)  # type: ignore[arg-type]
        return goals, False, why

    monkeypatch.setattr(pipeline, "verdict", stopping)
    bench = {"clock": True, "seed": 1, "temperature_ramp_k_per_h": 1.5}
    device = get_registry().device("cloverleaf", seed=1, bench=bench)
    config = {
        "device": {"name": "cloverleaf", "seed": 1},
        "tuning": {"criterion": "degenerate", "electrodes": ["B1", "B2"], "max_iterations": 6},
    }
    lines: list[str] = []
    result = tune(config, tmp_path / "run", plots=False, device=device, progress=lines.append)
    assert result.iterations == 1 and not result.converged
    assert any(why in note for note in result.as_dict()["notes"])
    assert any(line.endswith(why) for line in lines)
