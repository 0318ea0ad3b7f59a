"""The one error line of a run that did not converge says what may help, by why it ended."""

from __future__ import annotations

from sysid_core.cli.tune import advice
from sysid_core.run.summary import DAC_LIMITS


def test_a_run_that_lost_the_modes_is_not_told_to_iterate_more() -> None:
    said = advice(
        "NOT converged after 4 iteration(s): not verified, no sweep showed ...", None, False
    )
    assert "did not show the modes" in said and "max_iterations" not in said
    stopped = advice("NOT converged ...", "the bench-time budget of 313 min is spent", False)
    assert "did not show the modes" in stopped and "max_bench_minutes" not in stopped


def test_each_other_ending_has_its_own_advice() -> None:
    assert "finer DAC" in advice(f"NOT converged: {DAC_LIMITS} ...", None, True)
    assert "max_bench_minutes" in advice("NOT converged ...", "the budget is spent", True)
    assert "max_iterations" in advice("NOT converged after 3 iteration(s) ...", None, True)
