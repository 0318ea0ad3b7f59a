"""A drifting-bench run against the truth: what each verification measured and what was so.

    python examples/truth_along_run.py runs/lab-501/gyro522 --seed 522 --bench lab
    python examples/truth_along_run.py runs/lab-501 --coverage --bench lab

For one gyro of ``examples/drift_population.py`` (its run folder, and the seed, bench and
draw it was tuned with), a replica of its device (the same seeds) is asked, at the run's time
stamps in order, for the TRUE split. Per verification: the split its window measured, the
true split at the window's middle, and the true split at the same bias an iteration earlier
(at the middle of the previous window: the answer's own miss, before the drift between the
two windows). The temperature's random walk of the replica is another draw (the split moves
by its differential tempco, 0.5 ppm/K, about 0.5 mHz per kelvin at 1 kHz); the ramp and the
charging are the run's.

``--coverage`` takes a population's folder instead (every ``gyroNNN`` in it, the seed from the
name): per verdict of a tracked run, the bound its goal put on the split at the window's end
(the 95 % point of the windows' forecast, ``docs/drift-model.md``) beside the true split there,
tabled by the bound: how often the bound holds the truth, and how often the truth is over the
acceptance where the bound says it is under.

``--slopes`` prints instead, per iteration, how the split vector (its length the split, its
direction the modes' orientation: ``examples/window_replay.py``) moves per volt of B1 and of
B2 at the iteration's answer: the slopes of that iteration's fit (``model.nc``, its stiffness
law, and whether it carries the trend of a long run) beside the truth's at the window's middle.
"""

from __future__ import annotations

import argparse
import itertools
import json
from pathlib import Path

import numpy as np
import xarray as xr
from drift_population import BENCHES, make_device
from window_replay import split_vector

from sysid_core.api import load_model

#: The bias step of the slopes' central differences (V).
SLOPE_STEP_V = 0.01


def window_times(folder: Path) -> tuple[float, float] | None:
    """The first and last time stamps of an iteration's verification sweeps, or None."""
    stamps = []
    for path in sorted(folder.glob("verify*.nc")):
        if "model" in path.name:
            continue
        with xr.open_dataset(path) as ds:
            if "time_s" in ds:
                stamps.append(np.asarray(ds["time_s"].values, dtype=float))
    if not stamps:
        return None
    return min(float(t.min()) for t in stamps), max(float(t.max()) for t in stamps)


def rows(run: Path, seed: int, bench: str, draw: int = 0, start_min: float = 0.0) -> list[dict]:
    """One record per verification with a window (see the module)."""
    summary = json.loads((run / "summary.json").read_text())
    device, _ = make_device(seed, bench, draw=draw, start_min=start_min)
    found, previous = [], None
    for record in summary["history"]:
        it = int(record["iteration"])
        times = window_times(run / f"iter{it:02d}")
        if times is None:
            continue
        middle = 0.5 * (times[0] + times[1])
        bias = record["verified_bias"]
        earlier = None if previous is None else device.true_split_hz(bias, at_s=previous)
        measured = record["measured_split_hz"]
        found.append(
            {
                "iteration": it,
                "verification": record["verification"],
                "hours": (times[0] / 3600, times[1] / 3600),
                "measured_mhz": None if measured is None else measured * 1e3,
                "true_mhz": device.true_split_hz(bias, at_s=middle) * 1e3,
                "true_earlier_mhz": None if earlier is None else earlier * 1e3,
            }
        )
        previous = middle
    return found


#: The goal whose bound ``--coverage`` reads (``sysid_core.verdict.judgement.END_GOAL``).
END_GOAL = "split at the end, 95 % by the windows' forecast"
#: The bounds ``--coverage`` tables (mHz): each row from one edge to the next.
COVERAGE_EDGES_MHZ = (0.0, 1.0, 2.0, 3.0, 6.0, float("inf"))


def coverage(population: Path, bench: str, draw: int = 0, start_min: float = 0.0) -> list[dict]:
    """Per verdict with the forecast's goal in ``population``: its bound and the truth then.

    Each record: the seed, the iteration, the goal's bound (mHz), the true split at the last
    time stamp of the window at its bias (mHz), the window's own reading (mHz, or None),
    whether every goal was met (converged), and the goal's limit (mHz).
    """
    found = []
    for run in sorted(population.glob("gyro*")):
        if not (run / "summary.json").is_file():
            continue
        seed = int(run.name.removeprefix("gyro"))
        summary = json.loads((run / "summary.json").read_text())
        device, _ = make_device(seed, bench, draw=draw, start_min=start_min)
        for record in summary["history"]:
            goal = next((g for g in record["goals"] if g["name"] == END_GOAL), None)
            times = window_times(run / f"iter{int(record['iteration']):02d}")
            if goal is None or times is None:
                continue
            measured = record["measured_split_hz"]
            found.append(
                {
                    "seed": seed,
                    "iteration": int(record["iteration"]),
                    "bound_mhz": goal["value_hz"] * 1e3,
                    "limit_mhz": goal["limit_hz"] * 1e3,
                    "true_mhz": device.true_split_hz(record["verified_bias"], at_s=times[1]) * 1e3,
                    "measured_mhz": None if measured is None else measured * 1e3,
                    "converged": all(g["met"] for g in record["goals"]),
                }
            )
    return found


