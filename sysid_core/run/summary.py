"""What a tuning run reports: each iteration's verification, record, and the run's summary.

:class:`RunSummary` is what ``summary.json`` holds and the ``sysid tune --json`` line shows
(without ``history``): the keys of the public contract (``docs/contracts.md``) and more.
"""

from __future__ import annotations

import dataclasses
import os
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from sysid_core.clock.bench import Bench
from sysid_core.clock.budget import spent_s
from sysid_core.data.io import write_json
from sysid_core.measure.verification import Verification
from sysid_core.run.record import (
    IterationRecord,
    Least,
    latest_measured,
    least_measured,
    verified_splits,
)
from sysid_core.tuning.criteria import BiasSpace, ConfidenceRegion, Goal
from sysid_core.verdict.dacfloor import dac_floor

__all__ = [
    "CONFIDENCE_KEYS",
    "DAC_LIMITS",
    "IterationRecord",
    "Least",
    "RunSummary",
    "latest_measured",
    "least_measured",
    "status_line",
    "summarize",
    "verified_splits",
]

#: The confidence region's keys in ``summary.json`` and the ``--json`` line.
CONFIDENCE_KEYS = ("confidence_level", "bias_ci", "split_ci_hz", "frequency_ci_hz")
#: What the status of a run that did not converge says when the DAC limits its last answer.
DAC_LIMITS = "the DAC limits it"


