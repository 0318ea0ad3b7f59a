"""Response files in MATLAB ``.mat`` (see :mod:`sysid_core.data.sweepfiles`)."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np
import xarray as xr

from sysid_core.data.sweep import (
    check_sweep,
    make_sweep,
)
from sysid_core.errors import (
    FileFormatError,
)

__all__ = ["read_mat", "write_mat"]


# -------------------------------------------------------------------------------- MATLAB .mat
def write_mat(tmp: Path, f: np.ndarray, resp: np.ndarray, units: str) -> None:
    from scipy.io import savemat

    variables: dict[str, Any] = {"frequency_hz": f, "response": resp}
    if units:
        variables["response_units"] = units
    savemat(str(tmp), variables, appendmat=False, oned_as="column")


def read_mat(path: Path) -> xr.DataArray:
    from scipy.io import loadmat

    try:
        mat = loadmat(path, squeeze_me=False)
    except NotImplementedError as exc:  # MATLAB v7.3 (HDF5)
        raise FileFormatError(
            f"{path}: a MATLAB v7.3 (HDF5) file; save it with save(..., '-v7') ({exc})"
        ) from exc
    except Exception as exc:  # scipy raises ValueError, TypeError, MatReadError, ...
        raise FileFormatError(f"{path}: not a MATLAB .mat file ({exc})") from exc
    found = sorted(k for k in mat if not k.startswith("__"))
    for name in ("frequency_hz", "response"):
        if name not in mat:
            raise FileFormatError(
                f"{path}: no variable {name!r} (found: {', '.join(found) or 'none'}); expected "
                "frequency_hz (n,) and response (n, 2, 2) complex"
            )
    f = np.asarray(mat["frequency_hz"])
    if f.ndim == 2 and 1 in f.shape:
        f = f.ravel()
    if f.ndim != 1 or f.dtype.kind not in "iuf":
        raise FileFormatError(
            f"{path}, variable 'frequency_hz': {f.dtype} of shape {f.shape}; expected a real "
            "vector (n,) in Hz"
        )
    r = np.asarray(mat["response"])
    n = f.size
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
    units = ""
    if "response_units" in mat:
        u = np.asarray(mat["response_units"])
        if u.dtype.kind != "U" or u.size > 1:
            raise FileFormatError(
                f"{path}, variable 'response_units': {u.dtype} of shape {u.shape}; expected a "
                "character string such as 'V/V'"
            )
        units = str(u.item()).strip() if u.size else ""

    def freq_at(k: int) -> str:
        return f"{path}, variable 'frequency_hz'[{k}]"

    def value_at(k: int, o: int, i: int) -> str:
        return f"{path}, variable 'response'[{k}, {o}, {i}]"

    check_sweep(f.astype(float), r.astype(complex), str(path), freq_at, value_at)
    return make_sweep(f, r, units, str(path))
