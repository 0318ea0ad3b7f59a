"""netCDF response files: a one-experiment data set, or a bare DataArray of one sweep.

Read: a data set as :func:`sysid_core.data.schema.save_dataset` writes it (one experiment, its
measured points), or a bare DataArray with dims ``frequency``, ``output``, ``input`` (complex,
or split into ``<name>_real`` / ``<name>_imag`` as the data sets are). Written: a one-sweep data
set with the response and, when given, each point's time stamp.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import xarray as xr

from sysid_core.data.schema import load_dataset, measured_mask, save_dataset
from sysid_core.data.sweep import INPUTS, OUTPUTS, check_sweep, check_times, make_sweep
from sysid_core.errors import DataError, FileFormatError

__all__ = ["read_nc", "write_nc"]


def write_nc(
    path: Path,
    frequency_hz: np.ndarray,
    response: np.ndarray,
    units: str,
    time_s: np.ndarray | None,
) -> None:
    """Write one sweep to ``path`` as a one-sweep netCDF data set (``response``, ``time_s``)."""
    sweep = make_sweep(frequency_hz, response, time_s=time_s)
    sweep.attrs = {}
    ds = xr.Dataset({"response": sweep}, attrs={"response_units": units})
    save_dataset(ds, path)


def read_nc(path: Path) -> xr.DataArray:
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
