"""The paper's statistical study (Section III-B, Figs. 7-10) as a parallel batch of tuning runs.

A study is a grid of start biases × model structures × objectives; every (start, structure,
objective) is an independent :class:`~sysid_core.pipeline.TuningRun` of a fixed number of
iterations on a freshly created device (seeded from the run's position in the grid, so results
do not depend on the order or the place they are computed). Runs go to dask.distributed: a
``LocalCluster`` on this machine by default, or an existing cluster (``scheduler``).

Before any run starts, every run's configuration is checked (:func:`plan_study`): each distinct
component is constructed once, every start bias is checked against the device's limits and
the first experiment design, and the ``[study]`` lists must be non-empty without repeats. A
study that fails these checks writes nothing.

Each result is written to ``results/<key>.json`` as soon as it arrives. A re-run skips the runs
that succeeded and retries the ones that failed (their result files record the error until
then). A run whose worker died is recorded as failed only if dask gives up on it (it first
moves it to another worker); a run cut off earlier (its ``runs/<key>`` folder but no result)
starts again from scratch.

After the runs, the study compares with the device's ground truth (``true_modal_frequencies_hz``),
which the tuning itself never sees, and writes ``results.nc`` (tidy), ``summary.json`` and
plots in the style of Figs. 7-10.
"""

from __future__ import annotations

import asyncio
import itertools
import json
import math
import os
import re
import time
import traceback
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any, cast

import numpy as np
import xarray as xr
from pydantic import BaseModel, ConfigDict, Field

from sysid_core.config import PipelineConfig, _describe, parse_config, read_toml
from sysid_core.errors import ConfigError, SysidError
from sysid_core.io import atomic_write, write_json

if TYPE_CHECKING:
    from distributed import Client

    from sysid_core.interfaces import Device
    from sysid_core.registry import Registry

__all__ = [
    "StudyConfig",
    "StudyPlan",
    "failure_message",
    "load_study_config",
    "plan_study",
    "run_study",
    "summarize",
]

Progress = Callable[[int, int, str], None]

#: Names that become part of a run's key, hence of file names.
_SAFE_NAME = re.compile(r"[A-Za-z0-9][A-Za-z0-9_.+-]*")


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
        if self.study.objectives is None:
            return [self.pipeline.model.objective]
        return list(self.study.objectives)


