"""Sweeps from text exports read with a column map (:mod:`sysid_core.formats.columnmap`).

:func:`read_columns` reads one experiment's files (one file holding the whole response, one file
per drive input, or one file per channel) and gives the sweep that
:func:`~sysid_core.formats.sweepfiles.read_sweep` gives: complex, ``(frequency, output, input)``,
frequencies in Hz, the optional ``time_s``, the same checks. Every error is a
:class:`~sysid_core.errors.FileFormatError` naming the file, the line and the column with the
map's key, e.g. ``exp0-u1.csv, line 7: column 'theta1' (y1.phase_deg) is 'n/a', not a number``.

Text is read by :mod:`sysid_core.formats.textfile` (its size, NUL bytes and line lengths checked
first; UTF-16 with its byte-order mark, UTF-8, else Latin-1).
"""

from __future__ import annotations

import os
from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import xarray as xr

from sysid_core.data.sweep import check_sweep, check_times, make_sweep
from sysid_core.errors import FileFormatError
from sysid_core.formats.columnmap import CHANNEL_KEYS, FREQUENCY_UNITS, LAYOUTS, ColumnMap
from sysid_core.formats.textfile import read_text, split_fields

__all__ = ["decode_text", "read_columns", "split_fields"]

#: Frequencies of one experiment's files must agree to this relative tolerance.
GRID_RTOL = 1e-9


def decode_text(path: Path) -> str:
    """The text of a file, checked and decoded (:func:`sysid_core.formats.textfile.read_text`)."""
    return read_text(path)


@dataclass(frozen=True)
class _Table:
    """The numbers one file holds in the map's columns."""

    path: Path
    lines: list[int]  # each row's line number
    values: dict[str, np.ndarray]  # by the map's key (frequency, time_s, y1.mag, ...)
    labels: dict[str, str]  # each key's column, for messages: 'theta1' or 3


def read_columns(
    files: Mapping[str, str | os.PathLike[str]], column_map: ColumnMap
) -> xr.DataArray:
    """One sweep from an experiment's text files, read with a column map.

    Parameters
    ----------
    files : mapping
        The files by the keys of the map's layout: ``{"": path}`` for one file holding the whole
        response, ``{"u1": ..., "u2": ...}`` for one file per drive input, ``{"y1_u1": ...,
        "y1_u2": ..., "y2_u1": ..., "y2_u2": ...}`` for one file per channel.
    column_map : ColumnMap
        Where each file's numbers are (:func:`~sysid_core.formats.columnmap.parse_column_map`).

    Returns
    -------
    xarray.DataArray
        As :func:`~sysid_core.formats.sweepfiles.read_sweep` returns (``source``: the files, joined
        with ``", "``). With several files, the frequencies are the first file's (the others
        must agree within 1e-9, relative) and so are the time stamps.

    Raises
    ------
    FileFormatError
        A file that cannot be read with the map, naming the file, the line and the column.
    """
    keys = LAYOUTS[column_map.layout][0]
    if set(files) != set(keys):
        raise FileFormatError(
            f"the column map is for files keyed {', '.join(repr(k) for k in keys)}; got "
            f"{', '.join(repr(k) for k in files)}"
        )
    tables = [_read_table(Path(files[key]), column_map) for key in keys]
    first = tables[0]
    f = first.values["frequency"] * FREQUENCY_UNITS[column_map.frequency_unit]
    for table in tables[1:]:
        _same_grid(first, table)
    resp = np.empty((f.size, 2, 2), dtype=complex)
    where: dict[tuple[int, int], tuple[_Table, str]] = {}
    for key, table in zip(keys, tables, strict=True):
        for entry in column_map.channels():
            channel = entry if key == "" else (key if entry == "channel" else f"{entry}_{key}")
            o, i = divmod(CHANNEL_KEYS.index(channel), 2)
            resp[:, o, i] = _complex(table, entry, column_map)
            where[o, i] = (table, entry)

    def freq_at(k: int) -> str:
        return f"{first.path}, line {first.lines[k]}: column {first.labels['frequency']}"

    def value_at(k: int, o: int, i: int) -> str:
        table, entry = where[o, i]
        columns = ", ".join(v for key, v in table.labels.items() if key.startswith(f"{entry}."))
        channel = CHANNEL_KEYS[2 * o + i]
        return f"{table.path}, line {table.lines[k]}: {channel} (columns {columns})"

    source = ", ".join(str(t.path) for t in tables)
    check_sweep(f, resp, source, freq_at, value_at)
    times = first.values.get("time_s")
    if times is not None:
        times = times * column_map.seconds_per_time_unit
        check_times(times, lambda k: f"{first.path}, line {first.lines[k]}: time_s", f.size)
        _check_span(times, first, column_map)
    return make_sweep(f, resp, column_map.response_units, source, times)


