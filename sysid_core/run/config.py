"""Pipeline configuration files (TOML), validated with pydantic.

Tables (the public contract, docs/contracts.md)::

    [device]          name = "cloverleaf", plus the device's options
    [model]           structure = "act" | "sen", order = 2, bias_terms = 1
    [model.options]   the structure's other options
    [objective]       name = "least-squares" | "minimax", plus the objective's options
    [solver]          name = "clarabel" | "scs", plus the solver's options
    [tuning]          criterion, start_bias, acceptance_hz, max_iterations, max_bench_minutes,
                      aim, electrodes
                      (subset to tune), and the criterion options target_hz, tolerance_hz
    [tuning.options]  the criterion's other options
    [experiment]      band_hz, resolution_hz, bias_step, refine_span_hz, refine_resolution_hz,
                      verify_span_hz, verify_resolution_hz, max_points, timeout_s

**The rule for plugin options**, the same for every kind: the key that names the plugin
(``name``, ``structure``, ``criterion``) chooses it, and its options are the other keys of its
table, or, in ``[model]`` and ``[tuning]``, which also hold the run's own keys, the keys of their
``options`` sub-table. Every option is checked against the plugin's own parameters by one
function (:func:`sysid_core.plugin.options.check_options`) before anything is measured.

Unknown keys of the fixed tables are an error that names the key and its table.
"""

from __future__ import annotations

import hashlib
import json
import math
import os
import tomllib
from collections.abc import Sequence
from pathlib import Path
from typing import Any, Literal

from pydantic import BaseModel, ConfigDict, Field, StrictBool, ValidationError, field_validator

from sysid_core.drift.policy import REMOVED, DriftPolicy
from sysid_core.errors import ConfigError
from sysid_core.identification.objective import DEFAULT_OBJECTIVE
from sysid_core.measure.sweeps import SweepPlan
from sysid_core.model.structures import DEFAULT_BIAS_TERMS, DEFAULT_ORDER, DEFAULT_STIFFNESS

__all__ = ["PipelineConfig", "load_config", "parse_config", "read_toml"]


class _Strict(BaseModel):
    model_config = ConfigDict(extra="forbid", frozen=True)


class DeviceConfig(BaseModel):
    """``[device]``: the device name and its factory's options (checked by the factory)."""

    model_config = ConfigDict(extra="allow", frozen=True)
    name: str

    @property
    def options(self) -> dict[str, Any]:
        """Keyword options for the device factory."""
        return dict(self.model_extra or {})


class ModelConfig(_Strict):
    """``[model]``: the structure, its ``order``, ``bias_terms``, ``stiffness`` and ``options``.

    ``bias_terms`` (default 1) and ``stiffness`` (default ``"auto"``) are given to structures
    that take them (``act``, ``sen``); ``bias_terms = 0`` and ``stiffness = "linear"`` are the
    paper's model. ``drift``: ``"auto"`` (default), ``"track"`` once the measurements carry
    time stamps (a bench with a clock) and ``"none"`` while they do not; ``"none"``;
    ``"track"``, every answer solved for the gyro as it will be at the next verification, the
    model anchored on the latest verified windows (:mod:`sysid_core.drift.tracker`).
    ``drift_split_hz_per_h``: how fast the split may drift on the bench (Hz/h, the prior
    standard deviation of each component of its rate; unset, the stated trend's). See
    docs/drift-model.md (:mod:`sysid_core.drift.policy`).
    """

    structure: str = "act"
    order: int = DEFAULT_ORDER
    bias_terms: int = DEFAULT_BIAS_TERMS
    stiffness: str = DEFAULT_STIFFNESS
    drift: Literal["auto", "none", "track"] = "auto"
    drift_split_hz_per_h: float | None = Field(None, gt=0, allow_inf_nan=False)
    options: dict[str, Any] = Field(default_factory=dict)

    @property
    def policy(self) -> DriftPolicy:
        """``drift`` parsed once into what the run does about a drifting gyro.

        With ``drift_split_hz_per_h``, the lab's prior on the split's rate (docs/drift-model.md).
        """
        return DriftPolicy.parse(self.drift, self.drift_split_hz_per_h)

    def structure_options(self, accepted: Sequence[str]) -> dict[str, Any]:
        """Keyword options for a structure's factory taking ``accepted`` keywords.

        ``order`` always; ``bias_terms`` when the structure takes it (or when set explicitly, so
        that a structure without it says so); then ``options``.
        """
        out: dict[str, Any] = {"order": self.order}
        if "bias_terms" in accepted or "bias_terms" in self.model_fields_set:
            out["bias_terms"] = self.bias_terms
        if "stiffness" in accepted or "stiffness" in self.model_fields_set:
            out["stiffness"] = self.stiffness
        return {**out, **self.options}


