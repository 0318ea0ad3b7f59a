"""Column maps: how to read a text export that is not in the toolkit's own CSV layout.

A column map is a TOML table of a manifest (``docs/measured-data.md``): ``[columns]`` for every
experiment, and one experiment's ``[experiment.columns]``, whose keys replace the manifest's::

    [columns]
    delimiter = ";"              # one character, or "whitespace" (default ",")
    decimal = ","                # "." (default) or ","
    comment = ["#", "!"]         # lines whose first field starts so are skipped (default "#")
    skip_lines = 0               # lines skipped at the top of each file, whatever they hold
    header = true                # the first line that is not skipped names the columns
    frequency = "frequency"      # a column: its name in the header, or its number (1 = first)
    frequency_unit = "Hz"        # Hz (default), kHz, MHz, GHz or rad/s
    time_s = "time"              # optional: each point's time stamp ...
    time_unit = "s"              # ... in s (default), ms, us, ns, or "ticks" with ticks_per_s
    response_units = "V/V"       # optional: the response's units
    y1 = { mag = "r1", phase_deg = "theta1" }
    y2 = { mag = "r2", phase_deg = "theta2" }

Each channel gives two columns: ``re`` and ``im``; ``mag`` (linear) and ``phase_deg`` or
``phase_rad``; or ``db`` (``20 log10 |H|``) and ``phase_deg`` or ``phase_rad``. Which channels a
map names follows the experiment's files (:data:`LAYOUTS`): ``y1_u1``, ``y1_u2``, ``y2_u1``,
``y2_u2`` for one file holding them all; ``y1`` and ``y2`` for one file per drive input
(``files = { u1 = ..., u2 = ... }``); ``channel`` for one file per channel
(``files = { y1_u1 = ..., ... }``).

:func:`parse_column_map` checks a map (:class:`~sysid_core.errors.ManifestError`, one line naming
the key); :mod:`sysid_core.formats.columnsweep` reads files with it.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from pathlib import Path
from typing import Annotated, Any, Literal

from pydantic import (
    BaseModel,
    ConfigDict,
    Field,
    PlainValidator,
    ValidationError,
    field_validator,
    model_validator,
)

from sysid_core.errors import FileFormatError, ManifestError
from sysid_core.formats.engine import engine_for

__all__ = [
    "CHANNEL_KEYS",
    "FREQUENCY_UNITS",
    "INPUT_KEYS",
    "LAYOUTS",
    "PARTS",
    "TEXT_FORMATS",
    "TIME_UNITS",
    "ChannelColumns",
    "ColumnMap",
    "ColumnRef",
    "experiment_column_map",
    "parse_column_map",
]

#: The channels of a response, ``y<output>_u<input>``, in the toolkit's order.
CHANNEL_KEYS = ("y1_u1", "y1_u2", "y2_u1", "y2_u2")
#: The drive inputs (keys of ``files`` for one file per input).
INPUT_KEYS = ("u1", "u2")
#: Per layout of an experiment's files: the keys of ``files`` and the channels the map names.
LAYOUTS: dict[str, tuple[tuple[str, ...], tuple[str, ...]]] = {
    "file": (("",), CHANNEL_KEYS),
    "input": (INPUT_KEYS, ("y1", "y2")),
    "channel": (CHANNEL_KEYS, ("channel",)),
}
#: The parts a channel's columns can hold.
PARTS = ("re", "im", "mag", "db", "phase_deg", "phase_rad")
#: Each frequency unit's factor to Hz.
FREQUENCY_UNITS = {"Hz": 1.0, "kHz": 1e3, "MHz": 1e6, "GHz": 1e9, "rad/s": 1 / (2 * math.pi)}
#: Seconds per unit of ``time_unit`` (``"ticks"``: ``1 / ticks_per_s``).
TIME_UNITS = {"s": 1.0, "ms": 1e-3, "us": 1e-6, "ns": 1e-9}
_PAIRS = (
    {"re", "im"},
    {"mag", "phase_deg"},
    {"mag", "phase_rad"},
    {"db", "phase_deg"},
    {"db", "phase_rad"},
)


def _column(value: object) -> str | int:
    """A column reference: a non-empty name or a number from 1."""
    if isinstance(value, str) and value.strip():
        return value.strip()
    if isinstance(value, int) and not isinstance(value, bool) and value >= 1:
        return value
    raise ValueError(
        f"{value!r} is not a column: give its name in the header (a string) or its number "
        "(1 = the first column)"
    )


#: A column: its name in the file's header, or its number counted from 1.
ColumnRef = Annotated[str | int, PlainValidator(_column)]


class ChannelColumns(BaseModel):
    """One channel's two columns: ``re``/``im``, ``mag`` or ``db`` with a phase in deg or rad."""

    model_config = ConfigDict(extra="forbid", frozen=True, strict=True)
    re: ColumnRef | None = None
    im: ColumnRef | None = None
    mag: ColumnRef | None = None
    db: ColumnRef | None = None
    phase_deg: ColumnRef | None = None
    phase_rad: ColumnRef | None = None

    @model_validator(mode="after")
    def _one_pair(self) -> ChannelColumns:
        given = {part for part in PARTS if getattr(self, part) is not None}
        if given not in _PAIRS:
            raise ValueError(
                f"gives {', '.join(sorted(given)) or 'no column'}; a channel needs re and im, mag "
                "and phase_deg (or phase_rad), or db and phase_deg (or phase_rad)"
            )
        return self

    def parts(self) -> list[tuple[str, str | int]]:
        """``(part, column)`` for its two columns, in the order of :data:`PARTS`."""
        return [(p, c) for p in PARTS if (c := getattr(self, p)) is not None]


