"""Response files: one sweep at one bias, its 2x2 complex frequency response, in four formats.

:func:`read_sweep` and :func:`write_sweep` choose the format by the file's extension (any case):

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

The in-memory sweep and the checks every format shares are in :mod:`sysid_core.data.sweep`;
each format's reader and writer in :mod:`.csvsweep`, :mod:`.touchstone` and :mod:`.matsweep`.
"""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np
import xarray as xr

from sysid_core.data.csvsweep import csv_text, read_csv
from sysid_core.data.io import atomic_write
from sysid_core.data.matsweep import read_mat, write_mat
from sysid_core.data.schema import load_dataset, measured_mask, save_dataset
from sysid_core.data.sweep import (
    CSV_COLUMNS,
    CSV_HEADER,
    INPUTS,
    OUTPUTS,
    SWEEP_FORMATS,
    check_sweep,
    check_times,
    make_sweep,
)
from sysid_core.data.touchstone import read_s2p, s2p_text
from sysid_core.errors import (
    DataError,
    DimensionError,
    FileFormatError,
)

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


def _suffix(path: Path) -> str:
    ext = path.suffix.lower()
    if ext not in SWEEP_FORMATS:
        raise FileFormatError(
            f"{path}: unknown response-file extension {path.suffix or '(none)'!r}; supported: "
            f"{', '.join(SWEEP_FORMATS)}"
        )
    return ext


def read_sweep(path: str | os.PathLike[str]) -> xr.DataArray:
    """Read one sweep (a 2x2 complex frequency response) from a response file.

    Parameters
    ----------
    path : path-like
        A ``.csv``, ``.s2p``, ``.mat`` or ``.nc`` file (see the module for the formats).

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
    ext = _suffix(path)
    if not path.is_file():
        raise FileFormatError(
            f"{path}: no such file" if not path.exists() else f"{path}: not a file"
        )
    reader = {".csv": read_csv, ".s2p": read_s2p, ".mat": read_mat, ".nc": _read_nc}[ext]
    return reader(path)


def write_sweep(
    path: str | os.PathLike[str], response: xr.DataArray, response_units: str = ""
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

    Returns
    -------
    pathlib.Path
        ``path``.
    """
    path = Path(path)
    ext = _suffix(path)
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
    if ext == ".csv":
        text = csv_text(f, resp, units, times)
        return atomic_write(path, lambda tmp: tmp.write_text(text, encoding="utf-8"))
    if ext == ".s2p":  # Touchstone has no place for time stamps
        text = s2p_text(f, resp, units)
        return atomic_write(path, lambda tmp: tmp.write_text(text, encoding="utf-8"))
    if ext == ".mat":
        return atomic_write(path, lambda tmp: write_mat(tmp, f, resp, units, times))
    sweep = make_sweep(f, resp, time_s=times)
    sweep.attrs = {}
    ds = xr.Dataset({"response": sweep}, attrs={"response_units": units})
    return save_dataset(ds, path)


# -------------------------------------------------------------------------------------- netCDF
def _read_nc(path: Path) -> xr.DataArray:
    """The sweep in the netCDF file at ``path``: a one-experiment data set or a bare DataArray."""
    try:
        ds = load_dataset(path)
    except DataError as exc:
        raise FileFormatError(str(exc)) from exc
    names = [str(v) for v in ds.data_vars if str(v) not in ("measured", "time_s", "noise_var")]
    name = "response" if "response" in names else (names[0] if len(names) == 1 else None)
    if name is None:
        raise FileFormatError(
            f"{path}: no variable 'response' and not a single variable (found: "
            f"{', '.join(names) or 'none'})"
        )
    where = f"{path}, variable {name!r}"
    da = _nc_response(ds, name, where)
    f = np.asarray(da["frequency"].values, dtype=float)
    resp = np.asarray(da.values, dtype=complex)

    def value_at(k: int, o: int, i: int) -> str:
        return f"{where}[{k}, {o}, {i}]"

    check_sweep(f, resp, where, lambda k: f"{path}, variable 'frequency'[{k}]", value_at)
    units = str(da.attrs.get("units", ds.attrs.get("response_units", "")))
    times = _nc_times(ds, da, path, f.size)
    return make_sweep(f, resp, units, str(path), times)


def _nc_times(ds: xr.Dataset, da: xr.DataArray, path: Path, n: int) -> np.ndarray | None:
    """The sweep's time stamps, or ``None`` without them.

    A ``time_s`` coordinate of the response, or a one-experiment data set's ``time_s`` variable
    at its measured points.
    """
    if "time_s" in da.coords:
        times = np.asarray(da["time_s"].values, dtype=float).ravel()
    elif "time_s" in ds.data_vars and "experiment" in ds["time_s"].dims:
        times = np.asarray(ds["time_s"].values[0], dtype=float)[measured_mask(ds)[0]]
    else:
        return None
    check_times(times, lambda k: f"{path}, variable 'time_s'[{k}]", n)
    return times


def _nc_response(ds: xr.Dataset, name: str, where: str) -> xr.DataArray:
    """Variable ``name`` of ``ds`` as one complex 2x2 sweep, its measured points only."""
    da = ds[name]
    if "experiment" in da.dims:
        if da.sizes["experiment"] != 1:
            raise FileFormatError(
                f"{where}: {da.sizes['experiment']} experiments; a response file holds one "
                "(use a manifest, or sysid export, for several)"
            )
        keep = measured_mask(ds)[0]
        da = da.isel(experiment=0, frequency=np.flatnonzero(keep))
    if set(da.dims) != {"frequency", "output", "input"}:
        raise FileFormatError(f"{where}: dims {da.dims}; expected (frequency, output, input)")
    da = da.transpose("frequency", "output", "input")
    for dim, labels in (("output", OUTPUTS), ("input", INPUTS)):
        if da.sizes[dim] != 2:
            raise FileFormatError(f"{where}: {da.sizes[dim]} {dim}s; a response file is 2x2")
        if dim in da.coords and {str(v) for v in da[dim].values} == set(labels):
            da = da.sel({dim: list(labels)})
    if not np.iscomplexobj(da.values):
        raise FileFormatError(
            f"{where}: real values ({da.dtype}), no imaginary part; the response must be complex"
        )
    if "frequency" not in da.coords:
        raise FileFormatError(f"{where}: no 'frequency' coordinate (Hz)")
    return da
