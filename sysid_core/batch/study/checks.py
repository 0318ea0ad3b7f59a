"""The checks of a study before any run starts, each message naming its key."""

from __future__ import annotations

import math
from typing import Any

from sysid_core.batch.study.config import AUTO_STRUCTURE, SAFE_NAME, RunSpec, StudyConfig
from sysid_core.device.protocol import Device
from sysid_core.errors import ConfigError, PluginNotFoundError, SysidError
from sysid_core.plugin.registry import Registry

__all__ = ["check_list", "check_names", "check_settings", "check_starts", "one_line"]


def one_line(exc: BaseException) -> str:
    """The message of ``exc`` on one line, after its type unless it is a :class:`SysidError`."""
    text = str(exc) if isinstance(exc, SysidError) else f"{type(exc).__name__}: {exc}"
    return " ".join(text.split())


def check_list(key: str, values: list[Any] | None, example: str, unset: str) -> None:
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


def check_settings(cfg: StudyConfig) -> None:
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
    check_list(
        "starts", st.starts, "starts = [[0.0, 0.0], [3.0, -3.0]]", "or remove it to use grid"
    )
    if st.starts is None:
        check_list("grid", st.grid, "grid = [-3, 0, 3]", "or remove it for the paper's grid")
    check_list(
        "structures",
        st.structures,
        'structures = ["act", "sen"]',
        "or remove it to compare act and sen",
    )
    check_list(
        "objectives",
        st.objectives,
        'objectives = ["minimax"]',
        "or remove it to use the [model] objective",
    )
    objectives = "[study] objectives" if st.objectives is not None else "[objective] name"
    for key, names in (("[study] structures", st.structures), (objectives, cfg.objectives)):
        for name in names:
            if not SAFE_NAME.fullmatch(name):
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


def check_names(cfg: StudyConfig, registry: Registry) -> None:
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
            raise ConfigError(f"{key}: {name!r} cannot be used: {one_line(exc)}") from exc


def check_starts(
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
