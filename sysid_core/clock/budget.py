"""The bench-time budget: what a run has spent of the bench clock, and what it may still spend.

Every run is bounded by ``[tuning] max_bench_minutes`` of bench time. The bench time spent is
the device clock's span when every measurement carried time stamps, else the estimate from the
acquisitions and bias changes counted so far (:func:`spent_s`; docs/bench-time.md). Two rules
follow:

* no measurement starts that would end past the budget (:meth:`Budget.refuse`): the run then
  ends with what its last completed iteration verified
  (:class:`~sysid_core.errors.BudgetSpentError`, which the loop catches; before a first
  verification it is the run's error), and says so in one line with the time spent;
* the verdicts that ask how many iterations remain (a split that falls too slowly,
  :func:`sysid_core.measure.contraction.too_slow`) count the iterations the budget still affords at
  the mean cost of the iterations after the first (:meth:`Budget.iterations_left`), within the
  ``max_iterations`` cap: a cap over what the budget affords changes no verdict, one under it
  makes them count fewer iterations.

The budget is a lab's choice (how long a gyro may occupy a bench). Unset, it is the larger of
an hour (:data:`DEFAULT_MAX_BENCH_MINUTES`) and :data:`BUDGET_DWELLS` of the gyro's own dwells
per acquisition (:func:`default_limit_s`): a slow gyro's acquisition takes a minute (a 1.5 kHz
mode with Q = 100 000 rings for ``Q/ω`` = 11 s), and its first identification alone can take
longer than an hour with one tone.
"""

from __future__ import annotations

import itertools
import math
from dataclasses import dataclass, field

__all__ = [
    "BUDGET_DWELLS",
    "DEFAULT_MAX_BENCH_MINUTES",
    "DEFAULT_MAX_ITERATIONS",
    "Budget",
    "default_limit_s",
    "minutes",
    "spent_s",
]

#: The least default budget: an hour of a bench per gyro.
DEFAULT_MAX_BENCH_MINUTES = 60.0
#: The default budget in the gyro's own time, dwells per acquisition. Measured in the
#: uncontrolled lab (docs/studies/bench-budget.md, 120 random gyros, one tone, 24 iterations
#: without a budget): the runs that converged took up to 909 dwells (a slow gyro whose law
#: needed a local design at most iterations, about 100 dwells each, where a verification alone
#: takes about 22); 1200 leaves a third more. 720, a first identification and 24 windows
#: alone, stopped that gyro at 935 mHz.
BUDGET_DWELLS = 1200


#: The default cap on iterations. Fast gyros whose single windows cannot resolve the acceptance
#: at 60 dB converge by pooling windows: a 22 kHz gyro whose window measures its split to
#: ±9 mHz at 95 % needs about 200 (12 minutes of bench time). Measured in the uncontrolled lab
#: (docs/studies/bench-floor.md, 96 random gyros): caps of 24, 100 and 300 end 86, 87 and 88
#: runs within 2 mHz, 77, 88 and 91 converged, none falsely. 3, the paper's, ends 51 of 96.
#: Lifted, so that the budget ends them, the two of 48 gyros that reach 300 in the uncontrolled
#: lab (23 and 30 kHz) end at 31 and 19 mHz instead of 9.7 and 3.5: past about 500 windows the
#: tracker's forecast no longer holds the truth (docs/studies/bench-floor.md).
DEFAULT_MAX_ITERATIONS = 300


def minutes(seconds: float) -> str:
    """``seconds`` in minutes for a message: three digits, whole minutes from 100 on."""
    value = seconds / 60.0
    return f"{value:.0f}" if abs(value) >= 100 else f"{value:.3g}"


def default_limit_s(dwell_s: float | None) -> float:
    """The budget (seconds) when ``[tuning] max_bench_minutes`` is not set.

    The larger of :data:`DEFAULT_MAX_BENCH_MINUTES` and :data:`BUDGET_DWELLS` dwells of
    ``dwell_s`` (the device's, the configuration's or the fit's estimate; an hour without one).
    """
    hour = 60.0 * DEFAULT_MAX_BENCH_MINUTES
    return hour if dwell_s is None else max(hour, BUDGET_DWELLS * dwell_s)