class ObjectiveConfig(BaseModel):
    """``[objective]``: the fit objective's name and its options."""

    model_config = ConfigDict(extra="allow", frozen=True)
    name: str = DEFAULT_OBJECTIVE

    @property
    def options(self) -> dict[str, Any]:
        """Keyword options for the objective's factory."""
        return dict(self.model_extra or {})


class SolverConfig(BaseModel):
    """``[solver]``: backend name and its options (checked by the backend)."""

    model_config = ConfigDict(extra="allow", frozen=True)
    name: str = "clarabel"

    @property
    def options(self) -> dict[str, Any]:
        """Keyword options for the solver backend."""
        return dict(self.model_extra or {})


class TuningConfig(_Strict):
    """``[tuning]``.

    ``max_bench_minutes`` bounds the run by the bench clock (the device's time stamps, else the
    estimated bench time): no measurement starts that would end past it; unset, it is the
    larger of an hour and 1200 dwells of the gyro (:mod:`sysid_core.clock.budget`).
    ``max_iterations`` caps the iterations (default 300); the verdicts that look ahead count
    the iterations the budget affords within it. ``pair`` (on by default): for degenerate modes
    with more than two ``electrodes``, a lean run tunes the pair of them that reaches the goal
    with the least voltage, and another pair, or every electrode, once that pair's answer is
    beyond its reach (:mod:`sysid_core.measure.pairing`).
    """

    criterion: str = "degenerate"
    start_bias: list[float] | None = None
    acceptance_hz: float = Field(0.01, gt=0)
    max_iterations: int | None = Field(None, ge=1, le=10_000)
    max_bench_minutes: float | None = Field(None, gt=0)
    aim: float | None = Field(None, gt=0, le=1)
    target_hz: float | None = Field(None, gt=0)
    electrodes: list[str] | None = None
    pair: bool = True
    tolerance_hz: float | None = Field(None, gt=0)
    options: dict[str, Any] = Field(default_factory=dict)

    @property
    def criterion_options(self) -> dict[str, Any]:
        """Keyword options for the criterion's factory.

        ``options`` plus ``target_hz`` and ``tolerance_hz`` when given.
        """
        given = {k: v for k in ("target_hz", "tolerance_hz") if (v := getattr(self, k)) is not None}
        both = sorted(set(given) & set(self.options))
        if both:
            raise ConfigError(
                f"[tuning] {both[0]} is given twice, in [tuning] and in [tuning.options]; keep one"
            )
        return {**self.options, **given}

    @field_validator("electrodes")
    @classmethod
    def _unique(cls, v: list[str] | None) -> list[str] | None:
        if v is not None and len(set(v)) != len(v):
            raise ValueError("electrodes must not repeat")
        if v is not None and not v:
            raise ValueError("electrodes must not be empty")
        return v


