"""A study's results: the tidy data set, the statistics and the tables.

The tables are the one-line failure summary and the side-by-side table with the paper's
published numbers.
"""

from __future__ import annotations

from typing import Any

import numpy as np
import xarray as xr

__all__ = ["PAPER_NUMBERS", "failure_message", "markdown_report", "summarize", "to_dataset"]


def to_dataset(results: list[dict[str, Any]], electrodes: list[str], iterations: int) -> xr.Dataset:
    """Tidy data set of every run: dims (objective, model, start, iteration)."""
    objectives = sorted(
        {r["objective"] for r in results}, key=[r["objective"] for r in results].index
    )
    models = sorted({r["structure"] for r in results}, key=[r["structure"] for r in results].index)
    n_start = max(r["index"] for r in results) + 1
    shape = (len(objectives), len(models), n_start, iterations)
    bias = np.full((*shape, len(electrodes)), np.nan)
    fields = {
        k: np.full(shape, np.nan)
        for k in (
            "true_split_hz",
            "measured_split_hz",
            "predicted_split_hz",
            "gamma",
            "true_frequency_hz",
            "bias_covered",
            "split_covered",
        )
    }
    bias_ci = np.full((*shape, len(electrodes), 2), np.nan)
    split_ci = np.full((*shape, 2), np.nan)
    start = np.full((n_start, len(electrodes)), np.nan)
    error = np.full(shape[:3], "", dtype=object)
    for r in results:
        o, m, s = objectives.index(r["objective"]), models.index(r["structure"]), r["index"]
        start[s, : len(r["start"])] = r["start"]
        error[o, m, s] = r["error"] or ""
        for it in r["iterations"]:
            k = it["iteration"] - 1
            values = it["bias"]  # a gyro of a population may have fewer electrodes
            bias[o, m, s, k, : len(values)] = values
            for name, arr in fields.items():
                value = it.get(name)
                arr[o, m, s, k] = np.nan if value is None else value  # null: NaN in JSON
            if it.get("bias_ci") is not None:
                bias_ci[o, m, s, k, : len(it["bias_ci"])] = it["bias_ci"]
            if it.get("split_ci_hz") is not None:
                split_ci[o, m, s, k] = it["split_ci_hz"]
    dims = ("objective", "model", "start", "iteration")
    ds = xr.Dataset(
        {
            "predicted_bias": ((*dims, "electrode"), bias, {"units": "V"}),
            **{
                k: (dims, v, {"units": "Hz"} if k.endswith("_hz") else {})
                for k, v in fields.items()
            },
            "bias_ci": ((*dims, "electrode", "bound"), bias_ci, {"units": "V"}),
            "split_ci_hz": ((*dims, "bound"), split_ci, {"units": "Hz"}),
            "error": (dims[:3], error.astype(str)),
        },
        coords={
            "objective": objectives,
            "model": models,
            "start": np.arange(n_start),
            "iteration": np.arange(1, iterations + 1),
            "electrode": electrodes,
            "start_bias": (("start", "electrode"), start, {"units": "V"}),
            "bound": ["low", "high"],
        },
    )
    return ds


def summarize(ds: xr.Dataset, tuned_index: list[int], population: bool = False) -> dict[str, Any]:
    """Per objective, model and iteration: bias statistics and true-split counts.

    In a population study (every run a different gyro) the bias statistics are ``None``
    (biases of different gyros are not comparable); ``worst_step_ratio`` (from iteration 2)
    is the largest ratio of a run's true split to the split measured by its previous
    verification, and ``steps_over_10x`` counts the runs where it exceeds 10.
    """
    out: dict[str, Any] = {}
    for obj in ds["objective"].values:
        per_model: dict[str, Any] = {}
        for model in ds["model"].values:
            per_it: dict[str, Any] = {}
            for it in ds["iteration"].values:
                sel = ds.sel(objective=obj, model=model, iteration=it)
                split = sel["true_split_hz"].values
                ok = np.isfinite(split)
                b = sel["predicted_bias"].values[ok][:, tuned_index]
                if population:
                    b = b[:0]
                s = split[ok]
                per_it[str(int(it))] = {
                    "runs": int(ok.sum()),
                    "failed": int((~ok).sum()),
                    "mean_bias": np.round(b.mean(axis=0), 6).tolist() if len(b) else None,
                    "std_bias": np.round(b.std(axis=0, ddof=1), 6).tolist() if len(b) > 1 else None,
                    "under_1mHz": int((s < 0.001).sum()),
                    "under_2mHz": int((s < 0.002).sum()),
                    "under_10mHz": int((s < 0.010).sum()),
                    "under_300mHz": int((s < 0.300).sum()),
                    "median_split_hz": float(np.median(s)) if ok.any() else None,
                    "split_percentiles_hz": {
                        str(p): float(np.percentile(s, p)) for p in (10, 25, 50, 75, 90, 95, 100)
                    }
                    if ok.any()
                    else None,
                    **_coverage(sel, ok, tuned_index),
                    **_step_ratio(ds.sel(objective=obj, model=model), int(it)),
                }
            per_model[str(model)] = per_it
        out[str(obj)] = per_model
    return out