def spent_s(
    clock_span_s: float | None,
    acquisitions: int,
    bias_changes: int,
    dwell_s: float | None,
    settle_s: float | None,
) -> float | None:
    """Bench seconds a run has spent, or None when nothing tells.

    With a clock (``clock_span_s``, every measurement time-stamped), its span plus what came
    before the first stamp (one settling and one acquisition, as far as they are known); else
    ``acquisitions × dwell_s + bias_changes × settle_s`` (None without ``dwell_s``; the bias
    changes count only with ``settle_s``).
    """
    if clock_span_s is not None:
        return clock_span_s + (settle_s or 0.0) + (dwell_s or 0.0)
    if dwell_s is None:
        return None
    return acquisitions * dwell_s + (bias_changes * settle_s if settle_s else 0.0)


@dataclass
class Budget:
    """A run's bench-time budget and what its iterations cost.

    Parameters
    ----------
    minutes : float or None
        ``[tuning] max_bench_minutes``; None: :func:`default_limit_s`.
    iterations : int or None
        ``[tuning] max_iterations``: the most iterations, whatever the budget; None:
        :data:`DEFAULT_MAX_ITERATIONS`.
    """

    minutes: float | None
    iterations: int | None = None
    #: The bench time spent at the end of each completed iteration (None: not known).
    ends_s: list[float | None] = field(default_factory=list)

    @property
    def cap(self) -> int:
        """The most iterations: the configured cap, else :data:`DEFAULT_MAX_ITERATIONS`."""
        return DEFAULT_MAX_ITERATIONS if self.iterations is None else self.iterations

    def limit_s(self, dwell_s: float | None) -> float:
        """The budget in seconds, for a gyro whose dwell per acquisition is ``dwell_s``."""
        return default_limit_s(dwell_s) if self.minutes is None else 60.0 * self.minutes

    def ended(self, spent: float | None) -> None:
        """Record that an iteration ended with ``spent`` seconds of bench time spent."""
        self.ends_s.append(spent)

    def cost_s(self) -> float | None:
        """What an iteration after the first is expected to cost: their mean, else the first's.

        None before an iteration ended with a known bench time.
        """
        ends = [e for e in self.ends_s if e is not None]
        if len(ends) != len(self.ends_s) or not ends:
            return None
        costs = [b - a for a, b in itertools.pairwise(ends)]
        return sum(costs) / len(costs) if costs else ends[0]

    def iterations_left(self, done: int, spent: float | None, limit_s: float, cap: int) -> int:
        """Iterations still to come after ``done``: what ``limit_s`` affords, within ``cap``.

        Without a known cost or ``spent``, the cap alone decides.
        """
        by_cap = max(cap - done, 0)
        cost = self.cost_s()
        if spent is None or cost is None or cost <= 0:
            return by_cap
        return min(by_cap, max(math.floor((limit_s - spent) / cost), 0))

    def left_now(self, spent: float | None, limit_s: float, cap: int) -> int:
        """Iterations the run can still start, with ``spent`` seconds spent now."""
        return self.iterations_left(len(self.ends_s), spent, limit_s, cap)

    def refuse(self, spent: float | None, cost: float | None, limit_s: float) -> str | None:
        """Why a measurement costing ``cost`` seconds must not start, ``spent`` being spent.

        None while it ends inside ``limit_s`` (or nothing tells what was spent).
        """
        if spent is None:
            return None
        ends = spent + (cost or 0.0)
        if ends <= limit_s and spent < limit_s:
            return None
        key = "max_bench_minutes" if self.minutes is not None else "max_bench_minutes, unset"
        return (
            f"the bench-time budget of {minutes(limit_s)} min ([tuning] {key}) is spent: "
            f"{minutes(spent)} min measured, the next measurement would end at {minutes(ends)} min"
        )

    def describe(self, spent: float | None, limit_s: float) -> str:
        """``bench time 12.4 of 60 min (47.6 left)``, or the budget alone when not known."""
        if spent is None:
            return f"bench time not known yet (budget {minutes(limit_s)} min)"
        return (
            f"bench time {minutes(spent)} of {minutes(limit_s)} min "
            f"({minutes(max(limit_s - spent, 0.0))} left)"
        )