class ExperimentConfig(_Strict):
    """``[experiment]``: the identification sweeps and the verification sweep.

    The first iteration sweeps ``band_hz`` (default: the device's band) at ``resolution_hz``.
    Later iterations sweep ``refine_span_hz`` around the last measured modal frequency at
    ``refine_resolution_hz`` (0 disables this and sweeps the whole band every time, as the
    paper does). Defaults: 6 Hz at 0.05 Hz, 121 points like the paper's sweeps. Measured on the
    cloverleaf with 1.25 % feedthrough from the native state (3 seeds), two iterations then leave
    0.4-1.7 mHz (10 Hz at 0.1 Hz: 1.4-2.8 mHz) instead of 23-74 mHz with the whole band, because
    the band edges, where feedthrough dominates the response, no longer bias the fit.

    ``refine_bias_step`` (default 0.25 V) is the step of eq. (18) from the second iteration on
    (``None``: ``bias_step`` throughout). Near the answer a shorter step measures the local
    slope of a stiffness that is not exactly affine in ``w`` (a real bias law): measured on 12
    random gyros, the true split after iteration 2 was under 2 mHz for 7 of them against 1 of
    12 with 1 V, 0.1 V was worse than 0.25 V (noise).

    ``protocol`` (default ``"lean"``) decides where the sweeps go. ``"lean"``
    (:mod:`sysid_core.measure.lean`): the whole band only to locate the modes (at most 61 points),
    every other sweep only around where the modes are known or predicted to be, and every sweep
    of the run reused by later fits; iterations after the first measure nothing but the
    verification while that is the cheaper way to the acceptance at the rate the split falls
    (:mod:`sysid_core.measure.contraction`); otherwise the sweeps near the bias, with the local
    design there. ``"full"``: every iteration measures its whole design over the band (the
    first) or ``refine_span_hz`` (later) at the configured resolutions, as the paper does.
    Measured on the cloverleaf (49 starts, ``docs/studies/bench-time-lab.md``): to a true split
    of 1 mHz, lean needs a median of under 200 points against about 1400.

    ``locate_points`` (default 61) is the most points of a lean run's whole-band sweep, which
    only locates the modes (the band at ``resolution_hz`` when that has fewer). Measured with 31
    (docs/studies/bench-time-lab.md): with a good lab's drift, 10-30 % less time to a split of
    1 mHz on the cloverleaf and on 72 random gyros, as many ending within it; over
    docs/studies/drift-lab.md's 14 population rows (the uncontrolled lab lost most) 233 of 336
    runs ended within 2 mHz against 247.

    ``motion_ppm_per_h`` (default 60, an uncontrolled lab) is how fast the modes may move on a
    bench with a clock: a lean window around modes located earlier is widened by it
    (:mod:`sysid_core.measure.motion`).

    ``probe`` (default ``"auto"``: on when the device states its dwell per acquisition, a
    bench with a clock; ``true``/``false`` force it): the run's first look at the band is a
    probe of every fourth locating point (at least 16). A probe that shows both modes stands
    as the locating sweep, and scouts step as it did; on a quiet bench (its noise under 2 % of
    its response) the first design is one-sided under the ``auto`` law and scouts hold at least
    6 points instead of 8 (:mod:`sysid_core.measure.locating`). With a clock
    (docs/studies/bench-time-lab.md) the cloverleaf reaches a true split of 1 mHz in a median of
    14.4 minutes with one tone instead of 30.0.

    ``max_passes`` (default 1: never repeat) bounds how many passes of a verification window
    are averaged when its noise hides the split (:mod:`sysid_core.measure.passes`): for a bench of
    low SNR whose drift is slow (docs/drift.md, "Averaging a window").

    ``max_points`` (default 20 000) bounds the points of any sweep: a resolution typed wrong
    (``1e-6``) is refused before anything is measured instead of running for days.
    """

    band_hz: tuple[float, float] | None = None
    resolution_hz: float = Field(0.5, gt=0)
    bias_step: float = Field(1.0, gt=0)
    refine_bias_step: float | None = Field(0.25, gt=0)
    design: Literal["one-sided", "two-sided"] | None = None
    protocol: Literal["lean", "full"] = "lean"
    dwell_s: float | None = Field(None, gt=0)
    tones: int | None = Field(None, ge=1, le=1024)
    settle_s: float | None = Field(None, ge=0)
    refine_span_hz: float = Field(6.0, ge=0)
    refine_resolution_hz: float = Field(0.05, gt=0)
    verify_span_hz: float = Field(1.0, gt=0)
    verify_resolution_hz: float = Field(0.01, gt=0)
    max_points: int = Field(20_000, ge=11)
    max_passes: int = Field(1, ge=1, le=64)
    locate_points: int = Field(61, ge=11, le=4001)
    motion_ppm_per_h: float = Field(60.0, ge=0, le=1e5)
    probe: StrictBool | Literal["auto"] = "auto"
    timeout_s: float | None = Field(None, gt=0)

    @field_validator("probe", mode="before")
    @classmethod
    def _probe(cls, v: object) -> object:
        if v is True or v is False or v == "auto":
            return v
        raise ValueError('must be true, false or "auto" (probe on a bench with a clock)')

    @field_validator("band_hz")
    @classmethod
    def _ordered(cls, v: tuple[float, float] | None) -> tuple[float, float] | None:
        if v is not None and not (math.isfinite(v[0]) and math.isfinite(v[1]) and 0 < v[0] < v[1]):
            raise ValueError(f"must be [low, high] in Hz with 0 < low < high, got [{v[0]}, {v[1]}]")
        return v

    def sweep_plan(self, device_band_hz: Sequence[float], tones: int = 1) -> SweepPlan:
        """The sweeps' plan of this table for a device, checked.

        The device's ``band_hz``, and its ``tones`` (frequencies per acquisition).
        """
        band = (float(device_band_hz[0]), float(device_band_hz[1]))
        return SweepPlan(
            band_hz=self.band_hz if self.band_hz is not None else band,
            resolution_hz=self.resolution_hz,
            refine_span_hz=self.refine_span_hz,
            refine_resolution_hz=self.refine_resolution_hz,
            verify_span_hz=self.verify_span_hz,
            verify_resolution_hz=self.verify_resolution_hz,
            max_points=self.max_points,
            tones=max(int(tones), 1),
            motion_ppm_per_h=self.motion_ppm_per_h,
        ).check(band)


