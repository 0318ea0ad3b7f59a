"""A column map proposed for an unknown text export, from its layout and header.

:func:`guess_column_map` finds the rows of numbers (trying the delimiters tab, ``;``, ``,`` and
whitespace with either decimal mark), the lines before them (comments or lines to skip), the
header, and what each column holds from its name: the frequency (``freq``, ``Hz``, ...) and its
unit, a time column, each channel's parts (``re``/``real``/``X``, ``im``/``imag``/``Y``,
``mag``/``R``/``amplitude``, ``dB``/``log mag``, ``phase``/``theta`` in ``deg`` or ``rad``) and
which channel they belong to (``y1_u2``, ``S21`` = y2/u1, a demodulator or channel number = the
output). ``sysid import --guess FILE`` prints the result as TOML ready to paste into a manifest,
with what it could not decide as comments: a proposal to check, never read without a look.
"""

from __future__ import annotations

import math
import os
import re
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path

from sysid_core.data.sweep import CSV_COLUMNS, TIMED_CSV_COLUMNS
from sysid_core.errors import FileFormatError
from sysid_core.formats.columnsweep import decode_text, split_fields
from sysid_core.formats.export import toml_string

__all__ = ["Guess", "guess_column_map"]

_DELIMITERS = ("\t", ";", ",", "whitespace")
_COMMENT_MARKS = ("#", "!", "%", "//")
_FREQUENCY_UNITS = {"hz": "Hz", "khz": "kHz", "mhz": "MHz", "ghz": "GHz"}
_ROLE_WORDS = (  # (role, words), the first that matches wins
    ("frequency", {"freq", "frequency", "stimulus", "f"}),
    ("time_s", {"time", "t", "elapsed"}),
    ("db", {"db", "logmag"}),
    ("phase", {"phase", "theta", "phi", "angle", "arg", "ang", "deg", "rad"}),
    ("re", {"re", "real"}),
    ("im", {"im", "imag", "imaginary"}),
    ("mag", {"mag", "magnitude", "amplitude", "amp", "abs", "r", "lin", "linmag"}),
    ("re", {"x"}),  # a lock-in's X and Y: in phase and in quadrature
    ("im", {"y"}),
)
_CHANNEL = re.compile(r"y\s*_?([12])\s*[_\s-]*u\s*_?([12])(?!\d)")
_S_PARAMETER = re.compile(r"(?<![a-z])s\s*([12])([12])(?!\d)")
_NUMBERED = re.compile(r"(?:demod|channel|chan|ch|output|out|signal|sig)\s*[_#.]?\s*(\d+)")


@dataclass
class _Column:
    index: int
    name: str
    role: str = ""  # frequency, time_s, re, im, mag, db, phase, or "" (unknown)
    unit: str = ""  # the frequency's unit, or the phase's (deg, rad)
    channel: tuple[int, int | None] | None = None  # (output, input or None)


@dataclass
class Guess:
    """A proposed column map: its keys (TOML values, in order) and what to check.

    ``keys`` maps each key of the map to its value; ``notes`` says what was assumed or could not
    be decided; ``files`` suggests the experiment's ``files`` (or ``file``) line.
    """

    path: Path
    keys: dict[str, object] = field(default_factory=dict)
    notes: list[str] = field(default_factory=list)
    files: str = ""

    def toml(self) -> str:
        """The map as TOML (a ``[columns]`` table), the notes as comments."""
        lines = [
            f"# Column map proposed by sysid import --guess for {self.path.name}: check it, then",
            "# paste it into the manifest as [columns] (every experiment) or as one experiment's",
            "# [experiment.columns].",
            "[columns]",
            *(f"{key} = {_toml(value)}" for key, value in self.keys.items()),
        ]
        if self.files:
            lines += ["", "# Each [[experiment]] then lists its files:", f"# {self.files}"]
        if self.notes:
            lines += ["", "# To check:", *(f"# - {note}" for note in self.notes)]
        return "\n".join(lines) + "\n"


def _toml(value: object) -> str:
    """A TOML value: a string, an integer, a boolean, a list or an inline table."""
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, int):
        return str(value)
    if isinstance(value, list):
        return "[" + ", ".join(_toml(v) for v in value) + "]"
    if isinstance(value, dict):
        return "{ " + ", ".join(f"{k} = {_toml(v)}" for k, v in value.items()) + " }"
    return toml_string(str(value)).replace("\\u0009", "\\t")


