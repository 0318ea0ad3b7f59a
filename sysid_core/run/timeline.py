"""The split over the bench clock (``drift.png``): what a run saw in time, and what it predicted.

One point per iteration, at the bench time spent by the end of its verification (the device's
clock, else the estimate): the split the verification measured with its 95 % interval (from
the window's own fit), the 95 % range the model predicted for it when the answer was solved
(the tracked model moved to the verification's time on a drifting bench), on a tracked run the
95 % bound of the split its windows predict for that window's end (the verdict's goal,
docs/drift-model.md), the acceptance, and the bench-time budget. On a drifting bench the gap
between the predicted range and the measured split is what the drift did that the model did
not foresee.
"""

from __future__ import annotations

import os
from collections.abc import Sequence
from pathlib import Path
from typing import TYPE_CHECKING

from sysid_core.run.plots import save_figure
from sysid_core.verdict.judgement import END_GOAL

if TYPE_CHECKING:
    from matplotlib.figure import Figure

    from sysid_core.run.record import IterationRecord

__all__ = ["plot_timeline", "timeline_figure"]


def timeline_figure(
    history: Sequence[IterationRecord],
    acceptance_hz: float | None = None,
    budget_s: float | None = None,
    clock: bool = True,
) -> Figure:
    """The measured and predicted splits of ``history`` over the bench time (minutes).

    Iterations whose bench time is not known are left out; ``clock`` says whether the times
    are the device clock's (else estimated).
    """
    from matplotlib.figure import Figure

    fig = Figure(figsize=(8.0, 4.2), layout="constrained")
    ax = fig.subplots()
    floor = 1e-2 * (acceptance_hz or 1e-3) * 1e3  # mHz: a split of 0 sits here
    shown = [h for h in history if h.bench_time_s is not None]
    for k, h in enumerate(shown):
        t = float(h.bench_time_s or 0.0) / 60.0
        ci = h.tuning.get("split_ci_hz")
        if ci is not None:
            lo, hi = (max(1e3 * float(v), floor) for v in ci)
            ax.plot(
                [t, t],
                [lo, hi],
                "-",
                color="tab:orange",
                lw=7,
                alpha=0.45,
                solid_capstyle="butt",
                label="predicted at the answer (95 %)" if k == 0 else None,
            )
        if h.measured_split_hz is None:
            ax.plot(
                [t],
                [floor],
                "x",
                color="tab:red",
                label="not verified"
                if not any(g.measured_split_hz is None for g in shown[:k])
                else None,
            )
            continue
        y = max(1e3 * h.measured_split_hz, floor)
        if h.measured_split_ci_hz is not None:
            lo, hi = (max(1e3 * v, floor) for v in h.measured_split_ci_hz)
            yerr = [[y - min(lo, y)], [max(hi, y) - y]]
        else:
            yerr = None
        ax.errorbar(
            [t],
            [y],
            yerr=yerr,
            fmt="o",
            color="tab:blue",
            capsize=3,
            label="measured (95 % interval)"
            if not any(g.measured_split_hz is not None for g in shown[:k])
            else None,
        )
        ax.annotate(str(h.iteration), (t, y), textcoords="offset points", xytext=(4, 4), fontsize=7)
    # the tracked windows' forecast of the split at each window's end: its 95 % bound
    ends = [
        (float(h.bench_time_s or 0.0) / 60.0, max(1e3 * float(g["value_hz"]), floor))
        for h in shown
        for g in h.goals
        if g.get("name") == END_GOAL
    ]
    if ends:
        ax.plot(
            *zip(*ends, strict=True),
            "v",
            color="tab:purple",
            mfc="none",
            ms=10,
            zorder=3,
            label="the windows' forecast at the end (95 % bound)",
        )
    if acceptance_hz is not None:
        ax.axhline(
            acceptance_hz * 1e3,
            color="tab:green",
            ls="--",
            lw=1,
            label=f"acceptance {acceptance_hz * 1e3:.3g} mHz",
        )
    end_min = max((float(h.bench_time_s or 0.0) for h in shown), default=0.0) / 60.0
    if budget_s is not None and budget_s / 60.0 <= 3.0 * max(end_min, 1e-9):
        ax.axvline(
            budget_s / 60.0, color="0.3", ls=":", lw=1, label=f"budget {budget_s / 60:.3g} min"
        )
    elif budget_s is not None:  # far beyond the run: said, not drawn (the run would be a sliver)
        ax.plot([], [], " ", label=f"budget {budget_s / 60:.3g} min (not reached)")
    ax.set_yscale("log")
    ax.set_xlabel(f"bench time (min, {'the device clock' if clock else 'estimated'})")
    ax.set_ylabel("split (mHz)")
    ax.set_title("the split over the bench clock: measured at each verification, and predicted")
    ax.grid(True, which="both", alpha=0.3)
    if shown:
        ax.legend(fontsize=8, loc="best")
    return fig


def plot_timeline(
    history: Sequence[IterationRecord],
    path: str | os.PathLike[str],
    acceptance_hz: float | None = None,
    budget_s: float | None = None,
    clock: bool = True,
) -> Path:
    """:func:`timeline_figure` written to ``path``."""
    return save_figure(timeline_figure(history, acceptance_hz, budget_s, clock), path)