#: The longest a sweep's time stamps may span: a month. The slowest sweep a bench measures (a
#: 1 kHz gyro of Q 10^6: τ = Q/(π f) = 5.3 min, 5 τ a point, 200 points) takes 3.7 days; a span
#: of months or years is a clock read in the wrong unit (ticks taken for seconds).
MAX_SWEEP_SPAN_S = 30 * 86_400.0


def _check_span(times: np.ndarray, table: _Table, column_map: ColumnMap) -> None:
    """Refuse a sweep whose time stamps span more than :data:`MAX_SWEEP_SPAN_S`."""
    span = float(np.ptp(times)) if times.size else 0.0
    if span > MAX_SWEEP_SPAN_S:
        unit = column_map.time_unit if column_map.time_unit != "ticks" else "ticks"
        days = span / 86_400
        spans = f"{days:.3g} days" if days < 1000 else f"{days / 365.25:.3g} years"
        raise FileFormatError(
            f"{table.path}: column {table.labels['time_s']} (time_s) spans {spans} "
            f"read in {unit}, more than one sweep can take ({MAX_SWEEP_SPAN_S / 86_400:.0f} "
            'days): give the clock\'s unit in the column map (time_unit = "ms", "us", '
            '"ns", or "ticks" with ticks_per_s)'
        )


def _same_grid(first: _Table, other: _Table) -> None:
    """Check that ``other`` has the frequencies of ``first`` (one experiment's files)."""
    f0, f1 = first.values["frequency"], other.values["frequency"]
    if f0.size != f1.size:
        raise FileFormatError(
            f"{other.path}: {f1.size} points, but {first.path} has {f0.size}; the files of one "
            "experiment must share their frequency grid"
        )
    with np.errstate(invalid="ignore"):
        bad = np.flatnonzero(~(np.abs(f1 - f0) <= GRID_RTOL * np.abs(f0)))
    if bad.size:
        k = int(bad[0])
        here, there = float(f1[k]), float(f0[k])
        raise FileFormatError(
            f"{other.path}, line {other.lines[k]}: frequency {here!r}, but {first.path} has "
            f"{there!r} at that point (line {first.lines[k]}); the files of one experiment must "
            "share their frequency grid"
        )


def _complex(table: _Table, entry: str, column_map: ColumnMap) -> np.ndarray:
    """Channel ``entry``'s complex values from its two columns."""
    parts = dict(column_map.channels()[entry].parts())
    value = {part: table.values[f"{entry}.{part}"] for part in parts}
    out = np.empty(len(table.lines), dtype=complex)
    if "re" in value:  # not re + 1j*im: nan*1j spoils the real part
        out.real, out.imag = value["re"], value["im"]
        return out
    if "db" in value:
        mag = 10.0 ** (value["db"] / 20.0)
    else:
        mag = value["mag"]
        negative = np.flatnonzero(mag < 0)
        if negative.size:
            k = int(negative[0])
            raise FileFormatError(
                f"{table.path}, line {table.lines[k]}: column {table.labels[f'{entry}.mag']} "
                f"({entry}.mag) is {float(mag[k])!r}: a linear magnitude is never negative (is the "
                "column in dB? then map it as db)"
            )
    phase = value["phase_rad"] if "phase_rad" in value else np.deg2rad(value["phase_deg"])
    out.real, out.imag = mag * np.cos(phase), mag * np.sin(phase)
    return out