def guess_column_map(path: str | os.PathLike[str]) -> Guess:
    """A column map proposed for the text export at ``path`` (see the module).

    Raises
    ------
    FileFormatError
        A missing file, a file that is not text, or one without rows of numbers.
    """
    path = Path(path)
    if not path.is_file():
        what = "not a file" if path.exists() else "no such file"
        raise FileFormatError(f"{path}: {what}")
    if path.suffix.lower() in (".s2p", ".mat", ".nc"):
        raise FileFormatError(
            f"{path}: a {path.suffix} file is read as it is (file = {path.name!r} in the "
            "manifest); a column map is for text exports"
        )
    lines = decode_text(path).splitlines()
    delimiter, decimal, start, stop = _find_rows(lines, path)
    guess = Guess(path)
    guess.keys.update({"delimiter": delimiter, "decimal": decimal})
    rows = [split_fields(line, delimiter) for line in lines[start:stop] if line.strip()]
    names, header_line, in_comment = _header(lines, start, delimiter, len(rows[0]))
    first = start if header_line is None or in_comment else header_line
    _skipped(guess, lines, first, stop, delimiter)
    if in_comment or not names:
        guess.keys["header"] = False
    if tuple(names) in (CSV_COLUMNS, TIMED_CSV_COLUMNS):
        guess.notes.append("the toolkit's own CSV layout: read as it is, without a column map")
    columns = [_classify(k, name) for k, name in enumerate(names or [""] * len(rows[0]))]
    _phase_units(guess, columns, rows, decimal)
    _propose(guess, columns, by_number=in_comment or not names or _repeated(names))
    return guess


def _number(text: str, decimal: str) -> float | None:
    """``text`` as a number with the decimal mark ``decimal``, or ``None``."""
    if decimal == "," and "." in text:
        return None
    try:
        return float(text.replace(",", ".") if decimal == "," else text)
    except ValueError:
        return None


def _find_rows(lines: list[str], path: Path) -> tuple[str, str, int, int]:
    """The delimiter, decimal mark and line range of the longest block of rows of numbers."""
    best: tuple[int, str, str, int, int] = (0, ",", ".", 0, 0)
    for delimiter in _DELIMITERS:
        for decimal in (".", ","):
            if delimiter == decimal:
                continue
            count, start, stop = _longest_block(lines, delimiter, decimal)
            if count > best[0]:
                best = (count, delimiter, decimal, start, stop)
    if best[0] == 0:
        raise FileFormatError(
            f"{path}: no rows of numbers (with at least two columns) found with the delimiters "
            "tab, ';', ',' or whitespace and the decimal mark '.' or ','"
        )
    return best[1], best[2], best[3], best[4]


def _longest_block(lines: list[str], delimiter: str, decimal: str) -> tuple[int, int, int]:
    """``(rows, first line, line after)`` of the longest run of numeric rows of equal width."""
    best = (0, 0, 0)
    count, start, width = 0, 0, 0
    for k, line in enumerate([*lines, "end of file"]):
        if not line.strip() and count:
            continue
        fields = split_fields(line, delimiter)
        numeric = len(fields) >= 2 and all(_number(f, decimal) is not None for f in fields)
        if numeric and count and len(fields) == width:
            count += 1
            continue
        if count > best[0]:
            best = (count, start, k)
        count, start, width = (1, k, len(fields)) if numeric else (0, 0, 0)
    return best


def _header(
    lines: list[str], start: int, delimiter: str, width: int
) -> tuple[list[str], int | None, bool]:
    """The column names, the header's line index, and whether the header is a comment line."""
    before = [k for k in range(start) if lines[k].strip()]
    if not before:
        return [], None, False
    k = before[-1]
    fields = split_fields(lines[k], delimiter)
    if len(fields) != width:
        return [], None, False
    mark = next((m for m in _COMMENT_MARKS if fields[0].startswith(m)), "")
    fields[0] = fields[0][len(mark) :].strip()
    return fields, k, bool(mark)


