"""The paper's statistical study (Section III-B, Figs. 7-10) as a parallel batch of tuning runs.

A study is a grid of start biases × model structures × objectives; every (start, structure,
objective) is an independent :class:`~sysid_core.pipeline.TuningRun` of a fixed number of
iterations on a freshly created device (seeded from the run's position in the grid, so results
do not depend on the order or the place they are computed). Runs go to dask.distributed: a
``LocalCluster`` on this machine by default, or an existing cluster (``scheduler``). Each
result is written to ``results/<key>.json`` as soon as it arrives; a re-run skips what is done.

After the runs, the study compares with the device's ground truth (``true_modal_frequencies_hz``),
which the tuning itself never sees, and writes ``results.nc`` (tidy), ``summary.json`` and
plots in the style of Figs. 7-10.
"""

from __future__ import annotations

import itertools
import json
import os
import time
import traceback
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
import xarray as xr
from pydantic import BaseModel, ConfigDict, Field

from sysid_core.config import PipelineConfig, _describe, read_toml
from sysid_core.errors import ConfigError
from sysid_core.io import atomic_write, write_json

__all__ = ["StudyConfig", "load_study_config", "run_study", "summarize"]

Progress = Callable[[int, int, str], None]


class StudySettings(BaseModel):
    """``[study]``: the grid and what is compared."""

    model_config = ConfigDict(extra="forbid", frozen=True)
    grid: list[float] = Field(default_factory=lambda: [-9.0, -6.0, -3.0, 0.0, 3.0, 6.0, 9.0])
    starts: list[list[float]] | None = None
    structures: list[str] = Field(default_factory=lambda: ["act", "sen"])
    objectives: list[str] | None = None
    iterations: int = Field(2, ge=1, le=10)
    tuned_bias: list[float] | None = None
    seed: int = 0


class _StudyTable(BaseModel):
    model_config = ConfigDict(extra="forbid")
    study: StudySettings = StudySettings()


class StudyConfig(BaseModel):
    """A pipeline configuration plus a ``[study]`` table."""

    model_config = ConfigDict(extra="forbid", frozen=True)
    pipeline: PipelineConfig
    study: StudySettings

    @property
    def objectives(self) -> list[str]:
        """Objectives compared (default: the ``[model]`` objective)."""
        return self.study.objectives or [self.pipeline.model.objective]


def load_study_config(path: str | os.PathLike[str]) -> StudyConfig:
    """Read a study configuration (the ``sysid tune`` tables plus ``[study]``)."""
    from pydantic import ValidationError

    data = read_toml(path)
    study = data.pop("study", {})
    try:
        pipeline = PipelineConfig.model_validate(data)
        settings = _StudyTable.model_validate({"study": study}).study
    except ValidationError as exc:
        raise ConfigError(f"{path}: {_describe(exc)}") from None
    return StudyConfig(pipeline=pipeline, study=settings)


@dataclass(frozen=True)
class RunSpec:
    """One independent run of the study."""

    key: str
    index: int
    objective: str
    structure: str
    start: tuple[float, ...]
    seed: int
    config: dict[str, Any]
    out: str


def _starts(cfg: StudyConfig, n_electrodes_total: int, tuned_index: list[int]) -> list[list[float]]:
    base = cfg.pipeline.tuning.start_bias or [0.0] * n_electrodes_total
    if cfg.study.starts is not None:
        pts = [list(map(float, s)) for s in cfg.study.starts]
    else:
        pts = [list(p) for p in itertools.product(cfg.study.grid, repeat=len(tuned_index))]
    full = []
    for p in pts:
        if len(p) != len(tuned_index):
            raise ConfigError(
                f"a start point has {len(p)} values; {len(tuned_index)} electrodes are tuned"
            )
        b = list(map(float, base))
        for i, v in zip(tuned_index, p, strict=True):
            b[i] = v
        full.append(b)
    return full


def make_specs(cfg: StudyConfig, out: Path, electrodes: list[str]) -> list[RunSpec]:
    """Every run of the study, in a fixed order."""
    tuned = cfg.pipeline.tuning.electrodes or electrodes
    index = [electrodes.index(e) for e in tuned]
    starts = _starts(cfg, len(electrodes), index)
    specs = []
    for objective in cfg.objectives:
        for structure in cfg.study.structures:
            for i, start in enumerate(starts):
                data = cfg.pipeline.model_dump(mode="json")
                data["model"]["structure"] = structure
                data["model"]["objective"] = objective
                data["tuning"]["start_bias"] = start
                data["tuning"]["max_iterations"] = cfg.study.iterations
                data["tuning"]["acceptance_hz"] = 1e-12  # run every iteration
                seed = cfg.study.seed * 100003 + i
                data["device"]["seed"] = seed
                key = f"{objective}-{structure}-{i:03d}"
                specs.append(
                    RunSpec(
                        key,
                        i,
                        objective,
                        structure,
                        tuple(start),
                        seed,
                        data,
                        str(out / "runs" / key),
                    )
                )
    return specs