def _step_ratio(sel: xr.Dataset, it: int) -> dict[str, Any]:
    """Iteration ``it``'s true split over the previous iteration's measured split, per run."""
    if it < 2:
        return {"worst_step_ratio": None, "steps_over_10x": None}
    now = sel["true_split_hz"].sel(iteration=it).values
    before = sel["measured_split_hz"].sel(iteration=it - 1).values
    with np.errstate(all="ignore"):
        ratio = now / before
    ratio = ratio[np.isfinite(ratio)]
    return {
        "worst_step_ratio": float(ratio.max()) if ratio.size else None,
        "steps_over_10x": int((ratio > 10).sum()),
    }


def _fraction(flags: np.ndarray) -> float | None:
    known = flags[np.isfinite(flags)]
    return float(known.mean()) if known.size else None


def _coverage(sel: xr.Dataset, ok: np.ndarray, tuned_index: list[int]) -> dict[str, Any]:
    """How often the confidence regions held the truth, and how wide they were."""
    half = 0.5 * np.diff(sel["bias_ci"].values[ok][:, tuned_index], axis=-1)[..., 0]
    high = sel["split_ci_hz"].values[ok][:, 1]
    with np.errstate(all="ignore"):
        return {
            "bias_coverage": _fraction(sel["bias_covered"].values[ok]),
            "split_coverage": _fraction(sel["split_covered"].values[ok]),
            "median_bias_halfwidth": np.round(np.nanmedian(half, axis=0), 6).tolist()
            if np.isfinite(half).any()
            else None,
            "median_split_ci_high_hz": float(np.nanmedian(high))
            if np.isfinite(high).any()
            else None,
        }


def failure_message(full: dict[str, Any], hint: str = "re-run the same command") -> str:
    """One line on the failed runs of a study (``run_study``'s answer); "" if none failed.

    For example ``3 of 98 runs failed (first: minimax-act-004 at start [9.0, -9.0]:
    DeviceError: ...); results of the others are in DIR; re-run the same command to retry the
    failed ones``.
    """
    failures = full.get("failures") or []
    if not failures:
        return ""
    first = failures[0]
    error = " ".join(str(first["error"]).split())
    if len(error) > 300:
        error = error[:297] + "..."
    start = first.get("tuned_start", first["start"])
    n, runs, where = len(failures), full["runs"], full.get("out", "the output folder")
    kept = (
        f"results of the others are in {where}"
        if n < runs
        else f"no run succeeded; the errors are in {where}/summary.json"
    )
    return (
        f"{n} of {runs} runs failed (first: {first['key']} at start {start}: {error}); "
        f"{kept}; {hint} to retry the failed ones"
    )


#: The paper's published numbers for Section III-B (Figs. 7-10), for the side-by-side report.
PAPER_NUMBERS: dict[str, dict[str, str]] = {
    "act": {
        "1": "mean (2.005, 4.311) V, std (0.146, 0.150) V; 'the majority' < 300 mHz",
        "2": "all but one < 10 mHz (the one: 20 mHz)",
    },
    "sen": {
        "1": "mean (2.071, 4.241) V, std (0.762, 0.669) V",
        "2": "'about as good as act'",
    },
}


