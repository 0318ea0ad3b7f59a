"""One sweep in memory (a 2x2 complex response per frequency) and the checks all formats share.

:mod:`sysid_core.formats.sweepfiles` reads and writes sweeps in files.
"""

from __future__ import annotations

import re
from collections.abc import Callable, Sequence

import numpy as np
import xarray as xr

from sysid_core.errors import (
    DimensionError,
    FileFormatError,
    FrequencyGridError,
    NonFiniteDataError,
)

__all__ = [
    "CSV_COLUMNS",
    "CSV_HEADER",
    "INPUTS",
    "OUTPUTS",
    "SWEEP_FORMATS",
    "TIMED_CSV_COLUMNS",
    "UNITS_LINE",
    "check_sweep",
    "check_times",
    "make_sweep",
]

OUTPUTS = ("y1", "y2")
INPUTS = ("u1", "u2")
#: The file formats, by extension.
SWEEP_FORMATS = (".csv", ".s2p", ".mat", ".nc")
CHANNELS = [f"{y}_{u}" for y in OUTPUTS for u in INPUTS]
CSV_COLUMNS = ("frequency_hz", *[f"{c}_{part}" for c in CHANNELS for part in ("re", "im")])
CSV_HEADER = ",".join(CSV_COLUMNS)
#: The CSV columns of a sweep with time stamps: the 9 above, then ``time_s`` (seconds).
TIMED_CSV_COLUMNS = (*CSV_COLUMNS, "time_s")
UNITS_LINE = re.compile(r"^\s*response_units\s*:(.*)$")


# ------------------------------------------------------------------------------ common parts
def make_sweep(
    frequency_hz: Sequence[float] | np.ndarray,
    response: np.ndarray,
    units: str = "",
    source: str = "",
    time_s: Sequence[float] | np.ndarray | None = None,
) -> xr.DataArray:
    """The DataArray of one sweep: complex, dims ``(frequency, output, input)``, shape (n, 2, 2).

    Coordinates ``frequency`` (Hz), ``output`` (y1, y2), ``input`` (u1, u2) and, when given,
    ``time_s`` (each point's time stamp, seconds, the device's clock); attributes ``units``
    (the response's units, ``""`` if unknown) and ``source`` (where it came from). Nothing is
    checked here; :func:`~sysid_core.formats.sweepfiles.read_sweep` checks before it calls this.
    """
    return xr.DataArray(
        np.asarray(response, dtype=complex),
        dims=("frequency", "output", "input"),
        coords={
            "frequency": ("frequency", np.asarray(frequency_hz, dtype=float), {"units": "Hz"}),
            "output": list(OUTPUTS),
            "input": list(INPUTS),
            **(
                {}
                if time_s is None
                else {"time_s": ("frequency", np.asarray(time_s, dtype=float), {"units": "s"})}
            ),
        },
        name="response",
        attrs={"units": units, "source": source},
    )


def check_sweep(
    f: np.ndarray,
    resp: np.ndarray,
    where: str,
    freq_at: Callable[[int], str],
    value_at: Callable[[int, int, int], str],
    reading: bool = True,
) -> None:
    """Check a sweep's frequencies and values; ``freq_at(k)`` / ``value_at(k, o, i)`` locate.

    Reading, every problem is a :class:`FileFormatError`; writing, a :class:`DimensionError`,
    :class:`FrequencyGridError` or :class:`NonFiniteDataError`.
    """
    shape_error = FileFormatError if reading else DimensionError
    grid_error = FileFormatError if reading else FrequencyGridError
    value_error = FileFormatError if reading else NonFiniteDataError
    if f.size == 0:
        raise shape_error(f"{where}: no frequency points")
    if resp.shape != (f.size, 2, 2):
        raise shape_error(f"{where}: response has shape {resp.shape}; expected ({f.size}, 2, 2)")
    with np.errstate(invalid="ignore"):
        invalid = ~np.isfinite(f) | (f <= 0)
        unordered = np.concatenate([[False], ~(np.diff(f) > 0)]) & ~invalid
    problems = np.flatnonzero(invalid | unordered)
    if problems.size:  # the first one in the file's order
        k = int(problems[0])
        if invalid[k]:
            raise grid_error(
                f"{freq_at(k)}: frequency {float(f[k])!r} Hz; frequencies must be positive, finite"
            )
        raise grid_error(
            f"{freq_at(k)}: frequency {float(f[k])!r} Hz after {float(f[k - 1])!r} Hz; "
            "frequencies must be strictly increasing (sort the points, drop duplicates)"
        )
    bad = np.argwhere(~np.isfinite(resp))
    if bad.size:
        k, o, i = (int(v) for v in bad[0])
        raise value_error(
            f"{value_at(k, o, i)}: {resp[k, o, i]} at {f[k]} Hz; every value must be finite "
            f"({len(bad)} non-finite in all)"
        )


def check_times(times: np.ndarray, where: Callable[[int], str], n_points: int) -> None:
    """Time stamps of a sweep: one per point, finite (:class:`FileFormatError` locates one)."""
    if times.shape != (n_points,):
        raise FileFormatError(f"{where(0)}: {times.size} time stamps for {n_points} points")
    bad = np.flatnonzero(~np.isfinite(times))
    if bad.size:
        k = int(bad[0])
        raise FileFormatError(f"{where(k)}: time_s {float(times[k])!r}; time stamps must be finite")
