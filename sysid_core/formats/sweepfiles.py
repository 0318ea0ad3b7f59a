"""Response files: one sweep at one bias, its 2x2 complex frequency response, in any format.

:func:`read_sweep` and :func:`write_sweep` hand a file to its format's engine
(:mod:`sysid_core.formats.engine`): the one named, else the one that claims the file (by its
extension, any case). The built-in engines (the ``sysid_formats`` plugin):

* ``.csv``: the header ``frequency_hz,y1_u1_re,y1_u1_im,y1_u2_re,y1_u2_im,y2_u1_re,y2_u1_im,
  y2_u2_re,y2_u2_im`` (:data:`CSV_HEADER`, row-major over outputs then inputs), one row per
  frequency; lines starting with ``#`` are comments, and ``# response_units: V/V`` gives the units.
* ``.s2p``: Touchstone, read and written with scikit-rf (``skrf.Network``); ``S_ij`` is output
  ``i`` over input ``j`` (``S21 = y2/u1``); a comment ``! response_units: V/V`` gives the units.
* ``.mat``: variables ``frequency_hz`` (n,) and ``response`` (n, 2, 2) complex, optionally a string
  ``response_units``.
* ``.nc``: a one-experiment data set as :func:`sysid_core.data.schema.save_dataset` writes it, or
  a bare DataArray with dims ``frequency``, ``output``, ``input`` (complex, or split into
  ``<name>_real`` / ``<name>_imag`` as the data sets are).

Every reader checks what it read (complex, finite values; positive, finite, strictly increasing
frequencies; the columns or shape) and says in one line which file, which line (CSV, Touchstone)
or variable (.mat, .nc), and what is wrong (:class:`~sysid_core.errors.FileFormatError`). Nothing
here knows about runs, biases or manifests: a device that exchanges files reads its answers with
:func:`read_sweep` too.

A third party's format, registered from its own package (``docs/contracts.md``), is read and
written here exactly as these are. The in-memory sweep and the checks every format shares are in
:mod:`sysid_core.data.sweep`; each built-in format's reader and writer in :mod:`.csvsweep`,
:mod:`.touchstone`, :mod:`.matsweep` and :mod:`.netcdf`.
"""

from __future__ import annotations

import os
from pathlib import Path
from typing import Any

import numpy as np
import xarray as xr

from sysid_core.data.io import atomic_write
from sysid_core.data.sweep import (
    CSV_COLUMNS,
    CSV_HEADER,
    INPUTS,
    OUTPUTS,
    SWEEP_FORMATS,
    check_sweep,
    make_sweep,
)
from sysid_core.errors import DimensionError, FileFormatError
from sysid_core.formats.engine import engine_for
from sysid_core.plugin.registry import Registry

__all__ = [
    "CSV_COLUMNS",
    "CSV_HEADER",
    "INPUTS",
    "OUTPUTS",
    "SWEEP_FORMATS",
    "make_sweep",
    "read_sweep",
    "write_sweep",
]


def read_sweep(
    path: str | os.PathLike[str],
    format: str | None = None,
    registry: Registry | None = None,
    **options: Any,
) -> xr.DataArray:
    """Read one sweep (a 2x2 complex frequency response) from a response file.

    Parameters
    ----------
    path : path-like
        A ``.csv``, ``.s2p``, ``.mat`` or ``.nc`` file (see the module for the formats), or a
        file of a format a plugin registers.
    format : str, optional
        The engine's name (default: the engine that claims the file by its extension).
    registry : Registry, optional
        Where the engines come from (default: the process-wide registry).
    **options
        Passed to the engine (the column-mapped engine's ``column_map``).

    Returns
    -------
    xarray.DataArray
        Complex, dims ``(frequency, output, input)``, shape (n, 2, 2); coordinates ``frequency``
        (Hz), ``output`` ["y1", "y2"], ``input`` ["u1", "u2"]; attributes ``units`` (the
        response's, ``""`` if the file does not say) and ``source`` (the path).

    Raises
    ------
    FileFormatError
        A missing file, an unknown extension (listing the supported ones), or a file not in its
        format, naming the file and the line or variable.
    """
    path = Path(path)
    engine = engine_for(path, format, registry)
    if not path.is_file():
        raise FileFormatError(
            f"{path}: no such file" if not path.exists() else f"{path}: not a file"
        )
    return engine.open_sweep(path, **options)


def write_sweep(
    path: str | os.PathLike[str],
    response: xr.DataArray,
    response_units: str = "",
    format: str | None = None,
    registry: Registry | None = None,
) -> Path:
    """Write one sweep to a response file, atomically; the format follows the extension.

    Parameters
    ----------
    path : path-like
        ``.csv`` (every float written in full, so reading it back is exact), ``.s2p`` (with
        scikit-rf, real/imaginary parts in Hz, also exact), ``.mat`` or ``.nc``.
    response : xarray.DataArray
        Dims ``(frequency, output, input)``, shape (n, 2, 2); channels are taken in order.
    response_units : str, optional
        Written with the data (default: none, unless ``response.attrs["units"]`` says).
    format : str, optional
        The engine's name (default: the engine that claims the file by its extension).
    registry : Registry, optional
        Where the engines come from (default: the process-wide registry).

    Returns
    -------
    pathlib.Path
        ``path``.
    """
    path = Path(path)
    engine = engine_for(path, format, registry)
    if not engine.writes:
        raise FileFormatError(
            f"cannot write {path}: the {engine.name!r} format is read-only; write another format"
        )
    if not isinstance(response, xr.DataArray) or set(response.dims) != {
        "frequency",
        "output",
        "input",
    }:
        dims = getattr(response, "dims", type(response).__name__)
        raise DimensionError(f"a sweep needs dims ('frequency', 'output', 'input'), got {dims}")
    response = response.transpose("frequency", "output", "input")
    f = np.asarray(response["frequency"].values, dtype=float)
    resp = np.asarray(response.values, dtype=complex)
    units = response_units or str(response.attrs.get("units", ""))

    def value_at(k: int, o: int, i: int) -> str:
        return f"cannot write {path}: response[{k}, {o}, {i}]"

    def freq_at(k: int) -> str:
        return f"cannot write {path}: frequency[{k}]"

    check_sweep(f, resp, f"cannot write {path}", freq_at, value_at, reading=False)
    times = (
        np.asarray(response["time_s"].values, dtype=float) if "time_s" in response.coords else None
    )
    return atomic_write(path, lambda tmp: engine.write_sweep(tmp, f, resp, units, times))
