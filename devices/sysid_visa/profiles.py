"""Instrument profiles: the SCPI commands of an analyzer or a bias source, in TOML.

A profile is a file (``kind = "analyzer"`` or ``"source"``); the shipped ones are in
``sysid_visa/profiles/`` and are named by their file stem (``keysight-ena``,
``keysight-ena-1rx``, ``keysight-n6700``); any other is given by its path. Templates use
``{name}`` fields filled in by the device (docs/instruments.md lists them). A profile is checked
when the device is created: unknown keys, missing commands and templates with unknown fields
are refused then, not in the middle of a run.

An analyzer profile also states what the analyzer can do: ``receivers`` (1 or 2, default 1),
the outputs one sweep measures, and ``tones`` (default 1), the frequencies one acquisition
measures. With ``receivers = 2`` one sweep per drive input measures both outputs, each on its
own trace: the ``select`` commands define trace ``{trace}`` (1 for y1, 2 for y2) before the
sweep, and the ``activate`` commands and ``read`` read it after the sweep.
"""

from __future__ import annotations

import re
import string
import tomllib
from pathlib import Path
from typing import Literal

from pydantic import (
    BaseModel,
    ConfigDict,
    Field,
    ValidationError,
    field_validator,
    model_validator,
)

from sysid_core.errors import ConfigError

__all__ = [
    "SHIPPED",
    "AnalyzerProfile",
    "Connection",
    "SourceProfile",
    "load_profile",
]

#: Folder of the shipped profiles.
SHIPPED = Path(__file__).with_name("profiles")


class _Strict(BaseModel):
    model_config = ConfigDict(extra="forbid", frozen=True)


class Connection(_Strict):
    """How to talk to the instrument."""

    read_termination: str = "\n"
    write_termination: str = "\n"
    timeout_s: float = Field(10.0, gt=0)


def _fields(template: str) -> set[str]:
    return {f for _, f, _, _ in string.Formatter().parse(template) if f}


def _check(
    templates: dict[str, list[str]],
    allowed: dict[str, set[str]],
    hints: dict[str, str] | None = None,
) -> None:
    """Refuse a template that uses a field its command does not have.

    ``hints`` maps a field to a remark added to the message when a template uses it.
    """
    for key, texts in templates.items():
        for text in texts:
            bad = _fields(text) - allowed[key]
            if bad:
                known = ", ".join(sorted(allowed[key])) or "none"
                used = ", ".join(sorted(bad))
                notes = sorted({(hints or {})[f] for f in bad if f in (hints or {})})
                note = f" ({'; '.join(notes)})" if notes else ""
                raise ValueError(
                    f"command {key} = {text!r} uses {{{used}}}; its fields: {known}{note}"
                )


class _Commands(_Strict):
    """What both kinds have: identification, the error queue, setup commands."""

    identify: str = "*IDN?"
    error: str = "SYST:ERR?"
    no_error: str = r"^\s*[+-]?0\s*,"
    setup: list[str] = Field(default_factory=list)


class AnalyzerCommands(_Commands):
    """An analyzer's SCPI commands (templates).

    ``activate`` (only with ``receivers = 2``): written before ``read`` for each trace, to make
    trace ``{trace}`` the one ``read`` reads.
    """

    frequencies: str
    segment: str = "{frequency_hz}"
    select: list[str]
    trigger: list[str] = Field(default_factory=list)
    wait: str = "*OPC?"
    activate: list[str] = Field(default_factory=list)
    read: str


def _count(value: object, low: int, high: int | None = None) -> int:
    """``value`` if an integer in ``[low, high]``, else a ValueError saying what it must be."""
    if (
        isinstance(value, int)
        and not isinstance(value, bool)
        and low <= value
        and (high is None or value <= high)
    ):
        return value
    want = f"{low} or {high}" if high == low + 1 else f"an integer >= {low}"
    raise ValueError(f"must be {want}, got {value!r}")


