"""The paper's statistical study (Section III-B, Figs. 7-10) as a parallel batch of tuning runs.

A study is a grid of start biases × model structures × objectives; every (start, structure,
objective) is an independent :class:`~sysid_core.run.pipeline.TuningRun` of a fixed number of
iterations on a freshly created device (seeded from the run's position in the grid, so results
do not depend on the order or the place they are computed).

:func:`run_study` puts the steps together: check every run (:mod:`sysid_core.batch.study.plan`), run
them (:mod:`sysid_core.batch.study.execute`), then compare with the device's ground truth, which the
tuning itself never sees, and write ``results.nc`` (tidy), ``summary.json``, ``report.md``
(:mod:`sysid_core.batch.study.report`) and the Fig. 7-10 plots
(:mod:`sysid_core.batch.study.plots`).
"""

from __future__ import annotations

import json
import time
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from sysid_core.batch.study.execute import BatchProgress, execute
from sysid_core.batch.study.plan import StudyConfig, StudyPlan, load_study_config, plan_study
from sysid_core.batch.study.plots import plot_population, plot_study
from sysid_core.batch.study.report import failure_message, markdown_report, summarize, to_dataset
from sysid_core.data.io import atomic_write, write_json

if TYPE_CHECKING:
    from distributed import Client

__all__ = ["failure_message", "load_study_config", "plan_study", "run_study"]


def _bench(results: list[dict[str, Any]]) -> dict[str, float | None]:
    """Median frequency points and bench time per successful run (:mod:`sysid_core.clock`)."""
    points = [r["points"] for r in results if not r["error"] and r.get("points") is not None]
    times = [
        r["bench_time_s"] for r in results if not r["error"] and r.get("bench_time_s") is not None
    ]
    return {
        "median_points": float(np.median(points)) if points else None,
        "median_bench_time_s": float(np.median(times)) if times else None,
    }


def run_study(
    cfg: StudyConfig,
    out: Path,
    executor: str = "dask",
    workers: int | None = None,
    scheduler: str | None = None,
    progress: BatchProgress | None = None,
    plots: bool = True,
    command: str | None = None,
    client: Client | None = None,
    plan: StudyPlan | None = None,
) -> dict[str, Any]:
    """Run (or complete) the study in ``out`` and write its outputs; return ``summary.json``.

    Every run is checked first (:func:`plan_study`); a study that fails the checks raises
    :class:`~sysid_core.errors.ConfigError` and writes nothing. Runs that fail do not stop
    the others: they are listed under ``"failures"`` (``"failed"`` counts them) and run again
    by the next call with the same ``out``; :func:`failure_message` words them in one line.

    Outputs: ``study.json``, ``results/<key>.json`` per run, ``results.nc`` (tidy),
    ``summary.json``, ``report.md`` (the paper's numbers and this study's, side by side) and
    ``fig-<objective>-<model>-iter<k>.png`` (Figs. 7-10). ``client``: an existing dask client
    to run on (left open). ``plan``: the study's :func:`plan_study`, if the caller checked it
    already.
    """
    out = Path(out)
    if plan is None:
        plan = plan_study(cfg, out)  # before anything is written
    device, electrodes, tuned, tuned_index = (
        plan.device,
        plan.electrodes,
        plan.tuned,
        plan.tuned_index,
    )
    specs = plan.specs
    out.mkdir(parents=True, exist_ok=True)
    write_json(out / "study.json", {"config": cfg.model_dump(mode="json"), "runs": len(specs)})
    t0 = time.perf_counter()
    results = execute(specs, out, executor, workers, scheduler, progress, client=client)
    elapsed = time.perf_counter() - t0
    ds = to_dataset(results, electrodes, cfg.study.iterations)
    ds.attrs.update({"device": cfg.pipeline.device.name, "tuned": json.dumps(tuned)})
    atomic_write(out / "results.nc", lambda tmp: ds.to_netcdf(tmp, engine="h5netcdf"))
    population = cfg.study.gyros is not None
    summary = summarize(ds, tuned_index, population)
    failures = [
        {
            "key": r["key"],
            "start": r["start"],
            "tuned_start": [r["start"][i] for i in tuned_index if i < len(r["start"])],
            "error": r["error"],
        }
        for r in results
        if r["error"]
    ]
    full = {
        "summary": summary,
        "primary_objective": cfg.objectives[0],
        "runs": len(specs),
        "failed": len(failures),
        "failures": failures,
        "elapsed_s": elapsed,
        **_bench(results),
        "tuned": tuned,
        "population": population,
        "out": str(out),
    }
    write_json(out / "summary.json", full)
    text = markdown_report(full, command or "sysid study")
    atomic_write(out / "report.md", lambda tmp: tmp.write_text(text))
    if plots and population:
        plot_population(ds, out)
    elif plots:
        plot_study(ds, device, tuned_index, out, cfg.study.tuned_bias)
    return full
