"""Tuning many gyros at once: ``sysid tune-fleet FLEET.toml``.

A fleet file names the gyros and the configuration each is tuned with::

    config = "cloverleaf-2electrode.toml"   # the base configuration (relative to this file)
    seeds = [1, 2, 3]                       # shorthand: gyros "seed-1", ... with [device] seed = N

    [[gyro]]
    name = "sn-0042"                        # its run folder: OUT/sn-0042
    device = { seed = 42 }                  # options merged into the base [device] table

    [[gyro]]
    name = "sn-0043"
    config = "bench-b.toml"                 # a configuration of its own

Every gyro is a :class:`~sysid_core.run.pipeline.TuningRun` in its own folder, run as one job of
:func:`~sysid_core.batch.executor.run_batch` (a local dask cluster, or ``--scheduler``). A gyro
whose configuration is invalid, whose device fails, or whose worker dies is reported as failed; the
others go on. ``OUT/fleet.json`` (rewritten atomically as each gyro finishes) and
``OUT/fleet.md`` hold the table of all of them. Run again with ``resume``: converged gyros are
kept, the others continue from what their folders hold (nothing measured is measured again).
"""

from __future__ import annotations

import copy
import time
import traceback
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from pydantic import BaseModel, ConfigDict, Field, ValidationError, field_validator

from sysid_core.batch.executor import run_batch
from sysid_core.data.io import atomic_write, write_json
from sysid_core.errors import ConfigError, RunFolderError
from sysid_core.run.config import parse_config, read_toml

__all__ = ["FleetConfig", "GyroJob", "check_fleet", "load_fleet", "run_fleet", "tune_gyro"]

_NAME = r"^[A-Za-z0-9][A-Za-z0-9._-]{0,63}$"


class GyroEntry(BaseModel):
    """One ``[[gyro]]`` of a fleet file."""

    model_config = ConfigDict(extra="forbid")

    name: str = Field(pattern=_NAME)
    config: str | None = None
    device: dict[str, Any] = Field(default_factory=dict)

    @field_validator("device")
    @classmethod
    def _no_name(cls, v: dict[str, Any]) -> dict[str, Any]:
        if "name" in v:
            raise ValueError("holds options of the base [device]; its name comes from the config")
        return v


class FleetConfig(BaseModel):
    """A fleet file: a base ``config``, ``seeds`` and/or ``[[gyro]]`` entries."""

    model_config = ConfigDict(extra="forbid")

    config: str | None = None
    seeds: list[int] = Field(default_factory=list)
    gyro: list[GyroEntry] = Field(default_factory=list)


@dataclass(frozen=True)
class GyroJob:
    """One gyro to tune.

    Its name, configuration (a dict, or the error that makes it invalid), run folder, and
    whether to continue what the folder holds.
    """

    name: str
    config: dict[str, Any] | None
    error: str | None
    out: str
    resume: bool
    plots: bool = True


def load_fleet(path: str | Path) -> tuple[list[str], list[dict[str, Any] | str]]:
    """The gyros of a fleet file: names and, per gyro, its configuration or its error.

    The fleet file itself must be valid (a :class:`~sysid_core.errors.ConfigError` if not); a
    gyro's configuration that does not validate is returned as its error message, so that the
    other gyros can still be tuned.
    """
    path = Path(path)
    fleet = _fleet_file(path)
    entries = [GyroEntry(name=f"seed-{s}", device={"seed": s}) for s in fleet.seeds]
    entries += fleet.gyro
    if not entries:
        raise ConfigError(f"{path}: no gyros; add seeds = [...] or [[gyro]] tables")
    names = [e.name for e in entries]
    dup = sorted({n for n in names if names.count(n) > 1})
    if dup:
        raise ConfigError(f"{path}: gyro name(s) {', '.join(dup)} appear more than once")
    base: dict[str, Any] | None = None
    if fleet.config is not None:
        try:
            base = read_toml(path.parent / fleet.config)
        except ConfigError as exc:
            raise ConfigError(f"{path}: config = {fleet.config!r}: {exc}") from None
    configs = [_gyro_config(path, e, base) for e in entries]
    return names, configs


def _fleet_file(path: Path) -> FleetConfig:
    """The fleet file at ``path``, validated; a :class:`ConfigError` names the first problem."""
    raw = read_toml(path)
    try:
        return FleetConfig.model_validate(raw)
    except ValidationError as exc:
        first = exc.errors()[0]
        where = ".".join(str(x) for x in first["loc"])
        if first["type"] == "extra_forbidden":
            known = "config, seeds, [[gyro]]" if len(first["loc"]) == 1 else "name, config, device"
            raise ConfigError(f"{path}: unknown key {where!r} (known: {known})") from None
        raise ConfigError(f"{path}: {where}: {first['msg']}") from None


def _gyro_config(path: Path, e: GyroEntry, base: dict[str, Any] | None) -> dict[str, Any] | str:
    """Gyro ``e``'s configuration, or the error message that makes it invalid.

    Its own configuration file, or a copy of ``base``, with its ``device`` options merged in.
    """
    if e.config is not None:
        try:
            data = read_toml(path.parent / e.config)
        except ConfigError as exc:
            return str(exc)
    elif base is not None:
        data = copy.deepcopy(base)
    else:
        raise ConfigError(
            f"{path}: gyro {e.name!r} has no config and the fleet file no base config = ..."
        )
    data.setdefault("device", {}).update(e.device)
    try:
        parse_config(data, f"gyro {e.name}")
    except ConfigError as exc:
        return str(exc)
    return data


