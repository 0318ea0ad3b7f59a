"""What every measuring protocol of a run works with (:class:`RunContext`)."""

from __future__ import annotations

import dataclasses
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from sysid_core.clock.bench import Bench
from sysid_core.clock.budget import DEFAULT_MAX_ITERATIONS
from sysid_core.data.validation import check_rank_condition
from sysid_core.measure.fitter import Fitter
from sysid_core.measure.sweeps import SweepPlan, design_experiments
from sysid_core.run.config import PipelineConfig
from sysid_core.tuning.criteria import BiasSpace

__all__ = ["RunContext"]


@dataclass
class RunContext:
    """What every protocol works with.

    The configuration, the bias space, the sweeps' plan, the bench, the fitter and the
    progress callback.
    """

    config: PipelineConfig
    space: BiasSpace
    plan: SweepPlan
    bench: Bench
    fitter: Fitter
    say: Callable[[str], None]
    #: How many iterations the run can still start (the bench-time budget's,
    #: :meth:`sysid_core.clock.budget.Budget.iterations_left`); None: the cap's alone.
    afford: Callable[[], int] | None = None
    #: What a sweep of so many points costs on the bench clock, after a bias change or not
    #: (:meth:`sysid_core.clock.runclock.RunClock.sweep_s`); None: nothing compares costs.
    cost_s: Callable[[int, bool], float] | None = None

    @property
    def tracking(self) -> bool:
        """Whether the run tracks the drift (``drift = "track"``, or ``"auto"`` on a clock)."""
        return self.config.model.policy.tracking(self.bench.clock_span_s is not None)

    def left(self) -> int:
        """Iterations the run can still start, this one included if it has not measured yet.

        What the verdicts that look ahead count (:func:`sysid_core.measure.contraction.too_slow`).
        """
        if self.afford is not None:
            return self.afford()
        return self.config.tuning.max_iterations or DEFAULT_MAX_ITERATIONS

    @property
    def passes(self) -> tuple[float, int, float | None]:
        """What bounds a window's repeated passes (:mod:`sysid_core.measure.passes`).

        The acceptance (Hz), ``[experiment] max_passes`` and ``dwell_s``.
        """
        exp = self.config.experiment
        return self.config.tuning.acceptance_hz, exp.max_passes, exp.dwell_s

    def retune(self, tuned: list[str]) -> None:
        """Tune ``tuned`` from now on (a pair chosen among the configured electrodes)."""
        self.space = dataclasses.replace(self.space, tuned=list(tuned))

    def step(self, it: int) -> float:
        """The bias step of iteration ``it`` (volts)."""
        exp = self.config.experiment
        return exp.bias_step if it == 1 or exp.refine_bias_step is None else exp.refine_bias_step

    def design(self, bias: np.ndarray, it: int = 1, quiet: bool = False) -> np.ndarray:
        """The experiments of eq. (18) around ``bias``, checked against the rank condition (6).

        The design is two-sided unless the law is linear or the design says otherwise, or the
        law is ``auto`` and ``quiet`` (a quiet bench's first design,
        :mod:`sysid_core.measure.locating`).
        """
        exp, law = self.config.experiment, self.config.model.stiffness
        sided = law != "linear" and not (quiet and law == "auto")
        two_sided = exp.design == "two-sided" or (exp.design is None and sided)
        design = design_experiments(
            bias, self.space.index, self.step(it), self.space.limits, two_sided=two_sided
        )
        check_rank_condition(
            design[:, self.space.index],
            self.space.structure_potential,
            self.space.tuned,
            quadratic=law == "quadratic",
        )
        return design