@dataclass
class RunSummary:
    """The result of a tuning run (what ``summary.json`` and ``--json`` report).

    ``split_hz`` and ``frequency_hz`` are those of the last verification, or None when it did
    not verify them; ``converged`` is true only when the last verification was verified and
    every goal in ``goals`` is met; ``status`` says so in one sentence. ``notes`` lists what
    the identification fits found suspicious (:func:`sysid_core.identification.fitting.check_fit`),
    e.g. modes of a stepped experiment outside its window. ``confidence`` holds the last answer's
    confidence region (:meth:`sysid_core.tuning.criteria.ConfidenceRegion.as_dict`:
    ``confidence_level``, ``bias_ci``, ``split_ci_hz``, ``frequency_ci_hz``), or None when the fit
    states no covariance (``minimax``); :meth:`as_dict` puts its keys at the top level (None when
    missing).
    """

    device: str
    bias: list[float]
    split_hz: float | None
    frequency_hz: float | None
    iterations: int
    experiments: int
    converged: bool
    verified: bool
    status: str
    goals: list[dict[str, Any]]
    electrodes: list[str]
    tuned: list[str]
    history: list[IterationRecord] = field(default_factory=list)
    notes: list[str] = field(default_factory=list)
    out: str = ""
    confidence: dict[str, Any] | None = None
    points: int = 0
    acquisitions: int = 0
    settle_s: float | None = None
    settle_source: str | None = None
    bench_time_estimate_s: float | None = None
    bench_time_s: float | None = None
    dwell_s: float | None = None
    dwell_source: str | None = None
    bench_time_source: str | None = None
    drift_common_hz_per_h: float | None = None
    drift_split_hz_per_h: float | None = None
    #: Why the run stopped before meeting its goals (the bench-time budget, a drift that
    #: outruns the verification, the floor a bench sets at the last iteration), or None.
    stopped: str | None = None
    #: The bench-time budget (``[tuning] max_bench_minutes``, seconds).
    bench_budget_s: float | None = None
    #: The bench clock by purpose (design, verification, locating, repeats, other) and as
    #: settling against acquiring (seconds; on a clock only, else None).
    bench_time_by_purpose_s: dict[str, float] | None = None
    bench_time_split_s: dict[str, float] | None = None

    @classmethod
    def start(cls, device: str, bias: np.ndarray, space: BiasSpace, out: str) -> RunSummary:
        """The summary of a run that has not run an iteration yet."""
        return cls(
            device=device,
            bias=bias.tolist(),
            split_hz=None,
            frequency_hz=None,
            iterations=0,
            experiments=0,
            converged=False,
            verified=False,
            status="not started",
            goals=[],
            electrodes=list(space.electrodes),
            tuned=list(space.tuned),
            out=out,
        )

    def stopped_by(
        self, why: str, notes: list[str], spent_s: float | None, bench: Bench
    ) -> RunSummary:
        """The summary ended early for ``why``.

        With the run's ``notes``, bench time and the counts of its ``bench`` as they are now.
        """
        by_purpose, split = _clock_parts(bench)
        return dataclasses.replace(
            self,
            notes=list(notes),
            stopped=why,
            status=f"{self.status}; stopped: {why}",
            bench_time_s=spent_s if spent_s is not None else self.bench_time_s,
            experiments=bench.measurements,
            points=bench.points,
            acquisitions=bench.acquisitions,
            bench_time_by_purpose_s=by_purpose,
            bench_time_split_s=split,
        )

    @property
    def paths(self) -> dict[str, Any]:
        """The run's files: ``out``, ``summary``, ``config``, ``bias_path`` and ``iterations``.

        ``bias_path`` is the plot, if written, in whichever format; ``iterations`` has one folder
        per iteration, holding its measurements, model and plots.
        """
        out = Path(self.out)
        plots = sorted(out.glob("bias_path.*"))
        return {
            "out": out,
            "summary": out / "summary.json",
            "config": out / "config.json",
            "bias_path": plots[0] if plots else None,
            "iterations": [out / f"iter{r.iteration:02d}" for r in self.history],
        }

    def as_dict(self) -> dict[str, Any]:
        """JSON-friendly form."""
        return {
            "device": self.device,
            "bias": self.bias,
            "split_hz": self.split_hz,
            "frequency_hz": self.frequency_hz,
            "iterations": self.iterations,
            "experiments": self.experiments,
            "points": self.points,
            "bench_time_s": self.bench_time_s,
            "dwell_s": self.dwell_s,
            "dwell_source": self.dwell_source,
            "bench_time_source": self.bench_time_source,
            "bench_time_estimate_s": self.bench_time_estimate_s,
            "acquisitions": self.acquisitions,
            "settle_s": self.settle_s,
            "settle_source": self.settle_source,
            "drift_common_hz_per_h": self.drift_common_hz_per_h,
            "drift_split_hz_per_h": self.drift_split_hz_per_h,
            "bench_budget_s": self.bench_budget_s,
            "bench_time_by_purpose_s": self.bench_time_by_purpose_s,
            "bench_time_split_s": self.bench_time_split_s,
            "converged": self.converged,
            "stopped": self.stopped,
            "verified": self.verified,
            "status": self.status,
            "goals": self.goals,
            "electrodes": self.electrodes,
            "tuned": self.tuned,
            **{key: (self.confidence or {}).get(key) for key in CONFIDENCE_KEYS},
            "out": self.out,
            "notes": self.notes,
            "history": [r.as_dict() for r in self.history],
        }

    def save(self, path: str | os.PathLike[str]) -> Path:
        """Write :meth:`as_dict` to ``path`` (``summary.json``), atomically.

        Indented, with one line per ``history`` record, each encoded once.
        """
        top = {k: v for k, v in self.as_dict().items() if k != "history"}
        return write_json(path, top, {"history": [r.json for r in self.history]})


def status_line(
    it: int,
    ver: Verification,
    goals: list[Goal],
    converged: bool,
    dac_floor_hz: float | None = None,
) -> str:
    """One sentence on how a run stands after iteration ``it``.

    ``dac_floor_hz``: the split the model predicts at the last answer's DAC code when the DAC
    limits it (:func:`sysid_core.verdict.dacfloor.dac_floor`), said with goals not met.
    """
    if converged:
        return f"converged after {it} iteration(s): {ver.describe()}; goals met: " + ", ".join(
            str(g) for g in goals
        )
    if not ver.verified:
        return f"NOT converged after {it} iteration(s): not verified, {ver.describe()}"
    dac = (
        ""
        if dac_floor_hz is None
        else f"; {DAC_LIMITS}: its best code there is predicted to leave "
        f"{dac_floor_hz * 1e3:.3g} mHz"
    )
    return (
        f"NOT converged after {it} iteration(s): {ver.describe()}; goals not met: "
        + ", ".join(str(g) for g in goals if not g.met)
        + dac
    )