def load_study_config(path: str | os.PathLike[str]) -> StudyConfig:
    """Read a study configuration (the ``sysid tune`` tables plus ``[study]``).

    Only the syntax and the types are checked here; :func:`plan_study` checks the rest.
    """
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
    for k, p in enumerate(pts):
        if len(p) != len(tuned_index):
            raise ConfigError(
                f"[study] starts: entry {k} ({p}) has {len(p)} value(s) but "
                f"{len(tuned_index)} electrode(s) are tuned; give one bias (volts) per tuned "
                "electrode, in the order of [tuning] electrodes"
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


# ---------------------------------------------------------------------- checking before running
@dataclass(frozen=True)
class StudyPlan:
    """A checked study: the device (as configured, not seeded per run) and every run.

    Attributes
    ----------
    device : Device
        The configured device, for its electrodes, limits and ground truth (plots).
    electrodes : list of str
        All of the device's bias electrodes.
    tuned : list of str
        The electrodes tuned.
    tuned_index : list of int
        Positions of ``tuned`` among ``electrodes``.
    specs : list of RunSpec
        Every run, in a fixed order (objective, structure, start).
    """

    device: Device
    electrodes: list[str]
    tuned: list[str]
    tuned_index: list[int]
    specs: list[RunSpec]


def _one_line(exc: BaseException) -> str:
    text = str(exc) if isinstance(exc, SysidError) else f"{type(exc).__name__}: {exc}"
    return " ".join(text.split())


def _check_list(key: str, values: list[Any] | None, example: str, unset: str) -> None:
    """``[study] key`` must not be an empty list nor repeat an entry."""
    if values is None:
        return
    if not values:
        raise ConfigError(f"[study] {key} is empty: list at least one, e.g. {example}, {unset}")
    seen: set[Any] = set()
    for v in values:
        h = tuple(v) if isinstance(v, list) else v
        if h in seen:
            raise ConfigError(
                f"[study] {key} lists {v!r} more than once; list each entry once "
                "(repeated runs would only overwrite each other's results)"
            )
        seen.add(h)


def _check_settings(cfg: StudyConfig) -> None:
    """The ``[study]`` lists: non-empty, no repeats, names usable in file names."""
    st = cfg.study
    if st.starts is not None and "grid" in st.model_fields_set:
        raise ConfigError(
            "[study] has both starts and grid: keep starts (explicit start points) or grid "
            "(every combination of its values), not both"
        )
    _check_list(
        "starts", st.starts, "starts = [[0.0, 0.0], [3.0, -3.0]]", "or remove it to use grid"
    )
    if st.starts is None:
        _check_list("grid", st.grid, "grid = [-3, 0, 3]", "or remove it for the paper's grid")
    _check_list(
        "structures",
        st.structures,
        'structures = ["act", "sen"]',
        "or remove it to compare act and sen",
    )
    _check_list(
        "objectives",
        st.objectives,
        'objectives = ["minimax"]',
        "or remove it to use the [model] objective",
    )
    objectives = "[study] objectives" if st.objectives is not None else "[model] objective"
    for key, names in (("[study] structures", st.structures), (objectives, cfg.objectives)):
        for name in names:
            if not _SAFE_NAME.fullmatch(name):
                raise ConfigError(
                    f"{key}: {name!r} cannot name a run's files; use letters, digits and "
                    "'_.+-' (the installed names: sysid plugins)"
                )
    values = st.grid if st.starts is None else [v for s in st.starts for v in s]
    bad = [v for v in values if not math.isfinite(v)]
    if bad:
        raise ConfigError(
            f"[study] {'grid' if st.starts is None else 'starts'} holds {bad[0]}: every bias "
            "must be a finite number of volts"
        )


class _Once:
    """Construct each distinct component once; wrap a failure in a ConfigError naming its key."""

    def __init__(self, registry: Registry) -> None:
        self.registry = registry
        self.made: dict[tuple[str, str, str], Any] = {}

    def create(self, where: str, kind: str, name: str, **options: Any) -> Any:
        key = (kind, name, json.dumps(options, sort_keys=True, default=repr))
        if key not in self.made:
            try:
                self.made[key] = self.registry.create(kind, name, **options)
            except Exception as exc:
                raise ConfigError(f"{where}: {name!r} cannot be used: {_one_line(exc)}") from exc
        return self.made[key]


def _check_starts(cfg: StudyConfig, plan: StudyPlan) -> None:
    """Every start: inside the device's limits, and its first experiment design is valid."""
    from sysid_core.data import check_rank_condition

    device, electrodes, index = plan.device, plan.electrodes, plan.tuned_index
    low, high = (float(x) for x in device.bias_limits)
    key = "starts" if cfg.study.starts is not None else "grid"
    seen: set[tuple[float, ...]] = set()
    for spec in plan.specs:
        if spec.start in seen:
            continue
        seen.add(spec.start)
        tuned = [spec.start[i] for i in index]
        for p, v in enumerate(spec.start):
            if low <= v <= high:
                continue
            if p in index:
                raise ConfigError(
                    f"[study] {key}: start {tuned} puts {v} V on electrode {electrodes[p]}, "
                    f"outside the device's bias limits [{low}, {high}] V; keep every "
                    f"{'start' if key == 'starts' else 'grid value'} inside them"
                )
            raise ConfigError(
                f"[tuning] start_bias: {v} V on electrode {electrodes[p]} (held during the "
                f"study) is outside the device's bias limits [{low}, {high}] V"
            )
        # The first design (eq. 18): each tuned electrode stepped up, or down if up would leave.
        step = cfg.pipeline.experiment.bias_step
        design = [np.asarray(spec.start, dtype=float)]
        for i in index:
            b = design[0].copy()
            b[i] += step if b[i] + step <= high else -step
            design.append(b)
        stuck = [electrodes[i] for i, b in zip(index, design[1:], strict=True) if b[i] < low]
        try:
            if stuck:
                raise ConfigError(f"{step} V up or down leaves the limits on {stuck}")
            check_rank_condition(
                np.array(design)[:, index], float(device.structure_potential), plan.tuned
            )
        except SysidError as exc:
            raise ConfigError(
                f"[study] {key}: no experiments can be designed around start {tuned} "
                f"([experiment] bias_step = {step} V, limits [{low}, {high}] V): "
                f"{_one_line(exc)}; use a smaller bias_step or move the start"
            ) from exc


class _RegistryFacade:
    """The part of a registry :class:`~sysid_core.pipeline.TuningRun` uses, built once each."""

    def __init__(self, once: _Once, where: dict[str, str]) -> None:
        self.once, self.where = once, where

    def create(self, kind: str, name: str, /, **options: Any) -> Any:
        return self.once.create(self.where.get(kind, f"[{kind}]"), kind, name, **options)


def _check_runs_build(plan: StudyPlan, once: _Once, where: dict[str, str]) -> None:
    """Build (never run) a TuningRun per distinct structure and objective: its own checks.

    The runs share the components already built (each is built once) and a seeded device; the
    output folder given is one that does not exist, so nothing is written.
    """
    from sysid_core.pipeline import TuningRun
    from sysid_core.registry import Registry

    facade = cast(Registry, _RegistryFacade(once, where))
    first = plan.specs[0]
    run_cfg = parse_config(first.config, f"study run {first.key}")
    device = once.create(
        "[device] (with a run's seed)", "device", run_cfg.device.name, **run_cfg.device.options
    )
    nowhere = Path(first.out).parent / f".check-{os.getpid()}-{time.monotonic_ns()}"
    seen: set[tuple[str, str]] = set()
    for spec in plan.specs:
        if (spec.structure, spec.objective) in seen:
            continue
        seen.add((spec.structure, spec.objective))
        run_cfg = parse_config(spec.config, f"study run {spec.key}")
        try:
            TuningRun(run_cfg, nowhere, device=device, registry=facade, plots=False)
        except ConfigError:
            raise
        except SysidError as exc:
            raise ConfigError(f"study run {spec.key} cannot start: {_one_line(exc)}") from exc


def plan_study(
    cfg: StudyConfig, out: str | os.PathLike[str], registry: Registry | None = None
) -> StudyPlan:
    """Check every run of the study before any starts; return the runs. Writes nothing.

    Checks, each failing with a :class:`~sysid_core.errors.ConfigError` that names the key:

    * ``[study]``: ``starts``, ``grid``, ``structures``, ``objectives`` non-empty, without
      repeats (and not both ``starts`` and ``grid``);
    * the device (with its options and a run's seed), the tuned electrodes and
      ``[tuning] start_bias`` against the device's electrodes;
    * every run's configuration (:func:`~sysid_core.config.parse_config`);
    * each distinct model structure (with ``[model] order``), objective (with
      ``[model] objective_options``), solver and tuning criterion (with their options),
      constructed once each;
    * every start bias: one value per tuned electrode, inside the device's ``bias_limits``, and
      the first iteration's experiment design (eq. 18) meets the rank condition (6);
    * whatever else a :class:`~sysid_core.pipeline.TuningRun` checks when it is built (one per
      distinct structure and objective, built from the components above and never run).

    Raises
    ------
    ConfigError
        Naming the key (``[study] starts``, ``[solver]``, ...), the value and what to do.
    """
    from sysid_core.interfaces import Device
    from sysid_core.registry import get_registry

    _check_settings(cfg)
    once = _Once(registry or get_registry())
    pc = cfg.pipeline
    device = once.create("[device]", "device", pc.device.name, **pc.device.options)
    if not isinstance(device, Device):
        raise ConfigError(
            f"[device] name: {pc.device.name!r} does not follow the Device protocol "
            "(electrodes, bias_limits, structure_potential, band_hz, measure)"
        )
    electrodes = [str(e) for e in device.electrodes]
    tuned = list(pc.tuning.electrodes or electrodes)
    unknown = [e for e in tuned if e not in electrodes]
    if unknown:
        raise ConfigError(
            f"[tuning] electrodes: {unknown} not on device {pc.device.name!r}, whose electrodes "
            f"are {electrodes}"
        )
    if pc.tuning.start_bias is not None and len(pc.tuning.start_bias) != len(electrodes):
        raise ConfigError(
            f"[tuning] start_bias has {len(pc.tuning.start_bias)} value(s); device "
            f"{pc.device.name!r} has {len(electrodes)} electrodes ({', '.join(electrodes)})"
        )
    tuned_index = [electrodes.index(e) for e in tuned]
    specs = make_specs(cfg, Path(out).absolute(), electrodes)
    plan = StudyPlan(device, electrodes, tuned, tuned_index, specs)

    where = {
        "device": "[device]",
        "model structure": "[study] structures",
        "objective": "[study] objectives"
        if cfg.study.objectives is not None
        else "[model] objective",
        "solver": "[solver]",
        "tuning criterion": "[tuning] criterion",
    }
    for spec in specs:  # the study's own lists first, for messages naming them
        m = parse_config(spec.config, f"study run {spec.key}").model
        once.create(where["model structure"], "model structure", m.structure, order=m.order)
        once.create(where["objective"], "objective", m.objective, **m.objective_options)
    solver = cfg.pipeline.solver
    once.create(where["solver"], "solver", solver.name, **solver.options)
    _check_starts(cfg, plan)
    _check_runs_build(plan, once, where)  # the criterion and the rest
    return plan


# ---------------------------------------------------------------------- running
def _base(spec: RunSpec) -> dict[str, Any]:
    return {
        "key": spec.key,
        "index": spec.index,
        "objective": spec.objective,
        "structure": spec.structure,
        "start": list(spec.start),
        "seed": spec.seed,
    }


def _failure(spec: RunSpec, exc: BaseException, time_s: float = 0.0) -> dict[str, Any]:
    return {
        **_base(spec),
        "iterations": [],
        "error": f"{type(exc).__name__}: {exc}",
        "traceback": "".join(traceback.format_exception(exc, limit=4)),
        "time_s": time_s,
    }


def _clear_cut_off_run(spec: RunSpec) -> None:
    """Remove ``runs/<key>`` of a run cut off earlier, and nothing else.

    Only a real directory (not a symbolic link) named after the run's key, inside a folder
    ``runs`` whose parent holds the study's ``study.json``, is removed.
    """
    import shutil

    path = Path(spec.out)
    if not (path.exists() or path.is_symlink()):
        return
    real = path.resolve()
    if (
        path.is_symlink()
        or not real.is_dir()
        or not _SAFE_NAME.fullmatch(spec.key)
        or real.name != spec.key
        or real.parent.name != "runs"
        or not (real.parent.parent / "study.json").is_file()
    ):
        raise ConfigError(
            f"refusing to delete {path}: a study only removes its own runs/<key> folders "
            "(next to its study.json); remove or move it yourself"
        )
    shutil.rmtree(real)


def run_one(spec: RunSpec) -> dict[str, Any]:
    """Run one tuning run of the study and compare with the device's ground truth.

    Never raises: a failure is returned as ``{"error": ...}`` with the start point. A folder
    left by a run cut off earlier is removed first (see :func:`_clear_cut_off_run`).
    """
    from sysid_core.pipeline import TuningRun

    os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
    t0 = time.perf_counter()
    try:
        cfg = parse_config(spec.config, f"study run {spec.key}")
        _clear_cut_off_run(spec)  # a run cut off earlier: start it again cleanly
        run = TuningRun(cfg, spec.out, plots=False)
        summary = run.run()
        raw = getattr(run.device, "device", run.device)  # the device inside a guard, if any
        truth = getattr(raw, "true_modal_frequencies_hz", None)
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
        return {
            **_base(spec),
            "iterations": iters,
            "error": None,
            "time_s": time.perf_counter() - t0,
        }
    except Exception as exc:  # report, do not stop the study
        return _failure(spec, exc, time.perf_counter() - t0)


def _result_path(out: Path, key: str) -> Path:
    return out / "results" / f"{key}.json"


def _saved_result(out: Path, spec: RunSpec) -> dict[str, Any] | None:
    """The saved result of ``spec`` if it is a success of this very run, else None."""
    path = _result_path(out, spec.key)
    if not path.exists():
        return None
    try:
        res = json.loads(path.read_text())
    except (OSError, ValueError):
        return None
    same = (
        isinstance(res, dict)
        and res.get("error") is None
        and res.get("start") == list(spec.start)
        and res.get("seed") == spec.seed
        and res.get("objective") == spec.objective
        and res.get("structure") == spec.structure
    )
    return res if same else None


def execute(
    specs: list[RunSpec],
    out: Path,
    executor: str = "dask",
    workers: int | None = None,
    scheduler: str | None = None,
    progress: Progress | None = None,
    client: Client | None = None,
) -> list[dict[str, Any]]:
    """Run the specs not done yet (in parallel), saving each result as it completes.

    A run is done when ``results/<key>.json`` holds its successful result; failed runs are
    run again. A run that fails, including on the cluster's side (a worker that died too
    often, a lost or cancelled task), is recorded as failed; the others go on. ``client``: an
    existing dask client to use (left open); otherwise one is made for ``scheduler`` or for a
    new ``LocalCluster`` of ``workers`` processes.
    """
    done: dict[str, dict[str, Any]] = {}
    retry = 0
    for spec in specs:
        res = _saved_result(out, spec)
        if res is not None:
            done[spec.key] = res
        elif _result_path(out, spec.key).exists():
            retry += 1
    todo = [s for s in specs if s.key not in done]
    total = len(specs)
    say = progress or (lambda _d, _t, _m: None)
    again = f" ({retry} failed or stale, run again)" if retry else ""
    say(len(done), total, f"{len(done)} run(s) already done, {len(todo)} to run{again}")

    def record(res: dict[str, Any]) -> None:
        write_json(_result_path(out, res["key"]), res)
        done[res["key"]] = res
        split = (res["iterations"] or [{}])[-1].get("true_split_hz")
        what = (
            f"failed at start {res['start']}: {res['error']}"
            if res["error"]
            else f"true split {split * 1e3:.2f} mHz"
            if isinstance(split, float)
            else "done"
        )
        say(len(done), total, f"{res['key']}: {what}")

    if todo and executor == "local" and client is None:
        for spec in todo:
            record(run_one(spec))
    elif todo:
        from dask.distributed import Client, LocalCluster, as_completed

        cluster = None
        own = client is None
        if client is None:
            if scheduler:
                client = Client(scheduler)
            else:
                n = workers or os.cpu_count() or 1
                cluster = LocalCluster(
                    n_workers=n, threads_per_worker=1, processes=True, dashboard_address=":0"
                )
                client = Client(cluster)
        pending = {f"sysid-{s.key}": s for s in todo}
        try:
            try:
                futures = client.map(run_one, todo, key=list(pending), pure=False)
                completed = as_completed(futures)
            except Exception as exc:  # no cluster to run on: every run failed
                for spec in list(pending.values()):
                    record(_failure(spec, exc))
                pending.clear()
            while pending:
                try:
                    future = next(completed)
                except StopIteration:
                    break
                except Exception as exc:  # the cluster itself failed: keep what is saved
                    for spec in list(pending.values()):
                        record(_failure(spec, exc))
                    pending.clear()
                    break
                spec = pending.pop(future.key, None)
                if spec is None:
                    continue
                try:
                    res = future.result()
                except (Exception, asyncio.CancelledError) as exc:  # KilledWorker, cancelled
                    res = _failure(spec, exc)
                record(res)
            for spec in pending.values():  # never reported back (should not happen)
                record(_failure(spec, RuntimeError("the cluster never reported this run")))
        finally:
            if own:
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
                value = it.get(name)
                arr[o, m, s, k] = np.nan if value is None else value  # null: NaN in JSON
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
    client: Client | None = None,
) -> dict[str, Any]:
    """Run (or complete) the study in ``out`` and write its outputs; return ``summary.json``.

    Every run is checked first (:func:`plan_study`); a study that fails the checks raises
    :class:`~sysid_core.errors.ConfigError` and writes nothing. Runs that fail do not stop
    the others: they are listed under ``"failures"`` (``"failed"`` counts them) and run again
    by the next call with the same ``out``; :func:`failure_message` words them in one line.

    Outputs: ``study.json``, ``results/<key>.json`` per run, ``results.nc`` (tidy),
    ``summary.json``, ``report.md`` (the paper's numbers and this study's, side by side) and
    ``fig-<objective>-<model>-iter<k>.png`` (Figs. 7-10). ``client``: an existing dask client
    to run on (left open).
    """
    out = Path(out)
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
    summary = summarize(ds, tuned_index)
    failures = [
        {
            "key": r["key"],
            "start": r["start"],
            "tuned_start": [r["start"][i] for i in tuned_index],
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
        "tuned": tuned,
        "out": str(out),
    }
    write_json(out / "summary.json", full)
    text = markdown_report(full, command or "sysid study")
    atomic_write(out / "report.md", lambda tmp: tmp.write_text(text))
    if plots:
        from sysid_core.study_plots import plot_study

        plot_study(ds, device, tuned_index, out, cfg.study.tuned_bias)
    return full


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
                    f"{fmt(pct.get('90'))} | {fmt(pct.get('100'))} |"
                )
    return "\n".join(lines) + "\n"
