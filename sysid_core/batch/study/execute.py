"""Running a study's runs: one in a process (:func:`run_one`), all of them (:func:`execute`).

Runs go to dask.distributed (a ``LocalCluster`` on this machine, or an existing cluster), or
run here one after the other. Each result is written to ``results/<key>.json`` as soon as it
arrives; a re-run skips the runs that succeeded and retries the failed ones. A run whose worker
died is recorded as failed only if dask gives up on it (it first moves it to another worker); a
run cut off earlier (its ``runs/<key>`` folder but no result) starts again from scratch.
"""

from __future__ import annotations

import json
import time
import traceback
from collections.abc import Callable
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from sysid_core.batch.executor import run_batch
from sysid_core.batch.study.config import SAFE_NAME, RunSpec
from sysid_core.data.io import write_json
from sysid_core.device.measuring import ground_truth
from sysid_core.device.simulation import GyroTruth
from sysid_core.errors import ConfigError
from sysid_core.run.config import parse_config
from sysid_core.tuning.criteria import BiasSpace

if TYPE_CHECKING:
    from distributed import Client

__all__ = ["BatchProgress", "execute", "run_one"]

#: Receives (runs done, runs in all, one line about the last one).
BatchProgress = Callable[[int, int, str], None]


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
        or not SAFE_NAME.fullmatch(spec.key)
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
    from sysid_core.run.pipeline import TuningRun

    t0 = time.perf_counter()
    try:
        cfg = parse_config(spec.config, f"study run {spec.key}")
        _clear_cut_off_run(spec)  # a run cut off earlier: start it again cleanly
        run = TuningRun(cfg, spec.out, plots=False)
        summary = run.run()
        sim = ground_truth(run.device)
        truth = sim.true_modal_frequencies_hz if sim is not None else None
        target = true_degenerate_bias(sim, cfg.tuning.criterion, run.space)
        iters = []
        for rec in summary.history:
            f_true = np.asarray(truth(rec.verified_bias)) if truth else np.full(2, np.nan)
            true_split = float(f_true[1] - f_true[0])
            bias_ci, split_ci = rec.tuning.get("bias_ci"), rec.tuning.get("split_ci_hz")
            iters.append(
                {
                    "iteration": rec.iteration,
                    "bias": rec.verified_bias,
                    "predicted_split_hz": rec.tuning["predicted_split_hz"],
                    "measured_split_hz": rec.measured_split_hz,
                    "true_split_hz": true_split,
                    "true_frequency_hz": float(f_true.mean()),
                    "gamma": rec.gamma,
                    "fit_time_s": rec.fit_time_s,
                    "points": rec.points,
                    "bias_ci": bias_ci,
                    "split_ci_hz": split_ci,
                    "true_degenerate_bias": target,
                    "bias_covered": None
                    if bias_ci is None or target is None
                    else all(
                        lo <= t <= hi
                        for p, ((lo, hi), t) in enumerate(zip(bias_ci, target, strict=True))
                        if p in run.space.index
                    ),
                    "split_covered": None
                    if split_ci is None or truth is None
                    else bool(split_ci[0] <= true_split <= split_ci[1]),
                }
            )
        return {
            **_base(spec),
            "iterations": iters,
            "points": summary.points,
            "bench_time_s": summary.bench_time_s,
            "dwell_s": summary.dwell_s,
            "error": None,
            "time_s": time.perf_counter() - t0,
        }
    except Exception as exc:  # report, do not stop the study
        return _failure(spec, exc, time.perf_counter() - t0)


def true_degenerate_bias(sim: object, criterion: str, space: BiasSpace) -> list[float] | None:
    """The TRUE bias that makes the modes degenerate, where a study can say which one.

    Defined for the ``degenerate`` criterion on exactly two tuned electrodes (the others at
    their start bias) of a simulated device with a :class:`~sysid_core.device.simulation.GyroTruth`
    (its ``truth``); ``None`` otherwise (more electrodes tune along a whole set of biases).
    """
    truth = getattr(sim, "truth", None)
    if criterion != "degenerate" or len(space.index) != 2 or not isinstance(truth, GyroTruth):
        return None
    pair = (space.index[0], space.index[1])
    return [float(b) for b in truth.degenerate_bias(pair, bias=space.start_bias)]


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
    progress: BatchProgress | None = None,
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
        run_batch(
            todo,
            run_one,
            [f"sysid-{s.key}" for s in todo],
            record,
            _failure,
            workers=workers,
            scheduler=scheduler,
            client=client,
        )
    return [done[s.key] for s in specs]
