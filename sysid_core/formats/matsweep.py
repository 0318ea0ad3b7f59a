"""Response files in MATLAB ``.mat`` (see :mod:`sysid_core.formats.sweepfiles`).

Versions 4 to 7 are read with ``scipy.io.loadmat``, v7.3 (HDF5) with h5py
(:mod:`sysid_core.formats.mat73`); both are checked alike. Files are written as v5 (``savemat``).
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np
import xarray as xr

from sysid_core.data.sweep import (
    check_sweep,
    check_times,
    make_sweep,
)
from sysid_core.errors import (
    FileFormatError,
)
from sysid_core.formats.mat73 import is_mat73, load_mat73

__all__ = ["read_mat", "write_mat"]

#: The variables a response file may hold (a v7.3 file's others are not read).
_VARIABLES = ("frequency_hz", "response", "response_units", "time_s")


# -------------------------------------------------------------------------------- MATLAB .mat
def write_mat(
    tmp: Path, f: np.ndarray, resp: np.ndarray, units: str, times: np.ndarray | None = None
) -> None:
    """Write a sweep to ``tmp`` as a MATLAB ``.mat`` file (``frequency_hz``, ``response``).

    With ``times``, also ``time_s`` (n,): each point's time stamp.
    """
    from scipy.io import savemat

    variables: dict[str, Any] = {"frequency_hz": f, "response": resp}
    if times is not None:
        variables["time_s"] = np.asarray(times, dtype=float)
    if units:
        variables["response_units"] = units
    savemat(str(tmp), variables, appendmat=False, oned_as="column")


def read_mat(path: Path) -> xr.DataArray:
    """The sweep in the MATLAB ``.mat`` file at ``path``, checked (errors name the variable)."""
    mat = _load_mat(path)
    found = sorted(k for k in mat if not k.startswith("__"))
    for name in ("frequency_hz", "response"):
        if name not in mat:
            raise FileFormatError(
                f"{path}: no variable {name!r} (found: {', '.join(found) or 'none'}); expected "
                "frequency_hz (n,) and response (n, 2, 2) complex"
            )
    f = _frequency_variable(mat, path)
    r = _response_variable(mat, path, f.size)
    units = _units_variable(mat, path)

    def freq_at(k: int) -> str:
        return f"{path}, variable 'frequency_hz'[{k}]"

    def value_at(k: int, o: int, i: int) -> str:
        return f"{path}, variable 'response'[{k}, {o}, {i}]"

    check_sweep(f.astype(float), r.astype(complex), str(path), freq_at, value_at)
    times = None
    if "time_s" in mat:
        times = np.asarray(mat["time_s"], dtype=float).ravel()
        check_times(times, lambda k: f"{path}, variable 'time_s'[{k}]", f.size)
    return make_sweep(f, r, units, str(path), times)


def _load_mat(path: Path) -> dict[str, Any]:
    """The variables of the ``.mat`` file at ``path``: v4 to v7 with scipy, v7.3 with h5py."""
    if is_mat73(path):
        return load_mat73(path, _VARIABLES)
    from scipy.io import loadmat

    try:
        return loadmat(path, squeeze_me=False)
    except Exception as exc:  # scipy raises ValueError, TypeError, MatReadError, ...
        import h5py  # type: ignore[import-untyped]

        if h5py.is_hdf5(path):
            raise FileFormatError(
                f"{path}: an HDF5 file without MATLAB's v7.3 header: not a MATLAB .mat file "
                "(save it from MATLAB, or write a netCDF .nc file)"
            ) from exc
        raise FileFormatError(f"{path}: not a MATLAB .mat file ({exc})") from exc


def _frequency_variable(mat: dict[str, Any], path: Path) -> np.ndarray:
    """``frequency_hz`` as a real vector (a row or column matrix is flattened)."""
    f = np.asarray(mat["frequency_hz"])
    if f.ndim == 2 and 1 in f.shape:
        f = f.ravel()
    if f.ndim != 1 or f.dtype.kind not in "iuf":
        raise FileFormatError(
            f"{path}, variable 'frequency_hz': {f.dtype} of shape {f.shape}; expected a real "
            "vector (n,) in Hz"
        )
    return f


def _response_variable(mat: dict[str, Any], path: Path, n: int) -> np.ndarray:
    """``response``: complex numbers of shape ``(n, 2, 2)``."""
    r = np.asarray(mat["response"])
    if r.dtype.kind not in "iufc":
        raise FileFormatError(f"{path}, variable 'response': {r.dtype}, not numbers")
    if r.shape != (n, 2, 2):
        hint = ""
        if r.shape == (2, 2, n):
            hint = " (MATLAB's freqresp layout: use permute(H, [3 1 2]))"
        raise FileFormatError(
            f"{path}, variable 'response': shape {r.shape}; expected ({n}, 2, 2) "
            f"(frequency, output, input) with n = numel(frequency_hz) = {n}{hint}"
        )
    if r.dtype.kind != "c":
        raise FileFormatError(
            f"{path}, variable 'response': real values ({r.dtype}), no imaginary part; the "
            "response must be complex"
        )
    return r


def _units_variable(mat: dict[str, Any], path: Path) -> str:
    """``response_units``, a character string, or ``""`` if the file has none."""
    units = ""
    if "response_units" in mat:
        u = np.asarray(mat["response_units"])
        if u.dtype.kind != "U" or u.size > 1:
            raise FileFormatError(
                f"{path}, variable 'response_units': {u.dtype} of shape {u.shape}; expected a "
                "character string such as 'V/V'"
            )
        units = str(u.item()).strip() if u.size else ""
    return units
