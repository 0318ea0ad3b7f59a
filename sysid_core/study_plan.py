"""What a study runs: its configuration, every run's spec, and the checks before any starts.

A study configuration is a ``sysid tune`` configuration plus a ``[study]`` table (the grid of
start biases, the model structures and objectives compared, the iterations). :func:`make_specs`
turns it into independent :class:`RunSpec` s in a fixed order; :func:`plan_study` checks them
all before anything runs or is written.

Length: a little over the project's 300 lines: the study's configuration models and every
check of its ``[study]`` table, with messages naming the key, belong together.
"""

from __future__ import annotations

import itertools
import math
import os
import re
import time
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from pydantic import BaseModel, ConfigDict, Field, ValidationError

from sysid_core.config import PipelineConfig, _describe, parse_config, read_toml
from sysid_core.device import Device
from sysid_core.errors import ConfigError, PluginNotFoundError, SysidError
from sysid_core.registry import Registry

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
    gyros: int | None = Field(None, ge=1, le=100_000)


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
        """Objectives compared (default: the ``[objective]`` name)."""
        if self.study.objectives is None:
            return [self.pipeline.objective.name]
        return list(self.study.objectives)


def load_study_config(path: str | os.PathLike[str]) -> StudyConfig:
    """Read a study configuration (the ``sysid tune`` tables plus ``[study]``).

    Only the syntax and the types are checked here; :func:`plan_study` checks the rest.
    """
    data = read_toml(path)
    study = data.pop("study", {})
    parse_config(data, str(path))  # the pipeline tables, with their messages
    try:
        pipeline = PipelineConfig.model_validate(data)
        settings = _StudyTable.model_validate({"study": study}).study
    except ValidationError as exc:
        raise ConfigError(f"{path}: {_describe(exc)}") from None
    return StudyConfig(pipeline=pipeline, study=settings)


@dataclass(frozen=True)
class RunSpec:
    """One independent run of the study.

    In a population study (``[study] gyros``) ``index`` is the gyro's position, ``seed`` its
    device seed and ``structure`` the name in ``[study] structures`` (``auto`` for the
    structure the device names); ``config`` holds what the run really uses.
    """

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


#: ``[study] structures`` entry for the structure each device names (its ``structure``).
AUTO_STRUCTURE = "auto"


def population_seeds(cfg: StudyConfig) -> list[int]:
    """Device seeds of a population study: ``seed * 100003 + k`` for ``k < gyros``."""
    return [cfg.study.seed * 100003 + k for k in range(cfg.study.gyros or 0)]


def device_structure(device: Device, seed: int) -> str:
    """The model structure a device names (its ``structure`` attribute), for ``auto``."""
    name = getattr(device, "structure", None)
    if not isinstance(name, str) or not name:
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
    if st.gyros is not None and (st.starts is not None or "grid" in st.model_fields_set):
        raise ConfigError(
            "[study] gyros runs every gyro from its native state (0 V on every electrode): "
            "remove starts and grid, or remove gyros to study start biases on one device"
        )
    if st.gyros is None and AUTO_STRUCTURE in st.structures:
        raise ConfigError(
            f"[study] structures: {AUTO_STRUCTURE!r} is for population studies ([study] gyros); "
            'name the structures, e.g. structures = ["act", "sen"]'
        )
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
    objectives = "[study] objectives" if st.objectives is not None else "[objective] name"
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


