"""What a study runs: its configuration, every run's spec, and the checks before any starts.

A study configuration is a ``sysid tune`` configuration plus a ``[study]`` table (the grid of
start biases, the model structures and objectives compared, the iterations). :func:`make_specs`
turns it into independent :class:`RunSpec` s in a fixed order; :func:`plan_study` checks them
all before anything runs or is written.

The study file's models are in :mod:`.config`, the checks of its ``[study]`` table in
:mod:`.checks`.
"""

from __future__ import annotations

import itertools
import os
import time
from dataclasses import dataclass
from pathlib import Path

from sysid_core.batch.study.checks import check_names, check_settings, check_starts, one_line
from sysid_core.batch.study.config import (
    AUTO_STRUCTURE,
    RunSpec,
    StudyConfig,
    StudySettings,
    load_study_config,
)
from sysid_core.device.capabilities import named_structure
from sysid_core.device.protocol import Device
from sysid_core.errors import ConfigError, SysidError
from sysid_core.plugin.registry import Registry
from sysid_core.run.config import parse_config

__all__ = [
    "AUTO_STRUCTURE",
    "RunSpec",
    "StudyConfig",
    "StudyPlan",
    "StudySettings",
    "load_study_config",
    "make_population_specs",
    "make_specs",
    "plan_study",
    "population_seeds",
]


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


def population_seeds(cfg: StudyConfig) -> list[int]:
    """Device seeds of a population study: ``seed * 100003 + k`` for ``k < gyros``."""
    return [cfg.study.seed * 100003 + k for k in range(cfg.study.gyros or 0)]


def device_structure(device: Device, seed: int) -> str:
    """The model structure a device names (its ``structure`` attribute), for ``auto``."""
    name = named_structure(device)
    if name is None:
        raise ConfigError(
            f"[study] structures: {AUTO_STRUCTURE!r} needs a device that names its model "
            f"structure (a 'structure' attribute, as random-gyro has); the device with seed "
            f'{seed} does not: list the structures instead, e.g. structures = ["act"]'
        )
    return name


def _spec(
    cfg: StudyConfig,
    out: Path,
    objective: str,
    structure: str,
    resolved: str,
    i: int,
    start: list[float],
    seed: int,
) -> RunSpec:
    """Run ``i`` of a study: ``structure`` as named in ``[study]``, ``resolved`` as fitted."""
    data = cfg.pipeline.model_dump(mode="json")
    data["model"]["structure"] = resolved
    data["objective"]["name"] = objective
    data["tuning"]["start_bias"] = start
    data["tuning"]["max_iterations"] = cfg.study.iterations
    data["tuning"]["acceptance_hz"] = 1e-12  # run every iteration
    data["device"]["seed"] = seed
    key = f"{objective}-{structure}-{i:03d}"
    return RunSpec(key, i, objective, structure, tuple(start), seed, data, str(out / "runs" / key))


def make_population_specs(
    cfg: StudyConfig, out: Path, devices: list[tuple[int, Device]]
) -> list[RunSpec]:
    """The runs of a population study: every gyro from its native state (0 V everywhere)."""
    specs = []
    for objective in cfg.objectives:
        for structure in cfg.study.structures:
            for i, (seed, device) in enumerate(devices):
                resolved = (
                    device_structure(device, seed) if structure == AUTO_STRUCTURE else structure
                )
                start = [0.0] * len(device.electrodes)
                specs.append(_spec(cfg, out, objective, structure, resolved, i, start, seed))
    return specs


def make_specs(cfg: StudyConfig, out: Path, electrodes: list[str]) -> list[RunSpec]:
    """Every run of a study over start biases, in a fixed order."""
    tuned = cfg.pipeline.tuning.electrodes or electrodes
    index = [electrodes.index(e) for e in tuned]
    starts = _starts(cfg, len(electrodes), index)
    specs = []
    for objective in cfg.objectives:
        for structure in cfg.study.structures:
            for i, start in enumerate(starts):
                seed = cfg.study.seed * 100003 + i
                specs.append(_spec(cfg, out, objective, structure, structure, i, start, seed))
    return specs


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


