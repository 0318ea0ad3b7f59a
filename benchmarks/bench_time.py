"""Bench time of tuning protocols, from study runs: the table of docs/bench-time.md.

Reads the results of ``sysid study`` runs (one folder per protocol) and prints, per protocol,
how many frequency points and how much bench time each run needed until the TRUE split (the
simulated device's ground truth) was first at most ``--target-hz``, as a Markdown table with
ratios against the ``--reference`` protocol (measured the same way, on the same starts or
gyros). A run that never reached the target counts with all its points.

Usage::

    python benchmarks/bench_time.py runs/bench-time/full runs/bench-time/lean \\
        --reference full --target-hz 0.001

Each folder's name is the protocol's label. ``--json`` prints the numbers instead.
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path
from typing import Any

import numpy as np


def _runs(folder: Path) -> dict[str, dict[str, Any]]:
    """The successful runs of a study folder by start or gyro."""
    runs = {}
    for path in sorted((folder / "results").glob("*.json")):
        res = json.loads(path.read_text())
        if res.get("error") is None and res.get("iterations"):
            # the same start (grid position and start bias) or gyro (seed), whatever the model
            runs[f"{res['index']}:{res['seed']}:{res['start']}"] = res
    if not runs:
        sys.exit(f"bench_time: {folder} holds no successful study runs (results/*.json)")
    return runs


def to_target(run: dict[str, Any], target_hz: float) -> dict[str, Any]:
    """Points, bench time and iterations until the true split was first <= ``target_hz``."""
    # the dwell per point (a run's bench time also counts its settling since the estimate does)
    dwell = run.get("dwell_s") or (run.get("bench_time_s") or 0.0) / max(run.get("points") or 1, 1)
    dwell = dwell or None
    for it in run["iterations"]:
        if it["true_split_hz"] <= target_hz:
            points = it["points"]
            return {
                "reached": True,
                "points": points,
                "bench_time_s": None if dwell is None else points * dwell,
                "iterations": it["iteration"],
                "true_split_hz": it["true_split_hz"],
            }
    last = run["iterations"][-1]
    return {
        "reached": False,
        "points": last["points"],
        "bench_time_s": None if dwell is None else last["points"] * dwell,
        "iterations": last["iteration"],
        "true_split_hz": last["true_split_hz"],
    }


def summarize(
    folders: list[Path], reference: str | None, target_hz: float
) -> tuple[list[dict[str, Any]], str | None]:
    """One row per protocol; ``reference`` names the folder the ratios are against."""
    per = {f.name: {k: to_target(r, target_hz) for k, r in _runs(f).items()} for f in folders}
    finals = {
        f.name: [r["iterations"][-1]["true_split_hz"] for r in _runs(f).values()] for f in folders
    }
    ref = per.get(reference) if reference else None
    if reference and ref is None:
        sys.exit(f"bench_time: --reference {reference!r} is none of {', '.join(per)}")
    rows = []
    for name, runs in per.items():
        points = np.array([r["points"] for r in runs.values()], dtype=float)
        times = np.array([r["bench_time_s"] or np.nan for r in runs.values()], dtype=float)
        reached = sum(r["reached"] for r in runs.values())
        split = np.array([r["true_split_hz"] for r in runs.values()])
        row: dict[str, Any] = {
            "protocol": name,
            "runs": len(runs),
            "reached": reached,
            "median_points": float(np.median(points)),
            "max_points": float(points.max()),
            "median_bench_time_s": float(np.nanmedian(times)),
            "median_iterations": float(np.median([r["iterations"] for r in runs.values()])),
            "split_at_target_p50_hz": float(np.percentile(split, 50)),
            "split_at_target_max_hz": float(split.max()),
            "final_split_p50_hz": float(np.percentile(finals[name], 50)),
            "final_split_p90_hz": float(np.percentile(finals[name], 90)),
            "final_split_max_hz": float(np.max(finals[name])),
        }
        if ref is not None:
            common = [k for k in runs if k in ref]
            ratio = [
                runs[k]["bench_time_s"] / ref[k]["bench_time_s"]
                for k in common
                if runs[k]["bench_time_s"] and ref[k]["bench_time_s"]
            ]
            row["median_time_ratio"] = float(np.median(ratio)) if ratio else None
            row["time_ratio_of_medians"] = row["median_bench_time_s"] / float(
                np.nanmedian([r["bench_time_s"] or np.nan for r in ref.values()])
            )
            row["worse_than_reference"] = sum(
                1
                for k in common
                if runs[k]["points"] > ref[k]["points"]
                or (ref[k]["reached"] and not runs[k]["reached"])
            )
        rows.append(row)
    return rows, reference


def markdown(rows: list[dict[str, Any]], reference: str | None, target_hz: float) -> str:
    """The table of docs/bench-time.md."""
    t = f"{target_hz * 1e3:g} mHz"
    ref = reference or "reference"
    head = (
        f"| protocol | runs reaching {t} | points to {t}: median / max | bench time to {t}: "
        f"median (h) | × {ref} | runs needing more points than {ref} | iterations (median) "
        "| true split at the end: median / 90 % / max (mHz) |"
    )
    lines = [head, "|---|---|---|---|---|---|---|---|"]
    for r in rows:
        ratio = r.get("time_ratio_of_medians")
        lines.append(
            f"| {r['protocol']}{' (reference)' if r['protocol'] == reference else ''} "
            f"| {r['reached']}/{r['runs']} | {r['median_points']:.0f} / {r['max_points']:.0f} "
            f"| {r['median_bench_time_s'] / 3600:.2f} "
            f"| {'' if ratio is None else f'{ratio:.2f}'} "
            f"| {r.get('worse_than_reference', '')} | {r['median_iterations']:.0f} "
            f"| {r['final_split_p50_hz'] * 1e3:.3g} / {r['final_split_p90_hz'] * 1e3:.3g} / "
            f"{r['final_split_max_hz'] * 1e3:.3g} |"
        )
    return "\n".join(lines)


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("folders", nargs="+", type=Path, help="study output folders")
    parser.add_argument("--reference", help="label (folder name) of the reference protocol")
    parser.add_argument("--target-hz", type=float, default=1e-3, help="true split to reach")
    parser.add_argument("--json", action="store_true", help="print the numbers as JSON")
    args = parser.parse_args(argv)
    rows, ref = summarize(args.folders, args.reference, args.target_hz)
    if args.json:
        print(json.dumps(rows))
    else:
        print(markdown(rows, ref, args.target_hz))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