def _region_cells(v: dict[str, Any]) -> str:
    """The confidence columns of a report row: half-widths, split bound, two coverages."""
    half = v.get("median_bias_halfwidth")
    high = v.get("median_split_ci_high_hz")

    def pct(x: float | None) -> str:
        return "-" if x is None else f"{x:.0%}"

    cells = [
        "-" if half is None else "(" + ", ".join(f"{h * 1e3:.2g}" for h in half) + ")",
        "-" if high is None else f"{high * 1e3:.2g}",
        pct(v.get("bias_coverage")),
        pct(v.get("split_coverage")),
    ]
    return " | ".join(cells)


def _generated(full: dict[str, Any], command: str) -> str:
    """The first line of a report: the command, its time and its runs."""
    return (
        f"Generated by `{command}` in {full['elapsed_s']:.0f} s ({full['runs']} runs, "
        f"{len(full['failures'])} failed)."
    )


def _population_report(full: dict[str, Any], command: str) -> str:
    """The table of a population study: true-split percentiles, counts, steps, coverage."""
    lines = [
        _generated(full, command) + " True splits after each iteration, one gyro per run.",
        "",
        "| objective | model | iteration | gyros | median [mHz] | 90th pct [mHz] | "
        "95th pct [mHz] | max [mHz] | < 1 mHz | < 2 mHz | < 10 mHz | worst true / previous "
        "measured | steps > 10× | bias coverage | split coverage |",
        "|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|",
    ]
    for obj, per_model in full["summary"].items():
        for model, per_it in per_model.items():
            for it, v in per_it.items():
                pct = v["split_percentiles_hz"] or {}
                fmt = lambda x: "-" if x is None else f"{x * 1e3:.3g}"  # noqa: E731
                cover = lambda x: "-" if x is None else f"{x:.0%}"  # noqa: E731
                ratio = v.get("worst_step_ratio")
                n = v["runs"]
                lines.append(
                    f"| {obj} | {model} | {it} | {n} | {fmt(pct.get('50'))} | "
                    f"{fmt(pct.get('90'))} | {fmt(pct.get('95'))} | {fmt(pct.get('100'))} | "
                    f"{v['under_1mHz']}/{n} | {v['under_2mHz']}/{n} | {v['under_10mHz']}/{n} | "
                    f"{'-' if ratio is None else f'{ratio:.3g}'} | "
                    f"{'-' if v.get('steps_over_10x') is None else v['steps_over_10x']} | "
                    f"{cover(v.get('bias_coverage'))} | {cover(v.get('split_coverage'))} |"
                )
    return "\n".join(lines) + "\n"


def markdown_report(full: dict[str, Any], command: str) -> str:
    """A side-by-side table of the paper's numbers and this study's (true splits)."""
    if full.get("population"):
        return _population_report(full, command)
    lines = [
        _generated(full, command),
        "",
        "| objective | model | iteration | paper | mean bias [V] | std [V] | < 10 mHz | "
        "< 300 mHz | median true split [mHz] | 90th pct [mHz] | max [mHz] | "
        "95 % region: median ± [mV] | split up to [mHz] | bias coverage | split coverage |",
        "|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|",
    ]
    for obj, per_model in full["summary"].items():
        for model, per_it in per_model.items():
            for it, v in per_it.items():
                pct = v["split_percentiles_hz"] or {}
                fmt = lambda x: "-" if x is None else f"{x * 1e3:.2f}"  # noqa: E731
                bias = (
                    "-"
                    if v["mean_bias"] is None
                    else "(" + ", ".join(f"{b:.3f}" for b in v["mean_bias"]) + ")"
                )
                std = (
                    "-"
                    if v["std_bias"] is None
                    else "(" + ", ".join(f"{b:.3f}" for b in v["std_bias"]) + ")"
                )
                lines.append(
                    f"| {obj} | {model} | {it} | {PAPER_NUMBERS.get(model, {}).get(it, '')} | "
                    f"{bias} | {std} | {v['under_10mHz']}/{v['runs']} | "
                    f"{v['under_300mHz']}/{v['runs']} | {fmt(v['median_split_hz'])} | "
                    f"{fmt(pct.get('90'))} | {fmt(pct.get('100'))} | {_region_cells(v)} |"
                )
    return "\n".join(lines) + "\n"