def tune_gyro(job: GyroJob) -> dict[str, Any]:
    """Tune one gyro in its folder (a fleet's job); never raises: failures are returned."""
    from sysid_core.run.pipeline import TuningRun

    t0 = time.perf_counter()
    if job.error is not None:
        return failure(job, ConfigError(job.error))
    try:
        cfg = parse_config(job.config or {}, f"gyro {job.name}")
        summary = TuningRun(cfg, job.out, resume=job.resume, plots=job.plots).run()
    except Exception as exc:
        return failure(job, exc, time.perf_counter() - t0)
    result = {k: v for k, v in summary.as_dict().items() if k != "history"}
    return {"name": job.name, "error": None, **result, "time_s": time.perf_counter() - t0}


def failure(job: GyroJob, exc: BaseException, time_s: float = 0.0) -> dict[str, Any]:
    """The result of a gyro that failed: its name and the error in one line."""
    return {
        "name": job.name,
        "error": f"{type(exc).__name__}: {exc}".splitlines()[0],
        "traceback": "".join(traceback.format_exception(exc, limit=4)),
        "out": job.out,
        "converged": False,
        "time_s": time_s,
    }


def _table(results: list[dict[str, Any]]) -> str:
    lines = [
        "| gyro | status | split (mHz) | frequency (Hz) | bias (V) | iterations | points "
        "| bench time (h) |",
        "|---|---|---|---|---|---|---|---|",
    ]
    for r in results:
        if r.get("error"):
            lines.append(f"| {r['name']} | FAILED: {r['error']} | | | | | | |")
            continue
        split = r.get("split_hz")
        freq = r.get("frequency_hz")
        bench = r.get("bench_time_s")
        lines.append(
            f"| {r['name']} | {'converged' if r['converged'] else 'not converged'} "
            f"| {'' if split is None else f'{split * 1e3:.3g}'} "
            f"| {'' if freq is None else f'{freq:.3f}'} "
            f"| {', '.join(f'{b:.4f}' for b in r['bias'])} | {r['iterations']} | {r['points']} "
            f"| {'' if bench is None else f'{bench / 3600:.2f}'} |"
        )
    return "\n".join(lines) + "\n"


def check_fleet(
    fleet_file: str | Path, out: str | Path, resume: bool
) -> tuple[list[str], list[dict[str, Any] | str]]:
    """Load the fleet file (:func:`load_fleet`) and check ``out``, writing nothing.

    Raises
    ------
    ConfigError
        For a fleet file that is not valid.
    RunFolderError
        If ``out`` is a file, or holds files and ``resume`` is not set.
    """
    found = load_fleet(fleet_file)
    out = Path(out)
    if out.exists() and not out.is_dir():
        raise RunFolderError(f"--out {out} is a file, not a folder; choose another --out")
    if out.exists() and any(out.iterdir()) and not resume:
        raise RunFolderError(
            f"{out} is not empty; continue that fleet with --resume, or choose another --out"
        )
    return found


def run_fleet(
    fleet_file: str | Path,
    out: str | Path,
    resume: bool = False,
    workers: int | None = None,
    scheduler: str | None = None,
    progress: Callable[[int, int, str], None] | None = None,
    plots: bool = True,
) -> list[dict[str, Any]]:
    """Tune every gyro of ``fleet_file`` into ``out/<name>``; return their results in order.

    Raises
    ------
    ConfigError
        For a fleet file that is not valid (nothing is run).
    RunFolderError
        If ``out`` holds files and ``resume`` is not set.
    """
    names, configs = check_fleet(fleet_file, out, resume)
    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    say = progress or (lambda _d, _t, _m: None)
    results: dict[str, dict[str, Any]] = {}
    jobs: list[GyroJob] = []
    for name, cfg in zip(names, configs, strict=True):
        folder = out / name
        kept = _converged(folder) if resume else None
        if kept is not None:
            results[name] = {"name": name, "error": None, **kept, "time_s": 0.0}
            continue
        ok = isinstance(cfg, dict)
        jobs.append(
            GyroJob(
                name=name,
                config=cfg if isinstance(cfg, dict) else None,
                error=None if ok else str(cfg),
                out=str(folder),
                resume=resume and (folder / "config.json").exists(),
                plots=plots,
            )
        )
    total = len(names)
    say(len(results), total, f"{len(results)} gyro(s) already tuned, {len(jobs)} to tune")

    def save() -> None:
        ordered = [results[n] for n in names if n in results]
        write_json(out / "fleet.json", {"gyros": ordered})
        atomic_write(out / "fleet.md", lambda p: p.write_text(_table(ordered)))

    def record(res: dict[str, Any]) -> None:
        results[res["name"]] = res
        save()
        what = (
            f"FAILED: {res['error']}"
            if res.get("error")
            else f"{'converged' if res['converged'] else 'NOT converged'}, "
            f"split {res['split_hz'] * 1e3:.3g} mHz, {res['points']} points"
            if res.get("split_hz") is not None
            else f"{res.get('status')}"
        )
        say(len(results), total, f"{res['name']}: {what}")

    invalid = [j for j in jobs if j.error is not None]
    for j in invalid:  # nothing to run: reported at once
        record(failure(j, ConfigError(j.error or "")))
    todo = [j for j in jobs if j.error is None]
    run_batch(
        todo,
        tune_gyro,
        [f"sysid-fleet-{j.name}" for j in todo],
        record,
        failure,
        workers=workers,
        scheduler=scheduler,
    )
    save()
    return [results[n] for n in names]


def _converged(folder: Path) -> dict[str, Any] | None:
    """The saved summary of a gyro that converged, else None."""
    import json

    path = folder / "summary.json"
    try:
        summary = json.loads(path.read_text())
    except (OSError, ValueError):
        return None
    if not isinstance(summary, dict) or summary.get("converged") is not True:
        return None
    return {k: v for k, v in summary.items() if k != "history"}