def plan_study(
    cfg: StudyConfig, out: str | os.PathLike[str], registry: Registry | None = None
) -> StudyPlan:
    """Check every run of the study before any starts; return the runs. Writes nothing.

    The ``[study]`` lists must be non-empty, without repeats (and not both ``starts`` and
    ``grid``); then every run is built as a :class:`~sysid_core.run.pipeline.TuningRun` (never
    run, in a folder that does not exist), which checks its configuration, builds each of its
    components from ``registry`` with their options, and checks its device, start bias, sweeps
    and first experiment design. Each error is a :class:`~sysid_core.errors.ConfigError` naming
    the ``[study]`` key it comes from, the run and what to do.
    """
    from sysid_core.plugin.registry import get_registry
    from sysid_core.run.pipeline import TuningRun

    registry = registry or get_registry()
    check_settings(cfg)
    pc = cfg.pipeline
    if cfg.study.gyros is not None:
        return _plan_population(cfg, out, registry)
    try:
        device = registry.device(pc.device.name, **pc.device.options)
    except SysidError as exc:
        raise ConfigError(f"[device]: {one_line(exc)}") from exc
    electrodes = [str(e) for e in device.electrodes]
    tuned = list(pc.tuning.electrodes or electrodes)
    unknown = [e for e in tuned if e not in electrodes]
    if unknown:
        raise ConfigError(
            f"[tuning] electrodes: {unknown} not on device {pc.device.name!r}, whose electrodes "
            f"are {electrodes}"
        )
    tuned_index = [electrodes.index(e) for e in tuned]
    check_names(cfg, registry)
    specs = make_specs(cfg, Path(out).absolute(), electrodes)
    check_starts(cfg, device, electrodes, tuned_index, specs)
    nowhere = Path(out).absolute() / f".check-{os.getpid()}-{time.monotonic_ns()}"
    for spec in specs:
        run_cfg = parse_config(spec.config, f"study run {spec.key}")
        try:
            TuningRun(run_cfg, nowhere, device=device, registry=registry, plots=False)
        except SysidError as exc:
            raise ConfigError(f"study run {spec.key} cannot start: {one_line(exc)}") from exc
    return StudyPlan(device, electrodes, tuned, tuned_index, specs)


def _plan_population(
    cfg: StudyConfig, out: str | os.PathLike[str], registry: Registry
) -> StudyPlan:
    """:func:`plan_study` of a population study: one device per seed, each run checked."""
    from sysid_core.run.pipeline import TuningRun

    pc = cfg.pipeline
    devices: list[tuple[int, Device]] = []
    for seed in population_seeds(cfg):
        try:
            devices.append(
                (seed, registry.device(pc.device.name, **{**pc.device.options, "seed": seed}))
            )
        except SysidError as exc:
            raise ConfigError(f"[device] with seed {seed}: {one_line(exc)}") from exc
    electrodes: list[str] = []
    for _, device in devices:
        electrodes += [str(e) for e in device.electrodes if str(e) not in electrodes]
    tuned = list(pc.tuning.electrodes or electrodes)
    for seed, device in devices:
        missing = [e for e in pc.tuning.electrodes or [] if e not in device.electrodes]
        if missing:
            raise ConfigError(
                f"[tuning] electrodes: {missing} not on {pc.device.name!r} with seed {seed}, "
                f"whose electrodes are {list(device.electrodes)}"
            )
    check_names(cfg, registry)
    specs = make_population_specs(cfg, Path(out).absolute(), devices)
    nowhere = Path(out).absolute() / f".check-{os.getpid()}-{time.monotonic_ns()}"
    by_seed = dict(devices)
    for spec in specs:
        run_cfg = parse_config(spec.config, f"study run {spec.key}")
        try:
            TuningRun(run_cfg, nowhere, device=by_seed[spec.seed], registry=registry, plots=False)
        except SysidError as exc:
            raise ConfigError(f"study run {spec.key} cannot start: {one_line(exc)}") from exc
    tuned_index = [electrodes.index(e) for e in tuned]
    return StudyPlan(devices[0][1], electrodes, tuned, tuned_index, specs)