def _skipped(guess: Guess, lines: list[str], first: int, stop: int, delimiter: str) -> None:
    """``comment`` and ``skip_lines``: the lines before the header or data, and after the data."""
    marks: list[str] = []
    before = [split_fields(line, delimiter) for line in lines[:first] if line.strip()]
    marks += [m for m in _COMMENT_MARKS if any(f and f[0].startswith(m) for f in before)]
    # a marker line of one field led by a word (an analyzer's "BEGIN CH1_DATA") is a comment
    # too: a map that skips a count of lines breaks on a file with one more comment line
    for f in before:
        if f and not any(f[0].startswith(m) for m in marks):
            word = f[0].split()[0]
            if len(f) == 1 and word.isalpha():
                marks.append(word)
            else:
                guess.keys["skip_lines"] = first
                marks = [m for m in marks if m in _COMMENT_MARKS]
                break
    for line in lines[stop:]:
        fields = split_fields(line, delimiter)
        word = fields[0].split()[0] if fields and fields[0].split() else ""
        mark = next((m for m in _COMMENT_MARKS if word.startswith(m)), word)
        if mark and mark not in marks:
            marks.append(mark)
            guess.notes.append(f"lines after the data start with {mark!r}: skipped as comments")
    guess.keys["comment"] = marks or ["#"]


def _classify(index: int, name: str) -> _Column:
    """A column's role, unit and channel, from its name."""
    low = name.lower().replace("log mag", "logmag").replace("lin mag", "linmag")
    words = re.findall(r"[a-z]+", low)
    role = _role(low, words)
    unit = ""
    if role == "frequency":
        unit = next((_FREQUENCY_UNITS[w] for w in words if w in _FREQUENCY_UNITS), "")
        unit = "rad/s" if "rad/s" in low.replace(" ", "") else unit
    elif role == "phase" and ("°" in low or {"deg", "degree", "degrees"} & set(words)):
        unit = "deg"
    elif role == "phase" and {"rad", "radian", "radians"} & set(words):
        unit = "rad"
    return _Column(index, name, role, unit, _channel(low))


def _role(low: str, words: list[str]) -> str:
    """What a column holds, from its name's words (:data:`_ROLE_WORDS`)."""
    if "rad/s" in low.replace(" ", "") or (words and set(words) <= set(_FREQUENCY_UNITS)):
        return "frequency"  # a name that is a frequency unit only, e.g. "Hz"
    for role, known in _ROLE_WORDS:
        if any(w in known for w in words) and not (known == {"y"} and _CHANNEL.search(low)):
            return role  # (the y of y1_u1 is an output, not a lock-in's Y)
    return ""


def _channel(low: str) -> tuple[int, int | None] | None:
    """The channel a column name names: ``(output, input)``, ``(output, None)``, or ``None``."""
    for pattern in (_CHANNEL, _S_PARAMETER):
        match = pattern.search(low)
        if match:
            return int(match.group(1)), int(match.group(2))
    match = _NUMBERED.search(low) or re.search(r"[a-z](\d+)\b", low)
    return (int(match.group(1)), None) if match else None


def _phase_units(guess: Guess, columns: list[_Column], rows: list[list[str]], dec: str) -> None:
    """A phase unit from the values where the name does not say (beyond ±π: degrees)."""
    for column in columns:
        if column.role != "phase" or column.unit:
            continue
        values = [_number(row[column.index], dec) or 0.0 for row in rows]
        largest = max(abs(v) for v in values)
        column.unit = "deg" if largest > math.pi + 1e-9 else "rad"
        why = "beyond ±π" if column.unit == "deg" else "all within ±π"
        guess.notes.append(
            f"column {_name(column)}: phase in {column.unit} (the name does not say; its values "
            f"are {why})"
        )


def _name(column: _Column) -> str:
    return f"{column.index + 1} ({column.name!r})" if column.name else str(column.index + 1)


def _repeated(names: list[str]) -> bool:
    return len(set(names)) < len(names)


def _propose(guess: Guess, columns: list[_Column], by_number: bool) -> None:
    """The map's frequency, time and channel keys (or notes saying what is missing)."""

    def ref(column: _Column) -> str | int:
        return column.index + 1 if by_number or not column.name else column.name

    frequency = [c for c in columns if c.role == "frequency"] or columns[:1]
    if not frequency[0].role:
        guess.notes.append(f"frequency: no column's name says so; took column {_name(columns[0])}")
    guess.keys["frequency"] = ref(frequency[0])
    guess.keys["frequency_unit"] = frequency[0].unit or "Hz"
    if not frequency[0].unit:
        guess.notes.append("frequency_unit: the name does not say; took Hz")
    time = [c for c in columns if c.role == "time_s"]
    if time:
        guess.keys["time_s"] = ref(time[0])
        guess.notes.append(f"time_s: column {_name(time[0])} must hold seconds")
    _one_based(guess, columns)
    pairs = _pairs(guess, [c for c in columns if c.role not in ("", "frequency", "time_s")])
    _layout(guess, pairs, ref)
    unknown = [_name(c) for c in columns if not c.role and c is not frequency[0]]
    if unknown:
        guess.notes.append(f"not used (no role recognised): column(s) {', '.join(unknown)}")