def plan_study(
    cfg: StudyConfig, out: str | os.PathLike[str], registry: Registry | None = None
) -> StudyPlan:
    """Check every run of the study before any starts; return the runs. Writes nothing.

    The ``[study]`` lists must be non-empty, without repeats (and not both ``starts`` and
    ``grid``); then every run is built as a :class:`~sysid_core.pipeline.TuningRun` (never
    run, in a folder that does not exist), which checks its configuration, builds each of its
    components from ``registry`` with their options, and checks its device, start bias, sweeps
    and first experiment design. Each error is a :class:`~sysid_core.errors.ConfigError` naming
    the ``[study]`` key it comes from, the run and what to do.
    """
    from sysid_core.pipeline import TuningRun
    from sysid_core.registry import get_registry

    registry = registry or get_registry()
    _check_settings(cfg)
    pc = cfg.pipeline
    if cfg.study.gyros is not None:
        return _plan_population(cfg, out, registry)
    try:
        device = registry.device(pc.device.name, **pc.device.options)
    except SysidError as exc:
        raise ConfigError(f"[device]: {_one_line(exc)}") from exc
    electrodes = [str(e) for e in device.electrodes]
    tuned = list(pc.tuning.electrodes or electrodes)
    unknown = [e for e in tuned if e not in electrodes]
    if unknown:
        raise ConfigError(
            f"[tuning] electrodes: {unknown} not on device {pc.device.name!r}, whose electrodes "
            f"are {electrodes}"
        )
    tuned_index = [electrodes.index(e) for e in tuned]
    _check_names(cfg, registry)
    specs = make_specs(cfg, Path(out).absolute(), electrodes)
    _check_starts(cfg, device, electrodes, tuned_index, specs)
    nowhere = Path(out).absolute() / f".check-{os.getpid()}-{time.monotonic_ns()}"
    for spec in specs:
        run_cfg = parse_config(spec.config, f"study run {spec.key}")
        try:
            TuningRun(run_cfg, nowhere, device=device, registry=registry, plots=False)
        except SysidError as exc:
            raise ConfigError(f"study run {spec.key} cannot start: {_one_line(exc)}") from exc
    return StudyPlan(device, electrodes, tuned, tuned_index, specs)


def _plan_population(
    cfg: StudyConfig, out: str | os.PathLike[str], registry: Registry
) -> StudyPlan:
    """:func:`plan_study` of a population study: one device per seed, each run checked."""
    from sysid_core.pipeline import TuningRun

    pc = cfg.pipeline
    devices: list[tuple[int, Device]] = []
    for seed in population_seeds(cfg):
        try:
            devices.append(
                (seed, registry.device(pc.device.name, **{**pc.device.options, "seed": seed}))
            )
        except SysidError as exc:
            raise ConfigError(f"[device] with seed {seed}: {_one_line(exc)}") from exc
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
    _check_names(cfg, registry)
    specs = make_population_specs(cfg, Path(out).absolute(), devices)
    nowhere = Path(out).absolute() / f".check-{os.getpid()}-{time.monotonic_ns()}"
    by_seed = dict(devices)
    for spec in specs:
        run_cfg = parse_config(spec.config, f"study run {spec.key}")
        try:
            TuningRun(run_cfg, nowhere, device=by_seed[spec.seed], registry=registry, plots=False)
        except SysidError as exc:
            raise ConfigError(f"study run {spec.key} cannot start: {_one_line(exc)}") from exc
    tuned_index = [electrodes.index(e) for e in tuned]
    return StudyPlan(devices[0][1], electrodes, tuned, tuned_index, specs)


def _check_names(cfg: StudyConfig, registry: Registry) -> None:
    """Every component name the study uses is installed (the message names its key)."""
    pc = cfg.pipeline
    objectives = "[study] objectives" if cfg.study.objectives is not None else "[objective] name"
    wanted = [
        ("[study] structures", "model structure", s)
        for s in cfg.study.structures
        if s != AUTO_STRUCTURE
    ]
    wanted += [(objectives, "objective", o) for o in cfg.objectives]
    wanted += [("[solver]", "solver", pc.solver.name)]
    wanted += [("[tuning] criterion", "tuning criterion", pc.tuning.criterion)]
    for key, kind, name in wanted:
        try:
            registry.get(kind, name)
        except PluginNotFoundError as exc:
            raise ConfigError(f"{key}: {name!r} cannot be used: {_one_line(exc)}") from exc


def _check_starts(
    cfg: StudyConfig,
    device: Device,
    electrodes: list[str],
    tuned_index: list[int],
    specs: list[RunSpec],
) -> None:
    """Every start bias inside the device's limits, named by the key it comes from."""
    low, high = (float(x) for x in device.bias_limits)
    key = "starts" if cfg.study.starts is not None else "grid"
    for start in dict.fromkeys(spec.start for spec in specs):
        for p, v in enumerate(start):
            if low <= v <= high:
                continue
            if p in tuned_index:
                tuned = [start[i] for i in tuned_index]
                raise ConfigError(
                    f"[study] {key}: start {tuned} puts {v} V on electrode {electrodes[p]}, "
                    f"outside the device's bias limits [{low}, {high}] V; keep every "
                    f"{'start' if key == 'starts' else 'grid value'} inside them"
                )
            raise ConfigError(
                f"[tuning] start_bias: {v} V on electrode {electrodes[p]} (held during the "
                f"study) is outside the device's bias limits [{low}, {high}] V"
            )
