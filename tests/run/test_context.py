"""What every protocol of a run works with (``RunContext``): the iterations left (the budget's,
else the cap), the design step of each iteration, the design of eq. (18) by law and bench, and
what bounds a window's repeated passes; all read from the configuration."""

from __future__ import annotations

from typing import Any

import numpy as np
import pytest

from sysid_core.clock.budget import DEFAULT_MAX_ITERATIONS
from sysid_core.run.config import parse_config
from sysid_core.run.context import RunContext
from sysid_core.tuning.criteria import BiasSpace

SPACE = BiasSpace(["B1", "B2", "B3"], ["B1", "B2"], np.zeros(3), (-10.0, 10.0), 15.58)


def context(afford: Any = None, **tables: dict[str, Any]) -> RunContext:
    config = parse_config({"device": {"name": "cloverleaf"}, **tables})
    plan = config.experiment.sweep_plan((4385.0, 4445.0))
    return RunContext(config, SPACE, plan, None, None, lambda line: None, afford)  # type: ignore[arg-type]


def test_the_iterations_left_are_the_budgets_else_the_cap() -> None:
    assert context().left() == DEFAULT_MAX_ITERATIONS
    assert context(tuning={"max_iterations": 5}).left() == 5
    assert context(lambda: 2, tuning={"max_iterations": 5}).left() == 2


def test_the_first_iteration_steps_by_bias_step_the_later_ones_by_refine_bias_step() -> None:
    ctx = context(experiment={"bias_step": 2.0, "refine_bias_step": 0.5})
    assert (ctx.step(1), ctx.step(2), ctx.step(7)) == (2.0, 0.5, 0.5)
    whole = context(experiment={"bias_step": 2.0, "refine_bias_step": None})
    assert whole.step(3) == 2.0


@pytest.mark.parametrize(
    ("stiffness", "quiet", "design", "n"),
    [
        ("auto", False, None, 5),  # two-sided: the law test needs two levels per electrode
        ("auto", True, None, 3),  # a quiet bench's first design: one-sided
        ("linear", False, None, 3),  # the paper's n + 1
        ("quadratic", False, None, 5),
        ("linear", False, "two-sided", 5),
    ],
)
def test_the_design_follows_the_law_and_the_bench(
    stiffness: str, quiet: bool, design: str | None, n: int
) -> None:
    experiment = {"bias_step": 1.0} if design is None else {"bias_step": 1.0, "design": design}
    ctx = context(model={"stiffness": stiffness}, experiment=experiment)
    biases = ctx.design(np.zeros(3), quiet=quiet)
    assert biases.shape == (n, 3)
    np.testing.assert_array_equal(biases[0], np.zeros(3))  # the centre first
    assert np.all(biases[:, 2] == 0.0)  # an electrode not tuned keeps its bias
    assert set(np.abs(biases[1:, :2]).max(axis=1)) == {1.0}  # one electrode stepped at a time


def test_the_passes_are_bounded_by_the_acceptance_and_the_experiment() -> None:
    ctx = context(tuning={"acceptance_hz": 0.002}, experiment={"max_passes": 8, "dwell_s": 3.0})
    assert ctx.passes == (0.002, 8, 3.0)