class PipelineConfig(_Strict):
    """The whole configuration of ``sysid tune``."""

    device: DeviceConfig
    model: ModelConfig = ModelConfig()
    objective: ObjectiveConfig = ObjectiveConfig()
    solver: SolverConfig = SolverConfig()
    tuning: TuningConfig = TuningConfig()
    experiment: ExperimentConfig = ExperimentConfig()

    def digest(self) -> str:
        """A hash of the settings, to check that ``--resume`` continues the same run."""
        text = json.dumps(self.model_dump(mode="json"), sort_keys=True)
        return hashlib.sha256(text.encode()).hexdigest()[:16]


def describe_validation_error(err: ValidationError) -> str:
    """One line naming every bad key, its table, the value given and what is expected."""
    parts = []
    for e in err.errors():
        loc = [str(x) for x in e["loc"]]
        # an index into a list or tuple names its key, not a key of its own
        keys = [x for x in loc[1:] if not x.isdigit()]
        where = f"[{loc[0]}]" + (f" {'.'.join(keys)}" if keys else "")
        msg = str(e["msg"]).removeprefix("Value error, ")
        if e["type"] == "extra_forbidden":
            parts.append(
                f"unknown key {loc[-1]!r} in [{loc[0]}]"
                if len(loc) > 1
                else f"unknown table [{loc[0]}]"
            )
        elif e["type"] == "missing" and loc[-1].isdigit():
            parts.append(f"{where}: too few values")
        elif e["type"] == "missing":
            parts.append(f"missing key {where}")
        elif e["type"] == "too_long":
            parts.append(f"{where}: too many values")
        else:
            given = e.get("input")
            shown = f" = {given!r}" if isinstance(given, (str, int, float, bool)) else ""
            parts.append(f"{where}{shown}: {msg}")
    return "; ".join(parts)


#: Keys that moved, and where to: a clear error instead of "unknown key".
_MOVED = {
    ("model", "objective"): "[objective] name",
    ("model", "objective_options"): "the [objective] table (its keys are the options)",
}


def parse_config(data: dict[str, Any], source: str = "config") -> PipelineConfig:
    """Validate a configuration mapping (as read from TOML)."""
    for (table, key), where in _MOVED.items():
        if isinstance(data.get(table), dict) and key in data[table]:
            raise ConfigError(f"{source}: [{table}] {key} has moved to {where}")
    drift = data.get("model", {}).get("drift") if isinstance(data.get("model"), dict) else None
    if isinstance(drift, str) and drift in REMOVED:
        raise ConfigError(f"{source}: {REMOVED[drift]}")
    try:
        return PipelineConfig.model_validate(data)
    except ValidationError as exc:
        raise ConfigError(f"{source}: {describe_validation_error(exc)}") from None


def read_toml(path: str | os.PathLike[str]) -> dict[str, Any]:
    """The tables of a TOML file; a missing or malformed file is a ConfigError."""
    path = Path(path)
    if not path.exists():
        raise ConfigError(f"no configuration file at {path}")
    if not path.is_file():
        raise ConfigError(f"{path} is not a file; give a TOML configuration file")
    try:
        text = path.read_text(encoding="utf-8")
    except UnicodeDecodeError:
        raise ConfigError(
            f"{path} is not a text file (not UTF-8); give a TOML configuration file"
        ) from None
    except OSError as exc:
        raise ConfigError(f"cannot read {path}: {exc.strerror}") from None
    try:
        return tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        raise ConfigError(f"{path}: not valid TOML: {exc}") from None


def load_config(path: str | os.PathLike[str]) -> PipelineConfig:
    """Read and validate a TOML configuration file."""
    return parse_config(read_toml(path), str(path))
