"""Response files in CSV: the toolkit's own layout (see :mod:`sysid_core.formats.sweepfiles`)."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import xarray as xr

from sysid_core.data.sweep import (
    CSV_COLUMNS,
    CSV_HEADER,
    INPUTS,
    OUTPUTS,
    TIMED_CSV_COLUMNS,
    UNITS_LINE,
    check_sweep,
    check_times,
    make_sweep,
)
from sysid_core.errors import FileFormatError
from sysid_core.formats.textfile import read_text, split_fields

__all__ = ["csv_text", "read_csv"]


# ------------------------------------------------------------------------------------- CSV
def csv_text(f: np.ndarray, resp: np.ndarray, units: str, times: np.ndarray | None = None) -> str:
    """The CSV file of a sweep: the units comment (if any), the header, one row per frequency.

    With ``times``, a last column ``time_s`` holds each point's time stamp.
    """
    lines = [f"# response_units: {units}"] if units else []
    lines.append(CSV_HEADER if times is None else ",".join(TIMED_CSV_COLUMNS))
    flat = resp.reshape(f.size, 4)
    for k in range(f.size):
        parts = [repr(float(f[k]))]
        for z in flat[k]:
            parts += [repr(float(z.real)), repr(float(z.imag))]
        if times is not None:
            parts.append(repr(float(times[k])))
        lines.append(",".join(parts))
    return "\n".join(lines) + "\n"


def _header_problem(fields: list[str]) -> str:
    """What is wrong with a CSV header (it is not :data:`CSV_HEADER`)."""
    if len(fields) == 1 and ";" in fields[0]:
        return "fields must be separated by commas, not semicolons"
    try:
        [float(x) for x in fields]
    except ValueError:
        pass
    else:
        return "no header line; the first line that is not a comment must be the header"
    if fields and not any(name.endswith("_im") for name in fields):
        return (
            "no imaginary-part columns (*_im): the file holds a real-valued response, but the "
            "response must be complex (real and imaginary part of each channel)"
        )
    unknown = [name for name in fields if name not in TIMED_CSV_COLUMNS]
    if unknown:
        return f"unknown column {unknown[0]!r}"
    missing = [name for name in CSV_COLUMNS if name not in fields]
    if missing:
        return f"missing column(s) {', '.join(missing)}"
    return "the columns are not in the required order"


def read_csv(path: Path) -> xr.DataArray:
    """The sweep in the CSV file at ``path``, checked (:class:`FileFormatError` names the line)."""
    text = read_text(path)
    units, header_line, rows, lines, timed = _parse_lines(text, path)
    if not header_line:
        raise FileFormatError(f"{path}: no header line; expected {CSV_HEADER}")
    if not rows:
        raise FileFormatError(f"{path}: no data rows after the header (line {header_line})")
    data = np.array(rows)
    f = data[:, 0]
    flat = np.empty((f.size, 4), dtype=complex)  # not re + 1j*im: nan*1j spoils the real part
    flat.real, flat.imag = data[:, 1:9:2], data[:, 2:9:2]
    resp = flat.reshape(-1, 2, 2)

    def value_at(k: int, o: int, i: int) -> str:
        part = "re" if not np.isfinite(resp[k, o, i].real) else "im"
        return f"{path}, line {lines[k]}: {OUTPUTS[o]}_{INPUTS[i]}_{part}"

    check_sweep(f, resp, str(path), lambda k: f"{path}, line {lines[k]}", value_at)
    times = data[:, 9] if timed else None
    if times is not None:
        check_times(times, lambda k: f"{path}, line {lines[k]}", f.size)
    return make_sweep(f, resp, units or "", str(path), times)


def _parse_lines(
    text: str, path: Path
) -> tuple[str | None, int, list[list[float]], list[int], bool]:
    """The units, the header's line number (0: none), the rows, their lines, and time stamps.

    The last value says whether the header ends with the optional ``time_s`` column.
    """
    units: str | None = None
    header_line = 0
    columns: tuple[str, ...] = CSV_COLUMNS
    rows: list[list[float]] = []
    lines: list[int] = []
    for number, line in enumerate(text.splitlines(), start=1):
        where = f"{path}, line {number}"
        if line.lstrip().startswith("#"):
            units = _comment_units(line, units, where)
            continue
        if not line.strip():
            continue
        fields = split_fields(line)
        if not header_line:
            if tuple(fields) not in (CSV_COLUMNS, TIMED_CSV_COLUMNS):
                raise FileFormatError(
                    f"{where}: {_header_problem(fields)}; the header must be exactly {CSV_HEADER} "
                    "(optionally followed by ,time_s)"
                )
            header_line = number
            columns = tuple(fields)
            continue
        rows.append(_data_row(fields, where, columns))
        lines.append(number)
    return units, header_line, rows, lines, columns == TIMED_CSV_COLUMNS


def _comment_units(line: str, units: str | None, where: str) -> str | None:
    """``units`` after a comment line: its ``response_units`` if it gives them (once only)."""
    match = UNITS_LINE.match(line.lstrip()[1:])
    if not match:
        return units
    value = match.group(1).strip()
    if units is not None and value != units:
        raise FileFormatError(
            f"{where}: a second response_units ({value!r}) differs from the first ({units!r})"
        )
    return value


def _data_row(fields: list[str], where: str, columns: tuple[str, ...]) -> list[float]:
    """The numbers of a data row, one per column of the header (``columns``)."""
    if len(fields) != len(columns):
        raise FileFormatError(
            f"{where}: {len(fields)} field(s); expected {len(columns)} ({','.join(columns)})"
        )
    row = []
    for name, field in zip(columns, fields, strict=True):
        try:
            row.append(float(field))
        except ValueError:
            raise FileFormatError(f"{where}: {name} is {field!r}, not a number") from None
    return row
