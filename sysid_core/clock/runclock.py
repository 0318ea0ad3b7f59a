"""The run's bench clock: the seconds its measurements cost, what it has spent, what it may spend.

One object answers every question a run asks of time (:class:`RunClock`):

* the dwell per acquisition and the settling after a bias change, each the device's own
  (its checked capabilities, :mod:`sysid_core.device.capabilities`), else the configuration's
  (``[experiment] dwell_s``, ``settle_s``), else estimated from the latest fit's Q
  (:mod:`sysid_core.clock.benchtime`);
* the bench time spent: the device clock's span when every measurement was time-stamped
  (the stamps are checked once, :class:`~sysid_core.clock.bench.Bench`), else the estimate;
* the budget (:class:`~sysid_core.clock.budget.Budget`): a measurement that would end past it is
  refused (:class:`~sysid_core.errors.BudgetSpentError`), and the iterations it still affords
  are what the look-ahead verdicts count.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
import xarray as xr

from sysid_core.clock.bench import Bench
from sysid_core.clock.benchtime import dwell, settle
from sysid_core.clock.budget import Budget, minutes, spent_s
from sysid_core.device.capabilities import Capabilities
from sysid_core.errors import BudgetSpentError
from sysid_core.model.fitted import FittedModel

__all__ = ["RunClock", "Seconds", "stamps", "stamps_span_s"]


def stamps(ds: xr.Dataset) -> np.ndarray:
    """A sweep's (or data set's) finite time stamps (seconds, the bench clock), flat.

    Empty without ``time_s``; NaN marks a point of unknown time (a frequency a sweep of a data
    set did not measure) and is left out. The one reader of time stamps in a run: each stamp a
    device gives is checked finite, and each measurement's first stamp no earlier than the last
    one's before it (:class:`~sysid_core.clock.bench.Bench`).
    """
    if "time_s" not in ds:
        return np.array([])
    t = np.asarray(ds["time_s"].values, dtype=float).ravel()
    return t[np.isfinite(t)]


def stamps_span_s(ds: xr.Dataset) -> float | None:
    """The span of ``ds``'s time stamps (seconds), or None without any."""
    t = stamps(ds)
    return float(np.ptp(t)) if t.size else None


#: Seconds, and where they come from (``"device"``, ``"config"``, ``"estimated ..."``), or
#: ``(None, None)`` when nothing says.
Seconds = tuple[float | None, str | None]