def summarize(
    before: RunSummary,
    history: list[IterationRecord],
    ver: Verification,
    goals: list[Goal],
    converged: bool,
    *,
    bench: Bench,
    rates: tuple[tuple[float | None, str | None], tuple[float | None, str | None]],
    confidence: ConfidenceRegion | None,
    notes: list[str],
    drift: tuple[float | None, float | None] = (None, None),
    budget_s: float | None = None,
    tuned: list[str] | None = None,
) -> RunSummary:
    """The run's summary after the last iteration of ``history`` (a new object).

    ``ver`` and ``goals`` are that iteration's verification and goals; ``bench`` counts what
    was measured; ``rates`` are the dwell per acquisition and the settling, each with where it
    comes from (:meth:`sysid_core.clock.runclock.RunClock.rates`): the bench time is the device
    clock's span when every measurement carried time stamps (``bench_time_source =
    "clock"``), plus what comes before the first stamp (the settling and the first
    acquisition, as far as they are known), else the estimate ``acquisitions × dwell +
    bias_changes × settle_s`` (``"estimate"``; without ``settle_s`` the bias changes are not
    counted); :func:`sysid_core.clock.budget.spent_s`. ``drift``: the common and split drift
    rates found (Hz per hour); ``budget_s``: the bench-time budget; ``tuned``: the electrodes
    the run tunes, when a pair of them was chosen after the start.
    """
    last = history[-1]
    (dwell_s, dwell_source), (settle_s, settle_source) = rates
    n_acq, bias_changes, clock_span_s = bench.acquisitions, bench.bias_changes, bench.clock_span_s
    points, measurements = bench.points, bench.measurements
    estimate = spent_s(None, n_acq, bias_changes, dwell_s, settle_s)
    by_purpose, split = _clock_parts(bench)
    return dataclasses.replace(
        before,
        tuned=list(before.tuned if tuned is None else tuned),
        bias=list(last.verified_bias),
        split_hz=ver.split_hz,
        frequency_hz=ver.frequency_hz,
        iterations=last.iteration,
        experiments=measurements,
        points=points,
        dwell_s=dwell_s,
        dwell_source=dwell_source,
        acquisitions=n_acq,
        settle_s=settle_s,
        settle_source=settle_source,
        bench_time_s=spent_s(clock_span_s, n_acq, bias_changes, dwell_s, settle_s),
        bench_time_estimate_s=estimate,
        bench_time_source=(
            "clock" if clock_span_s is not None else None if dwell_s is None else "estimate"
        ),
        converged=converged,
        verified=ver.verified,
        goals=[g.as_dict() for g in goals],
        confidence=None if confidence is None else confidence.as_dict(),
        status=status_line(
            last.iteration,
            ver,
            goals,
            converged,
            dac_floor(last.tuning, next((g.limit_hz for g in goals if g.name == "split"), None)),
        ),
        history=list(history),
        notes=list(notes),
        drift_common_hz_per_h=drift[0],
        drift_split_hz_per_h=drift[1],
        bench_budget_s=budget_s,
        bench_time_by_purpose_s=by_purpose,
        bench_time_split_s=split,
    )


def _clock_parts(bench: Bench) -> tuple[dict[str, float] | None, dict[str, float] | None]:
    """The bench clock by purpose and as settling against acquiring (None without a clock)."""
    if bench.clock_span_s is None:
        return None, None
    return dict(bench.by_purpose), {"settling": bench.settling_s, "acquiring": bench.acquiring_s}