class ColumnMap(BaseModel):
    """A checked column map (see the module for its keys and their defaults)."""

    model_config = ConfigDict(extra="forbid", frozen=True, strict=True)
    delimiter: str = ","
    decimal: Literal[".", ","] = "."
    comment: tuple[str, ...] = ("#",)
    skip_lines: int = Field(0, ge=0)
    header: bool = True
    frequency: ColumnRef
    frequency_unit: Literal["Hz", "kHz", "MHz", "GHz", "rad/s"] = "Hz"
    time_s: ColumnRef | None = None
    time_unit: Literal["s", "ms", "us", "ns", "ticks"] = "s"
    ticks_per_s: float | None = Field(None, gt=0, allow_inf_nan=False)
    response_units: str = ""
    y1_u1: ChannelColumns | None = None
    y1_u2: ChannelColumns | None = None
    y2_u1: ChannelColumns | None = None
    y2_u2: ChannelColumns | None = None
    y1: ChannelColumns | None = None
    y2: ChannelColumns | None = None
    channel: ChannelColumns | None = None

    @field_validator("comment", mode="before")
    @classmethod
    def _prefixes(cls, value: object) -> object:
        items = [value] if isinstance(value, str) else value
        if not isinstance(items, list) or not all(isinstance(p, str) and p for p in items):
            raise ValueError(
                f"{value!r}: expected a prefix or a list of prefixes, e.g. ['#', '!'] "
                "(non-empty strings)"
            )
        return tuple(items)

    @field_validator("delimiter")
    @classmethod
    def _delimiter(cls, value: str) -> str:
        if value != "whitespace" and (len(value) != 1 or value.isalnum() or value in ".+-\"'"):
            raise ValueError(
                "expected one character such as ',' ';' or '\\t' (not a letter, digit, sign, "
                "point or quote), or 'whitespace' (runs of spaces and tabs)"
            )
        return value

    @property
    def seconds_per_time_unit(self) -> float:
        """What one unit of the ``time_s`` column is, in seconds."""
        if self.time_unit == "ticks":
            assert self.ticks_per_s is not None  # checked by the model
            return 1.0 / self.ticks_per_s
        return TIME_UNITS[self.time_unit]

    @model_validator(mode="after")
    def _consistent(self) -> ColumnMap:
        if (self.time_unit == "ticks") != (self.ticks_per_s is not None):
            raise ValueError(
                "time_unit = 'ticks' needs ticks_per_s (the clock's rate, e.g. 60e6 for a "
                "lock-in's 60 MHz timestamp), and ticks_per_s needs time_unit = 'ticks'"
            )
        if self.decimal == "," and self.delimiter == ",":
            raise ValueError(
                "decimal = ',' needs another delimiter (e.g. ';'): with ',' for both a row "
                "cannot be split"
            )
        if not self.header:
            named = [(key, ref) for key, ref in self.columns() if isinstance(ref, str)]
            if named:
                key, ref = named[0]
                raise ValueError(
                    f"header = false, so columns are given by number (1 = the first), but {key} "
                    f"is the name {ref!r}"
                )
        self.layout  # noqa: B018 (raises if the channels are not one of the layouts)
        return self

    @property
    def layout(self) -> str:
        """Which files the map is for: ``file``, ``input`` or ``channel`` (:data:`LAYOUTS`)."""
        given = {key for key in (*CHANNEL_KEYS, "y1", "y2", "channel") if getattr(self, key)}
        for name, (_, keys) in LAYOUTS.items():
            if given == set(keys):
                return name
        raise ValueError(
            f"the map gives the channel(s) {', '.join(sorted(given)) or '(none)'}; give either "
            "y1_u1, y1_u2, y2_u1 and y2_u2 (one file holds the response), y1 and y2 (one file per "
            "drive input: files = { u1 = ..., u2 = ... }) or channel (one file per channel: "
            "files = { y1_u1 = ..., y1_u2 = ..., y2_u1 = ..., y2_u2 = ... })"
        )

    def channels(self) -> dict[str, ChannelColumns]:
        """The channels' columns, by the keys of the map's layout."""
        return {key: getattr(self, key) for key in LAYOUTS[self.layout][1]}

    def columns(self) -> list[tuple[str, str | int]]:
        """Every column the map reads, as ``(key, column)``; keys such as ``y1.phase_deg``."""
        found: list[tuple[str, str | int]] = [("frequency", self.frequency)]
        if self.time_s is not None:
            found.append(("time_s", self.time_s))
        for key in (*CHANNEL_KEYS, "y1", "y2", "channel"):
            channel: ChannelColumns | None = getattr(self, key)
            if channel is not None:
                found += [(f"{key}.{part}", ref) for part, ref in channel.parts()]
        return found