def run_one(spec: RunSpec) -> dict[str, Any]:
    """Run one tuning run of the study and compare with the device's ground truth.

    Never raises: a failure is returned as ``{"error": ...}`` with the start point.
    """
    import shutil

    from sysid_core.config import parse_config
    from sysid_core.pipeline import TuningRun

    os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
    t0 = time.perf_counter()
    base = {
        "key": spec.key,
        "index": spec.index,
        "objective": spec.objective,
        "structure": spec.structure,
        "start": list(spec.start),
        "seed": spec.seed,
    }
    try:
        cfg = parse_config(spec.config, f"study run {spec.key}")
        if Path(spec.out).exists():  # a run cut off earlier: start it again cleanly
            shutil.rmtree(spec.out)
        run = TuningRun(cfg, spec.out, plots=False)
        summary = run.run()
        truth = getattr(run.device, "true_modal_frequencies_hz", None)
        iters = []
        for rec in summary.history:
            f_true = np.asarray(truth(rec.verified_bias)) if truth else np.full(2, np.nan)
            iters.append(
                {
                    "iteration": rec.iteration,
                    "bias": rec.verified_bias,
                    "predicted_split_hz": rec.tuning["predicted_split_hz"],
                    "measured_split_hz": rec.measured_split_hz,
                    "true_split_hz": float(f_true[1] - f_true[0]),
                    "true_frequency_hz": float(f_true.mean()),
                    "gamma": rec.gamma,
                    "fit_time_s": rec.fit_time_s,
                }
            )
        return {**base, "iterations": iters, "error": None, "time_s": time.perf_counter() - t0}
    except Exception as exc:  # report, do not stop the study
        return {
            **base,
            "iterations": [],
            "error": f"{type(exc).__name__}: {exc}",
            "traceback": traceback.format_exc(limit=4),
            "time_s": time.perf_counter() - t0,
        }


def _result_path(out: Path, key: str) -> Path:
    return out / "results" / f"{key}.json"


def execute(
    specs: list[RunSpec],
    out: Path,
    executor: str = "dask",
    workers: int | None = None,
    scheduler: str | None = None,
    progress: Progress | None = None,
) -> list[dict[str, Any]]:
    """Run the specs not done yet (in parallel), saving each result as it completes."""
    done: dict[str, dict[str, Any]] = {}
    for spec in specs:
        path = _result_path(out, spec.key)
        if path.exists():
            done[spec.key] = json.loads(path.read_text())
    todo = [s for s in specs if s.key not in done]
    total = len(specs)
    say = progress or (lambda _d, _t, _m: None)
    say(len(done), total, f"{len(done)} run(s) already done, {len(todo)} to run")

    def record(res: dict[str, Any]) -> None:
        write_json(_result_path(out, res["key"]), res)
        done[res["key"]] = res
        what = (
            f"failed at start {res['start']}: {res['error']}"
            if res["error"]
            else f"true split {res['iterations'][-1]['true_split_hz'] * 1e3:.2f} mHz"
        )
        say(len(done), total, f"{res['key']}: {what}")

    if todo and executor == "local":
        for spec in todo:
            record(run_one(spec))
    elif todo:
        from dask.distributed import Client, LocalCluster, as_completed

        cluster = None
        if scheduler:
            client = Client(scheduler)
        else:
            n = workers or os.cpu_count() or 1
            cluster = LocalCluster(
                n_workers=n, threads_per_worker=1, processes=True, dashboard_address=":0"
            )
            client = Client(cluster)
        try:
            futures = client.map(run_one, todo, key=[f"sysid-{s.key}" for s in todo], pure=False)
            for future in as_completed(futures):
                record(future.result())
        finally:
            client.close()
            if cluster is not None:
                cluster.close()
    return [done[s.key] for s in specs]


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
        )
    }
    start = np.full((n_start, len(electrodes)), np.nan)
    error = np.full(shape[:3], "", dtype=object)
    for r in results:
        o, m, s = objectives.index(r["objective"]), models.index(r["structure"]), r["index"]
        start[s] = r["start"]
        error[o, m, s] = r["error"] or ""
        for it in r["iterations"]:
            k = it["iteration"] - 1
            bias[o, m, s, k] = it["bias"]
            for name, arr in fields.items():
                arr[o, m, s, k] = it[name]
    dims = ("objective", "model", "start", "iteration")
    ds = xr.Dataset(
        {
            "predicted_bias": ((*dims, "electrode"), bias, {"units": "V"}),
            **{k: (dims, v, {"units": "Hz"} if k != "gamma" else {}) for k, v in fields.items()},
            "error": (dims[:3], error.astype(str)),
        },
        coords={
            "objective": objectives,
            "model": models,
            "start": np.arange(n_start),
            "iteration": np.arange(1, iterations + 1),
            "electrode": electrodes,
            "start_bias": (("start", "electrode"), start, {"units": "V"}),
        },
    )
    return ds