class AnalyzerProfile(_Strict):
    """``kind = "analyzer"``: sweeps a frequency list and reads each (output, input) pair.

    ``receivers`` (1 or 2) is how many outputs one sweep measures: 1, one sweep per pair (four
    per measurement); 2, one sweep per drive input measuring both outputs (two). ``tones``
    is how many frequencies one acquisition measures (a lock-in's demodulators).
    """

    kind: Literal["analyzer"]
    name: str
    receivers: int = 1
    tones: int = 1
    connection: Connection = Connection()
    commands: AnalyzerCommands
    pairs: dict[str, str]

    @field_validator("receivers", mode="before")
    @classmethod
    def _receivers(cls, value: object) -> int:
        try:
            return _count(value, 1, 2)
        except ValueError as exc:
            raise ValueError(f"{exc} (the outputs one sweep measures)") from None

    @field_validator("tones", mode="before")
    @classmethod
    def _tones(cls, value: object) -> int:
        try:
            return _count(value, 1)
        except ValueError as exc:
            raise ValueError(f"{exc} (the frequencies one acquisition measures)") from None

    @model_validator(mode="after")
    def _templates(self) -> AnalyzerProfile:
        c = self.commands
        setup_fields = {"if_bandwidth_hz", "delay_s"}
        pair = {"parameter", "output", "input"}
        templates = {
            "setup": c.setup,
            "frequencies": [c.frequencies],
            "segment": [c.segment],
            "select": c.select,
            "trigger": c.trigger,
        }
        allowed = {
            "setup": setup_fields,
            "frequencies": {"count", "segments", "start_hz", "stop_hz"},
            "segment": {"frequency_hz", "delay_s", "if_bandwidth_hz"},
            "select": pair,
            "trigger": pair,
        }
        if self.receivers == 1:
            _check(templates, allowed, {"trace": "{trace} needs receivers = 2"})
            if c.activate:
                raise ValueError(
                    "commands.activate is for receivers = 2 (which trace read reads); remove "
                    "it or set receivers = 2"
                )
        else:
            trace = pair | {"trace"}
            _check(
                {**templates, "activate": c.activate, "read": [c.read]},
                {
                    **allowed,
                    "select": trace,
                    "trigger": {"input"},
                    "activate": trace,
                    "read": trace,
                },
                {
                    "parameter": "one sweep per input measures both outputs",
                    "output": "one sweep per input measures both outputs",
                },
            )
            if not any("trace" in _fields(t) for t in c.select):
                raise ValueError(
                    "receivers = 2: a select command must use {trace} to put each output on its "
                    "own trace, e.g. select = [':CALC1:PAR{trace}:DEF {parameter}']"
                )
            if not any("trace" in _fields(t) for t in [*c.activate, c.read]):
                raise ValueError(
                    "receivers = 2: read or an activate command must use {trace} to say which "
                    "trace is read, e.g. activate = [':CALC1:PAR{trace}:SEL']"
                )
        want = {"y1/u1", "y1/u2", "y2/u1", "y2/u2"}
        if set(self.pairs) != want:
            raise ValueError(f"[pairs] must name exactly {sorted(want)}, got {sorted(self.pairs)}")
        re.compile(c.no_error)
        return self


class SourceCommands(_Commands):
    """A bias source's SCPI commands (templates)."""

    set: str
    measure: str
    output_on: str
    output_off: str


class Safety(_Strict):
    """Limits of a source profile."""

    readback_tolerance_v: float = Field(0.005, gt=0)
    max_step_v: float = Field(1.0, gt=0)
    step_settle_s: float = Field(0.05, ge=0)


class SourceProfile(_Strict):
    """``kind = "source"``: sets, reads back and switches each electrode's channel."""

    kind: Literal["source"]
    name: str
    connection: Connection = Connection()
    commands: SourceCommands
    safety: Safety = Safety()

    @model_validator(mode="after")
    def _templates(self) -> SourceProfile:
        c = self.commands
        _check(
            {
                "setup": c.setup,
                "set": [c.set],
                "measure": [c.measure],
                "output_on": [c.output_on],
                "output_off": [c.output_off],
            },
            {
                "setup": set(),
                "set": {"channel", "volts"},
                "measure": {"channel"},
                "output_on": {"channel"},
                "output_off": {"channel"},
            },
        )
        re.compile(c.no_error)
        return self


def shipped(kind: str) -> list[str]:
    """Names of the shipped profiles of ``kind``."""
    names = []
    for path in sorted(SHIPPED.glob("*.toml")):
        if tomllib.loads(path.read_text()).get("kind") == kind:
            names.append(path.stem)
    return names


def load_profile(
    name_or_path: str, kind: Literal["analyzer", "source"]
) -> AnalyzerProfile | SourceProfile:
    """A shipped profile by name, or a profile file by path, checked.

    Raises
    ------
    ConfigError
        Naming the profile and what is wrong with it.
    """
    path = SHIPPED / f"{name_or_path}.toml"
    if not path.exists():
        path = Path(name_or_path).expanduser()
    if not path.is_file():
        raise ConfigError(
            f"no {kind} profile {name_or_path!r}: neither a shipped one "
            f"({', '.join(shipped(kind))}) nor a file"
        )
    try:
        data = tomllib.loads(path.read_text())
    except (OSError, UnicodeDecodeError, tomllib.TOMLDecodeError) as exc:
        raise ConfigError(f"{kind} profile {path}: not a readable TOML file: {exc}") from None
    if data.get("kind") != kind:
        raise ConfigError(f"{path} is not an {kind} profile (kind = {data.get('kind')!r})")
    model = AnalyzerProfile if kind == "analyzer" else SourceProfile
    try:
        return model.model_validate(data)
    except ValidationError as exc:
        first = exc.errors()[0]
        where = ".".join(str(x) for x in first["loc"]) or "profile"
        msg = str(first["msg"]).removeprefix("Value error, ")
        if first["type"] == "extra_forbidden":
            msg = "unknown key"
        raise ConfigError(f"{kind} profile {path}: {where}: {msg}") from None
