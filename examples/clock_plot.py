"""Plot populations of clocked runs: every run's time to 1 mHz, one row per population.

    python examples/clock_plot.py runs/clock-c1 runs/clock-c8 --labels "1 tone" "8 tones"

Each argument is the ``--out`` folder of ``examples/clock_population.py`` (its
``runs.jsonl``), or that file itself. Every run is a dot at the bench time (by the clock) at
which an answer was first verified with a TRUE split of at most 1 mHz; a run that never got
there is a cross at the right edge, marked "never". The median of each row is a bar, the lower
one of an even count as in the script's table (a row whose median run never got there has
none); a run that ended with an error is left out. ``--marks 5 15`` draws dashed lines at those
minutes (targets, say).
"""

from __future__ import annotations

import argparse
import math
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt
import numpy as np
import population_plot  # the same folder: the population scripts' shared reading
from matplotlib.ticker import FixedLocator, NullFormatter, ScalarFormatter


def read_runs(path: Path) -> list[dict]:
    """The records of one population (a folder with ``runs.jsonl``, or the file)."""
    return population_plot.read_runs(path, "clock_plot", "clock_population")


def minutes(record: dict) -> float:
    """The run's time to 1 mHz in minutes (infinite if it never got there)."""
    t = record.get("time_to_target_s")
    return math.inf if t is None else float(t) / 60.0


def plot_clock(
    populations: dict[str, list[dict]], out: Path, marks: list[float] | None = None
) -> list[float]:
    """Draw the figure to ``out``; return each row's median minutes (inf: never)."""
    rows = list(populations.items())
    finite = [m for _, rs in rows for m in map(minutes, rs) if math.isfinite(m)]
    hi = max(finite, default=10.0)
    never_at = hi * 2.5
    fig, ax = plt.subplots(figsize=(9, 0.55 * len(rows) + 1.6), constrained_layout=True)
    medians = []
    rng = np.random.default_rng(0)  # a vertical jitter, so that equal times stay apart
    for y, (_, records) in enumerate(rows):
        # the table's median (the lower one of an even count), a run with an error left out
        times = np.array([minutes(r) for r in records if "error" not in r])
        median = float(np.percentile(times, 50, method="lower")) if times.size else math.inf
        medians.append(median)
        jitter = rng.uniform(-0.18, 0.18, times.size)
        ok = np.isfinite(times)
        ax.scatter(times[ok], y + jitter[ok], s=16, color=f"C{y % 10}", alpha=0.8)
        if np.any(~ok):
            ax.scatter(
                np.full(int(np.sum(~ok)), never_at), y + jitter[~ok], marker="x", color="red"
            )
        if math.isfinite(median):
            ax.plot([median, median], [y - 0.32, y + 0.32], color="k", lw=2)
        reached = int(np.sum(ok))
        ax.text(never_at * 1.25, y, f"{reached}/{len(records)}", va="center", fontsize=8)
    for m in marks or []:
        ax.axvline(m, color="gray", ls="--", lw=1)
        ax.text(m * 1.04, -0.6, f"{m:g} min", fontsize=8, color="gray", va="bottom")
    ax.axvline(never_at / 1.4, color="k", lw=0.5)
    ax.set_xscale("log")
    lo = min(finite, default=1.0) / 1.5
    ax.set_xlim(lo, never_at * 2.0)
    grid = (0.1, 0.2, 0.5, 1, 2, 5, 10, 20, 50, 100, 200, 500)
    ticks = [t for t in grid if lo <= t <= never_at / 2]
    ax.xaxis.set_major_locator(FixedLocator([*ticks, never_at]))
    ax.xaxis.set_major_formatter(ScalarFormatter())
    ax.xaxis.set_minor_formatter(NullFormatter())
    labels = [f"{t:g}" for t in ticks] + ["never"]
    ax.set_xticks([*ticks, never_at], labels)
    ax.set_yticks(range(len(rows)), [label for label, _ in rows])
    ax.invert_yaxis()
    ax.set_xlabel("minutes to a true split of 1 mHz, by the clock (bar: median; right: reached)")
    ax.grid(True, axis="x", which="major", alpha=0.3)
    fig.savefig(out, dpi=110)
    plt.close(fig)
    return medians


def main() -> None:
    """Parse the arguments and draw."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("runs", nargs="+", type=Path, help="clock_population --out folders")
    parser.add_argument("--labels", nargs="+", default=None, help="one per folder (its name)")
    parser.add_argument("--marks", nargs="*", type=float, default=None, help="minutes to mark")
    parser.add_argument("--out", type=Path, default=Path("clock.png"))
    args = parser.parse_args()
    populations = population_plot.labelled_runs(parser, args, "clock_plot", "clock_population")
    medians = plot_clock(populations, args.out, args.marks)
    text = ", ".join(
        f"{lab} {'never' if math.isinf(m) else f'{m:.1f}'}"
        for lab, m in zip(populations, medians, strict=True)
    )
    print(f"median minutes to 1 mHz: {text}; figure in {args.out}")


if __name__ == "__main__":
    main()