@dataclass
class RunClock:
    """A run's bench clock (see the module).

    Parameters
    ----------
    bench : Bench
        The run's bench: its counts and its device's time stamps.
    configured : (float or None, float or None)
        ``[experiment] dwell_s`` and ``settle_s`` (None: not set).
    budget : Budget
        The bench-time budget.
    """

    bench: Bench
    configured: tuple[float | None, float | None]
    budget: Budget
    #: The latest fitted model, whose Q estimates what neither device nor configuration states.
    latest: FittedModel | None = field(default=None)

    @property
    def caps(self) -> Capabilities:
        """What the device states of its bench, checked once."""
        return self.bench.device.capabilities

    def saw(self, model: FittedModel) -> None:
        """Estimate from ``model`` (the run's latest fit) what nothing else states."""
        self.latest = model

    def rates(self, model: FittedModel | None = None) -> tuple[Seconds, Seconds]:
        """The dwell per acquisition and the settling after a bias change, with their sources.

        Estimated from ``model`` (default: the latest fit) where neither the device nor the
        configuration states them.
        """
        model = model or self.latest
        return (
            dwell(self.caps, self.configured[0], model),
            settle(self.caps, self.configured[1], model),
        )

    def settle_s(self, model: FittedModel | None = None) -> float:
        """The settling after a bias change (seconds; 0 when nothing says)."""
        return float(self.rates(model)[1][0] or 0.0)

    def sweep_s(self, n_points: int, bias_change: bool = True) -> float:
        """What a sweep of ``n_points`` would take (seconds), settling after a bias change included.

        In acquisitions (a dwell of 1) while nothing states or estimates the dwell: a cost to
        compare with another's, not a time.
        """
        n = self.bench.acquisitions_for(n_points)
        cost = _cost_s(n, bias_change, self.rates())
        return float(n) if cost is None else cost

    def afford(self, n_points: int) -> tuple[int, float]:
        """How many more windows of ``n_points`` the run can measure, and the seconds of each.

        Called during an iteration (before :meth:`Budget.ended` records it): the iterations the
        cap leaves after this one, and no more windows than the budget left holds, each with
        the settling after a bias change (:meth:`sweep_s`).
        """
        each = self.sweep_s(n_points)
        by_cap = max(self.cap - len(self.budget.ends_s) - 1, 0)
        spent = self.spent_s()
        if spent is None or each <= 0:
            return by_cap, each
        return min(by_cap, max(int((self.limit_s - spent) // each), 0)), each

    def spent_s(self, rates: tuple[Seconds, Seconds] | None = None) -> float | None:
        """The bench time spent so far (seconds; the clock's, else estimated), or None.

        ``rates``: :meth:`rates`, when the caller has them.
        """
        (dwell_s, _), (settle_s, _) = rates or self.rates()
        b = self.bench
        return spent_s(b.clock_span_s, b.acquisitions, b.bias_changes, dwell_s, settle_s)

    @property
    def limit_s(self) -> float:
        """The budget in seconds (the configured one, else the gyro's own: its dwell's)."""
        return self.budget.limit_s(self.rates()[0][0])

    def binds(self, rates: tuple[Seconds, Seconds]) -> bool:
        """:attr:`binding`, with the dwell's source from ``rates``."""
        b = self.bench
        clock = b.measurements > 0 and b.clock_span_s is not None
        return clock or rates[0][1] in ("device", "config")

    @property
    def binding(self) -> bool:
        """Whether the budget stops the run: its bench time is known, not guessed.

        Known: every measurement so far carried time stamps (a clock), or the dwell per
        acquisition is stated (the device's ``dwell_s`` or ``[experiment] dwell_s``). A dwell
        estimated from the fitted Q (``5 Q/ω``) can be off severalfold (the analyzer's
        bandwidth decides), so a run without a clock or a stated dwell reports its estimated
        bench time against the budget and plans with it, but is not stopped by it.
        """
        return self.binds(self.rates())

    def guard(self, n_acquisitions: int, bias_changes: bool) -> None:
        """Refuse a measurement of ``n_acquisitions`` that would end past a binding budget.

        Raises
        ------
        BudgetSpentError
            Saying what was spent and where the measurement would end.
        """
        rates = self.rates()  # one estimate from the latest fit for the whole check
        if not self.binds(rates):
            return
        cost = _cost_s(n_acquisitions, bias_changes, rates)
        why = self.budget.refuse(self.spent_s(rates), cost, self.budget.limit_s(rates[0][0]))
        if why is not None:
            raise BudgetSpentError(why)

    def left(self) -> int:
        """Iterations the run can still start (the budget's, within the cap).

        Where the budget does not bind (:attr:`binding`), its estimated bench time still plans.
        """
        return self.budget.left_now(self.spent_s(), self.limit_s, self.cap)

    @property
    def cap(self) -> int:
        """The most iterations (``[tuning] max_iterations``, else its default)."""
        return self.budget.cap

    def describe(self, spent: float | None) -> str:
        """What the run spent of its budget, for the progress (estimated where not binding).

        On a clock, also what it spent the time on
        (:func:`sysid_core.clock.bench.purpose_of`).
        """
        if self.binding or spent is None:
            parts = self.bench.by_purpose if self.bench.clock_span_s is not None else {}
            said = ", ".join(f"{k} {minutes(v)}" for k, v in parts.items() if v > 0)
            settling = minutes(self.bench.settling_s)
            on = f"; {said} min ({settling} min of it settling)" if said else ""
            return self.budget.describe(spent, self.limit_s) + on
        return (
            f"bench time about {minutes(spent)} min, estimated from the fitted Q (the budget of "
            f"{minutes(self.limit_s)} min binds a run on a clock or with a stated dwell)"
        )


def _cost_s(n_acquisitions: int, bias_change: bool, rates: tuple[Seconds, Seconds]) -> float | None:
    """Seconds of ``n_acquisitions`` at ``rates``, and the settling after a bias change.

    None while nothing states or estimates the dwell.
    """
    (dwell_s, _), (settle_s, _) = rates
    if dwell_s is None:
        return None
    return n_acquisitions * dwell_s + ((settle_s or 0.0) if bias_change else 0.0)