def coverage_table(found: list[dict]) -> list[str]:
    """``--coverage``'s table: per range of the bound, how often it holds the truth."""
    lines = [
        "| bound (mHz) | verdicts | truth under the bound | truth over the goal's limit |",
        "|---|---|---|---|",
    ]
    for lo, hi in itertools.pairwise(COVERAGE_EDGES_MHZ):
        rows_in = [r for r in found if lo <= r["bound_mhz"] < hi]
        if not rows_in:
            continue
        held = np.mean([r["true_mhz"] <= r["bound_mhz"] for r in rows_in])
        over = np.mean([r["true_mhz"] > r["limit_mhz"] for r in rows_in])
        lines.append(f"| {lo:g}-{hi:g} | {len(rows_in)} | {held:.1%} | {over:.1%} |")
    claims = [r for r in found if r["converged"]]
    wrong = sum(r["true_mhz"] > r["limit_mhz"] for r in claims)
    lines.append(f"\n{len(claims)} verdicts converged; {wrong} with the truth over the limit")
    return lines


def slopes(run: Path, seed: int, bench: str, draw: int = 0) -> list[dict]:
    """Per iteration with a window, the split vector's slopes in B1 and B2 (mHz/V, columns):
    the iteration's fit's (``model``) and the truth's (``true``); see the module."""
    summary = json.loads((run / "summary.json").read_text())
    device, _ = make_device(seed, bench, draw=draw)
    found = []
    for record in summary["history"]:
        it = int(record["iteration"])
        times = window_times(run / f"iter{it:02d}")
        if times is None:
            continue
        model = load_model(run / f"iter{it:02d}" / "model.nc")
        bias = np.asarray(record["tuning"]["bias"], dtype=float)
        index = [list(summary["electrodes"]).index(e) for e in model.electrodes]
        tuned = bias[index]
        at = np.array([0.5 * (times[0] + times[1])])
        fitted, true = np.zeros((2, 2)), np.zeros((2, 2))
        for j in range(2):
            step = np.zeros(bias.size)
            step[index[j]] = SLOPE_STEP_V
            fitted[:, j] = (
                split_vector(model.M, model.stiffness(tuned + step[index]))
                - split_vector(model.M, model.stiffness(tuned - step[index]))
            ) / (2 * SLOPE_STEP_V)
            k_up = device._drifted_stiffness(bias + step, at)[0]
            k_down = device._drifted_stiffness(bias - step, at)[0]
            true[:, j] = (
                split_vector(device.truth.M, k_up) - split_vector(device.truth.M, k_down)
            ) / (2 * SLOPE_STEP_V)
        found.append(
            {
                "iteration": it,
                "law": str(model.meta.get("stiffness_law", model.structure.stiffness)),
                "trend": "drift_trend" in model.meta,
                "model": fitted,
                "true": true,
            }
        )
    return found


def main() -> None:
    """Parse the arguments and print the table."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument(
        "run",
        type=Path,
        help="the gyro's run folder (with summary.json), or with --coverage the population's",
    )
    parser.add_argument("--seed", type=int, help="the gyro's seed (not with --coverage)")
    parser.add_argument("--bench", choices=sorted(BENCHES), default="lab")
    parser.add_argument("--draw", type=int, default=0)
    parser.add_argument(
        "--start-min", type=float, default=0.0, help="as the population run was given (0)"
    )
    parser.add_argument(
        "--slopes", action="store_true", help="the split's slopes in B1 and B2, fit and truth"
    )
    parser.add_argument(
        "--coverage", action="store_true", help="a population's verdicts: bound against truth"
    )
    args = parser.parse_args()
    if args.coverage:
        found = coverage(args.run, args.bench, args.draw, args.start_min)
        if not found:
            parser.error(f"no tracked verdict in {args.run}/gyro*/summary.json")
        print("\n".join(coverage_table(found)))
        return
    if args.seed is None:
        parser.error("--seed is required (the seed the gyro was tuned with)")
    if not (args.run / "summary.json").is_file():
        parser.error(f"no summary.json in {args.run}; give a gyro's folder of drift_population")
    if args.slopes:
        print("| iteration | law | trend | fit: per V of B1, of B2 (mHz) | truth (mHz) |")
        print("|---|---|---|---|---|")
        for r in slopes(args.run, args.seed, args.bench, args.draw):
            fit, true = (
                ", ".join(f"({c[0]:.0f}, {c[1]:.0f})" for c in r[k].T) for k in ("model", "true")
            )
            trend = "yes" if r["trend"] else "no"
            print(f"| {r['iteration']} | {r['law']} | {trend} | {fit} | {true} |")
        return

    def mhz(v: float | None) -> str:
        return "-" if v is None else f"{v:.3g}"

    print("| iteration | window (h) | measured (mHz) | true, window's middle | true, earlier |")
    print("|---|---|---|---|---|")
    for r in rows(args.run, args.seed, args.bench, args.draw, args.start_min):
        lo, hi = r["hours"]
        print(
            f"| {r['iteration']} ({r['verification']}) | {lo:.2f}-{hi:.2f} | "
            f"{mhz(r['measured_mhz'])} | {mhz(r['true_mhz'])} | {mhz(r['true_earlier_mhz'])} |"
        )


if __name__ == "__main__":
    main()
