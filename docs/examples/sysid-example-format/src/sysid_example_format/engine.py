"""Sweeps in numpy ``.npz`` archives: ``frequency_hz``, ``response`` and optional ``time_s``."""

from __future__ import annotations

import zipfile
from pathlib import Path
from typing import Any

import numpy as np
import xarray as xr

from sysid_core.data.sweep import check_sweep, check_times, make_sweep
from sysid_core.errors import FileFormatError
from sysid_core.formats.engine import ResponseFormat


class NpzFormat(ResponseFormat):
    """One sweep per ``.npz``: ``frequency_hz`` (n,), ``response`` (n, 2, 2) complex."""

    name = "npz"
    extensions = (".npz",)
    description = "numpy .npz archives (frequency_hz, response, optional time_s)"
    writes = True

    def open_sweep(self, path: Path, **options: Any) -> xr.DataArray:
        if options:
            raise FileFormatError(f"{path}: the 'npz' format takes no options")
        try:
            with np.load(path, allow_pickle=False) as npz:
                arrays = {name: npz[name] for name in npz.files}
        except (OSError, ValueError, zipfile.BadZipFile) as exc:
            raise FileFormatError(f"{path}: not a numpy .npz archive ({exc})") from exc
        for name in ("frequency_hz", "response"):
            if name not in arrays:
                found = ", ".join(sorted(arrays)) or "nothing"
                raise FileFormatError(f"{path}: no array {name!r} (found: {found})")
        f = np.asarray(arrays["frequency_hz"], dtype=float).ravel()
        resp = np.asarray(arrays["response"])
        if not np.iscomplexobj(resp) or resp.shape != (f.size, 2, 2):
            raise FileFormatError(
                f"{path}: 'response' is {resp.dtype} {resp.shape}; expected complex "
                f"({f.size}, 2, 2)"
            )
        check_sweep(
            f,
            resp,
            str(path),
            lambda k: f"{path}, 'frequency_hz'[{k}]",
            lambda k, o, i: f"{path}, 'response'[{k}, {o}, {i}]",
        )
        times = None
        if "time_s" in arrays:
            times = np.asarray(arrays["time_s"], dtype=float).ravel()
            check_times(times, lambda k: f"{path}, 'time_s'[{k}]", f.size)
        units = str(arrays["response_units"]) if "response_units" in arrays else ""
        return make_sweep(f, resp, units, str(path), times)

    def write_sweep(
        self,
        path: Path,
        frequency_hz: np.ndarray,
        response: np.ndarray,
        units: str,
        time_s: np.ndarray | None,
    ) -> None:
        arrays: dict[str, np.ndarray] = {
            "frequency_hz": frequency_hz,
            "response": response,
            "response_units": np.array(units),
        }
        if time_s is not None:
            arrays["time_s"] = time_s
        with open(path, "wb") as fh:  # np.savez would append .npz to a temporary name
            np.savez(fh, **arrays)