def parse_column_map(
    table: Mapping[str, Any], where: str, tables: Mapping[str, str] | None = None
) -> ColumnMap:
    """The column map of a TOML table, checked.

    Parameters
    ----------
    table : mapping
        The map's keys (a manifest's ``[columns]`` with an experiment's keys over them).
    where : str
        Prefixes every error, e.g. ``"m.toml, experiment 2"``.
    tables : mapping, optional
        Per key, the TOML table it came from (default ``columns``), for the error messages.

    Raises
    ------
    ManifestError
        One line naming every bad key (``experiment.columns.y1.phase_deg = 'x': ...``), a
        missing ``frequency``, or channels that are not one of the layouts.
    """
    try:
        return ColumnMap.model_validate(dict(table))
    except ValidationError as exc:
        problems = [_problem(e, tables or {}) for e in exc.errors()]
        raise ManifestError(f"{where}: {'; '.join(problems)}") from None


def _problem(error: Any, tables: Mapping[str, str]) -> str:
    """One pydantic error as ``<table>.<key> = <value>: <what is wrong>``."""
    loc = [str(x) for x in error["loc"]]
    message = str(error["msg"]).removeprefix("Value error, ")
    if not loc:
        return f"column map: {message}"
    key = f"{tables.get(loc[0], 'columns')}.{'.'.join(loc)}"
    kind = error["type"]
    if kind == "extra_forbidden":
        allowed = PARTS if len(loc) > 1 else tuple(ColumnMap.model_fields)
        return f"unknown key {key!r} (allowed: {', '.join(allowed)})"
    if kind == "missing":
        return f"missing key {key!r} (the frequency column, by name or number)"
    if kind in ("model_type", "dict_type"):
        return f'{key} must be a table such as {{ mag = "r", phase_deg = "theta" }}'
    given = error.get("input")
    shown = f" = {given!r}" if isinstance(given, str | int | float | bool) else ""
    return f"{key}{shown}: {message}"


#: The engines that read text: the CSV's own header, or a column map. A file that any other
#: engine claims (``.s2p``, ``.mat``, ``.nc``, a plugin's format) is never read with a map.
TEXT_FORMATS = ("csv", "columns")


def experiment_column_map(
    table: dict[str, Any], top: dict[str, Any], where: str, files: tuple[tuple[str, Path], ...]
) -> ColumnMap | None:
    """The column map an experiment's files are read with, or ``None`` (their own format).

    ``table``: the manifest's ``[[experiment]]`` table, ``top`` its ``[columns]`` (empty without
    one), ``where`` the experiment in messages, ``files`` its files by layout key. Files that a
    format engine other than the CSV's claims (``.s2p``, ``.mat``, ``.nc``, a plugin's) are read
    by it, never with a map.
    """
    own = table.get("columns", {})
    if not isinstance(own, dict):
        raise ManifestError(f"{where}: columns is {own!r}; expected a table ([experiment.columns])")
    text = [f for _, f in files if _is_text(f)]
    if len(text) < len(files):
        if len(files) > 1 or own:
            raise ManifestError(
                f"{where}: a column map reads text files only; "
                f"{', '.join(f.name for _, f in files if f not in text)} has its own format"
            )
        return None  # a .s2p, .mat, .nc or plugin format's file: [columns] do not apply
    if not top and not own:
        if len(files) > 1:
            raise ManifestError(
                f"{where}: several files need a column map ([columns] or [experiment.columns]) "
                "saying which columns each file holds"
            )
        return None
    tables = {key: "experiment.columns" if key in own else "columns" for key in {**top, **own}}
    columns = parse_column_map({**top, **own}, where, tables)
    keys, entries = LAYOUTS[columns.layout]
    if tuple(key for key, _ in files) != keys:
        raise ManifestError(
            f"{where}: the column map names the channel(s) {', '.join(entries)}, which is for "
            f"{_LAYOUT_FILES[columns.layout]}; this experiment has "
            f"{_LAYOUT_FILES[_layout_of(files)]}"
        )
    return columns


def _is_text(file: Path) -> bool:
    """Whether ``file`` is text a column map may read: no engine but the CSV's claims it."""
    try:
        return engine_for(file).name in TEXT_FORMATS
    except FileFormatError:
        return True  # an instrument's export (.txt, .dat, ...): only a column map reads it


_LAYOUT_FILES = {
    "file": "one file holding the whole response (file = ...)",
    "input": "one file per drive input (files = { u1 = ..., u2 = ... })",
    "channel": "one file per channel (files = { y1_u1 = ..., ... })",
}


def _layout_of(files: tuple[tuple[str, Path], ...]) -> str:
    """The layout (:data:`~sysid_core.formats.columnmap.LAYOUTS`) of an experiment's files."""
    keys = tuple(key for key, _ in files)
    return next(name for name, (layout, _) in LAYOUTS.items() if layout == keys)