def _one_based(guess: Guess, columns: list[_Column]) -> None:
    """Demodulators or channels numbered from 0 (0 and 1) are outputs y1 and y2."""
    outputs = {c.channel[0] for c in columns if c.channel and c.channel[1] is None}
    if 0 in outputs:
        for c in columns:
            if c.channel and c.channel[1] is None:
                c.channel = (c.channel[0] + 1, None)
        guess.notes.append("channels are numbered from 0: took 0 as y1 and 1 as y2")


def _pairs(guess: Guess, columns: list[_Column]) -> dict[object, dict[str, _Column]]:
    """The channel columns grouped by channel, each group's parts by role."""
    groups: dict[object, dict[str, _Column]] = {}
    for column in columns:
        part = f"phase_{column.unit}" if column.role == "phase" else column.role
        group = groups.setdefault(column.channel, {})
        if part in group:
            guess.notes.append(
                f"columns {_name(group[part])} and {_name(column)} both look like {part} of the "
                "same channel; one is used"
            )
            continue
        group[part] = column
    return groups


def _layout(
    guess: Guess, groups: dict[object, dict[str, _Column]], ref: Callable[[_Column], str | int]
) -> None:
    """The channel keys for the groups found (see :data:`~.columnmap.LAYOUTS`), or a note."""
    name = guess.path.name
    usable = {key: parts for key, parts in groups.items() if _complete(parts)}
    keys = set(usable)
    full = {(o, i) for o in (1, 2) for i in (1, 2)}
    if keys == full:
        for o, i in sorted(full):
            guess.keys[f"y{o}_u{i}"] = _entry(usable[o, i], ref)
    elif keys == {(1, None), (2, None)}:
        for o in (1, 2):
            guess.keys[f"y{o}"] = _entry(usable[o, None], ref)
        guess.files = f'files = {{ u1 = "{name}", u2 = "..." }}  # one file per drive input'
    elif keys in ({(1, 1), (2, 1)}, {(1, 2), (2, 2)}):
        i = next(k[1] for k in keys if isinstance(k, tuple))
        for o in (1, 2):
            guess.keys[f"y{o}"] = _entry(usable[o, i], ref, numbers=True)
        guess.files = f'files = {{ u{i} = "{name}", u{3 - i} = "..." }}  # one file per input'
    elif len(keys) == 1:
        key = keys.pop()
        numbers = isinstance(key, tuple) and key[1] is not None  # S21: its name differs per file
        guess.keys["channel"] = _entry(usable[key], ref, numbers)
        held = f"y{key[0]}_u{key[1]}" if isinstance(key, tuple) and key[1] else "y1_u1"
        guess.files = f'files = {{ {held} = "{name}", ... }}  # one file per channel'
    else:
        guess.notes.append(
            "channels: could not decide which columns hold which channel (found: "
            + ("; ".join(_describe(k, p) for k, p in groups.items()) or "no channel columns")
            + "); add y1_u1 ... y2_u2, y1 and y2, or channel, e.g. "
            "y1_u1 = { mag = 2, phase_deg = 3 }"
        )


def _complete(parts: dict[str, _Column]) -> bool:
    return ({"re", "im"} <= set(parts)) or (
        bool({"mag", "db"} & set(parts)) and bool({"phase_deg", "phase_rad"} & set(parts))
    )


def _entry(
    parts: dict[str, _Column], ref: Callable[[_Column], str | int], numbers: bool = False
) -> dict[str, object]:
    """A channel's inline table: its two columns by part."""
    order = ("re", "im") if "re" in parts and "im" in parts else None
    if order is None:
        magnitude = "db" if "db" in parts else "mag"
        phase = "phase_deg" if "phase_deg" in parts else "phase_rad"
        order = (magnitude, phase)
    return {part: parts[part].index + 1 if numbers else ref(parts[part]) for part in order}


def _describe(key: object, parts: dict[str, _Column]) -> str:
    """One group of channel columns, for a note."""
    which = "no channel named" if key is None else f"channel {key}"
    return f"{which}: " + ", ".join(f"{p} = {_name(c)}" for p, c in parts.items())