def _read_table(path: Path, column_map: ColumnMap) -> _Table:
    """The map's columns of the file at ``path``, as numbers (errors name line and column)."""
    if not path.is_file():
        raise FileFormatError(
            f"{path}: no such file" if not path.exists() else f"{path}: not a file"
        )
    rows = _rows(decode_text(path), column_map)
    header_line, names = rows.pop(0) if column_map.header and rows else (0, [])
    if not rows:
        after = f" after the header (line {header_line})" if header_line else ""
        raise FileFormatError(
            f"{path}: no data rows{after}; check skip_lines, comment and the delimiter"
        )
    width = len(names) if header_line else len(rows[0][1])
    names = names or [""] * width
    index = _resolve(path, header_line, names, column_map)
    numbers = []
    for number, fields in rows:
        _check_width(path, number, fields, width, header_line, column_map)
        numbers.append(_numbers(path, number, fields, index, names, column_map))
    data = np.array(numbers, dtype=float)
    values = {key: data[:, k] for k, key in enumerate(index)}
    labels = {key: _label(names, column) for key, column in index.items()}
    return _Table(path, [number for number, _ in rows], values, labels)


def _rows(text: str, column_map: ColumnMap) -> list[tuple[int, list[str]]]:
    """The lines that are neither skipped, blank nor comments: ``(line number, fields)``."""
    rows = []
    for number, line in enumerate(text.splitlines(), start=1):
        if number <= column_map.skip_lines:
            continue
        fields = split_fields(line, column_map.delimiter)
        if fields and not fields[0].startswith(column_map.comment):
            rows.append((number, fields))
    return rows


def _label(names: list[str], column: int) -> str:
    """A column for messages: its name if the header gives one, else its number."""
    name = names[column] if column < len(names) else ""
    return repr(name) if name else str(column + 1)


def _resolve(path: Path, line: int, names: list[str], column_map: ColumnMap) -> dict[str, int]:
    """Per key of the map, the index of its column in a row of ``len(names)`` fields."""
    index = {}
    where = f"{path}, line {line}" if line else str(path)
    for key, ref in column_map.columns():
        if isinstance(ref, int):
            if ref > len(names):
                raise FileFormatError(
                    f"{where}: {key} = {ref}, but the {'header' if line else 'first row'} has "
                    f"{len(names)} column(s)"
                )
            index[key] = ref - 1
            continue
        found = [k for k, name in enumerate(names) if name == ref]
        if len(found) != 1:
            what = "no column" if not found else f"{len(found)} columns"
            raise FileFormatError(
                f"{where}: {key} = {ref!r}: the header has {what} of that name (its columns: "
                f"{', '.join(repr(n) for n in names)}){'; give it by number' if found else ''}"
            )
        index[key] = found[0]
    return index


def _check_width(
    path: Path, number: int, fields: list[str], width: int, header_line: int, cmap: ColumnMap
) -> None:
    """A data row must have as many fields as the header (or the first row)."""
    if len(fields) != width:
        against = f"the header (line {header_line})" if header_line else "the first row"
        raise FileFormatError(
            f"{path}, line {number}: {len(fields)} field(s), but {against} has {width}; check "
            f"the delimiter ({cmap.delimiter!r}) and the decimal mark ({cmap.decimal!r})"
        )


def _numbers(
    path: Path,
    number: int,
    fields: list[str],
    index: dict[str, int],
    names: list[str],
    column_map: ColumnMap,
) -> list[float]:
    """The numbers of one data row in the map's columns (in the order of ``index``)."""
    row = []
    for key, column in index.items():
        field = fields[column]
        text = field.replace(",", ".") if column_map.decimal == "," else field
        try:
            if column_map.decimal == "," and "." in field:
                raise ValueError(field)
            row.append(float(text))
        except ValueError:
            raise FileFormatError(
                f"{path}, line {number}: column {_label(names, column)} ({key}) is {field!r}, not "
                f"a number (decimal mark {column_map.decimal!r})"
            ) from None
    return row
