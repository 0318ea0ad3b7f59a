"""Plot populations of drifting-bench runs: each gyro's true end split and bench time.

    python examples/population_plot.py runs/lab-101 runs/lab-301 --out lab-population.png

Each argument is the ``--out`` folder of ``examples/drift_population.py`` (its
``runs.jsonl``), or that file itself. Left: every gyro's TRUE split at the end of its run
against its frequency, the acceptance as a dashed line, a filled marker where the run claimed
convergence and an open one where it did not. Right: the run's bench time by the clock. A run
that ended with an error is counted in the legend, not drawn. The title says how many runs end
within the acceptance.
"""

from __future__ import annotations

import argparse
import json
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt
from matplotlib.ticker import FixedLocator, NullFormatter, ScalarFormatter

ACCEPTANCE_MHZ = 2.0


def read_runs(
    path: Path, script: str = "population_plot", maker: str = "drift_population"
) -> list[dict]:
    """The records of one population (a folder with ``runs.jsonl``, or the file).

    ``script`` and ``maker`` name this script and the one whose ``--out`` it reads, for the
    one-line refusal of a path without ``runs.jsonl``.
    """
    file = path / "runs.jsonl" if path.is_dir() else path
    if not file.is_file():
        raise SystemExit(f"{script}: no runs.jsonl at {path}; give {maker}'s --out")
    return [json.loads(line) for line in file.read_text().splitlines() if line.strip()]


def labelled_runs(
    parser: argparse.ArgumentParser,
    args: argparse.Namespace,
    script: str = "population_plot",
    maker: str = "drift_population",
) -> dict[str, list[dict]]:
    """Each population's records under its label (``--labels``, else its folder's name)."""
    labels = args.labels or [p.name if p.is_dir() else p.parent.name for p in args.runs]
    if len(labels) != len(args.runs):
        parser.error(f"--labels gives {len(labels)} labels for {len(args.runs)} populations")
    return {lab: read_runs(p, script, maker) for lab, p in zip(labels, args.runs, strict=True)}


def plot_population(
    populations: dict[str, list[dict]], out: Path, acceptance_mhz: float = ACCEPTANCE_MHZ
) -> tuple[int, int]:
    """Draw the figure to ``out``; return (runs within the acceptance, runs)."""
    fig, (left, right) = plt.subplots(1, 2, figsize=(11, 4.8), constrained_layout=True)
    within = total = 0
    for k, (label, records) in enumerate(populations.items()):
        color = f"C{k}"
        ok = [r for r in records if "error" not in r]
        errors = len(records) - len(ok)
        total += len(records)
        within += sum(r["true_end_split_hz"] * 1e3 <= acceptance_mhz for r in ok)
        for claimed in (True, False):
            rs = [r for r in ok if bool(r["converged"]) is claimed]
            if not rs:
                continue
            f = [r["frequency_hz"] / 1e3 for r in rs]
            face = color if claimed else "none"
            name = f"{label}{' (converged)' if claimed else ''}"
            if errors and claimed:
                name += f", {errors} error(s)"
            left.scatter(
                f,
                [r["true_end_split_hz"] * 1e3 for r in rs],
                s=28,
                facecolors=face,
                edgecolors=color,
                label=name,
            )
            right.scatter(
                f,
                [r["bench_time_s"] / 3600 for r in rs],
                s=28,
                facecolors=face,
                edgecolors=color,
            )
    left.axhline(acceptance_mhz, color="k", ls="--", lw=1)
    left.text(1.02, acceptance_mhz * 1.08, f"acceptance {acceptance_mhz:g} mHz", fontsize=8)
    for ax in (left, right):
        ax.set_xscale("log")
        ax.set_yscale("log")
        ax.set_xlabel("gyro frequency (kHz)")
        ax.grid(True, which="both", alpha=0.3)
        ax.xaxis.set_major_locator(FixedLocator([1, 2, 5, 10, 20, 50]))
        ax.xaxis.set_major_formatter(ScalarFormatter())
        ax.xaxis.set_minor_formatter(NullFormatter())
    left.set_ylabel("TRUE split at the end of the run (mHz)")
    right.set_ylabel("bench time by the clock (h)")
    fig.legend(fontsize=8, loc="outside lower center", ncol=4)
    left.set_title(
        f"{within} of {total} runs end within {acceptance_mhz:g} mHz (open: not converged)"
    )
    right.set_title("time the run took")
    fig.savefig(out, dpi=110)
    plt.close(fig)
    return within, total


def main() -> None:
    """Parse the arguments and draw."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("runs", nargs="+", type=Path, help="drift_population --out folders")
    parser.add_argument("--labels", nargs="+", default=None, help="one per folder (its name)")
    parser.add_argument("--acceptance", type=float, default=ACCEPTANCE_MHZ, help="mHz (2)")
    parser.add_argument("--out", type=Path, default=Path("population.png"))
    args = parser.parse_args()
    populations = labelled_runs(parser, args)
    within, total = plot_population(populations, args.out, args.acceptance)
    print(f"{within} of {total} runs end within {args.acceptance:g} mHz; figure in {args.out}")


if __name__ == "__main__":
    main()