def summarize(ds: xr.Dataset, tuned_index: list[int]) -> dict[str, Any]:
    """Per objective, model and iteration: bias statistics and true-split counts."""
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
                s = split[ok]
                per_it[str(int(it))] = {
                    "runs": int(ok.sum()),
                    "failed": int((~ok).sum()),
                    "mean_bias": np.round(b.mean(axis=0), 6).tolist() if ok.any() else None,
                    "std_bias": np.round(b.std(axis=0, ddof=1), 6).tolist()
                    if ok.sum() > 1
                    else None,
                    "under_10mHz": int((s < 0.010).sum()),
                    "under_300mHz": int((s < 0.300).sum()),
                    "median_split_hz": float(np.median(s)) if ok.any() else None,
                    "split_percentiles_hz": {
                        str(p): float(np.percentile(s, p)) for p in (10, 25, 50, 75, 90, 100)
                    }
                    if ok.any()
                    else None,
                }
            per_model[str(model)] = per_it
        out[str(obj)] = per_model
    return out


def run_study(
    cfg: StudyConfig,
    out: Path,
    executor: str = "dask",
    workers: int | None = None,
    scheduler: str | None = None,
    progress: Progress | None = None,
    plots: bool = True,
    command: str | None = None,
) -> dict[str, Any]:
    """Run (or complete) the study in ``out`` and write its outputs; return ``summary.json``.

    Outputs: ``results/<key>.json`` per run, ``results.nc`` (tidy), ``summary.json``,
    ``report.md`` (the paper's numbers and this study's, side by side) and
    ``fig-<objective>-<model>-iter<k>.png`` (Figs. 7-10).
    """
    from sysid_core.registry import get_registry

    out.mkdir(parents=True, exist_ok=True)
    device = get_registry().create(
        "device", cfg.pipeline.device.name, **cfg.pipeline.device.options
    )
    electrodes = [str(e) for e in device.electrodes]
    tuned = cfg.pipeline.tuning.electrodes or electrodes
    tuned_index = [electrodes.index(e) for e in tuned]
    specs = make_specs(cfg, out, electrodes)
    write_json(out / "study.json", {"config": cfg.model_dump(mode="json"), "runs": len(specs)})
    t0 = time.perf_counter()
    results = execute(specs, out, executor, workers, scheduler, progress)
    elapsed = time.perf_counter() - t0
    ds = to_dataset(results, electrodes, cfg.study.iterations)
    ds.attrs.update({"device": cfg.pipeline.device.name, "tuned": json.dumps(tuned)})
    atomic_write(out / "results.nc", lambda tmp: ds.to_netcdf(tmp, engine="h5netcdf"))
    summary = summarize(ds, tuned_index)
    failures = [
        {"key": r["key"], "start": r["start"], "error": r["error"]} for r in results if r["error"]
    ]
    full = {
        "summary": summary,
        "primary_objective": cfg.objectives[0],
        "runs": len(specs),
        "failures": failures,
        "elapsed_s": elapsed,
        "tuned": tuned,
    }
    write_json(out / "summary.json", full)
    text = markdown_report(full, command or "sysid study")
    atomic_write(out / "report.md", lambda tmp: tmp.write_text(text))
    if plots:
        from sysid_core.study_plots import plot_study

        plot_study(ds, device, tuned_index, out, cfg.study.tuned_bias)
    return full


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


def markdown_report(full: dict[str, Any], command: str) -> str:
    """A side-by-side table of the paper's numbers and this study's (true splits)."""
    lines = [
        f"Generated by `{command}` in {full['elapsed_s']:.0f} s ({full['runs']} runs, "
        f"{len(full['failures'])} failed).",
        "",
        "| objective | model | iteration | paper | mean bias [V] | std [V] | < 10 mHz | "
        "< 300 mHz | median true split [mHz] | 90th pct [mHz] | max [mHz] |",
        "|---|---|---|---|---|---|---|---|---|---|---|",
    ]
    for obj, per_model in full["summary"].items():
        for model, per_it in per_model.items():
            for it, v in per_it.items():
                pct = v["split_percentiles_hz"] or {}
                fmt = lambda x: "-" if x is None else f"{x * 1e3:.2f}"  # noqa: E731
                bias = "-" if v["mean_bias"] is None else "(" + ", ".join(
                    f"{b:.3f}" for b in v["mean_bias"]) + ")"
                std = "-" if v["std_bias"] is None else "(" + ", ".join(
                    f"{b:.3f}" for b in v["std_bias"]) + ")"
                lines.append(
                    f"| {obj} | {model} | {it} | {PAPER_NUMBERS.get(model, {}).get(it, '')} | "
                    f"{bias} | {std} | {v['under_10mHz']}/{v['runs']} | "
                    f"{v['under_300mHz']}/{v['runs']} | {fmt(v['median_split_hz'])} | "
                    f"{fmt(pct.get('90'))} | {fmt(pct.get('100'))} |"
                )
    return "\n".join(lines) + "\n"
