"""Exporting a data set as response files and a manifest (``docs/measured-data.md``).

* :func:`export_dataset`: one response file per experiment (``exp0.csv``, ...) and a manifest
  that :func:`sysid_core.formats.manifest.load_manifest` reads back exactly.
* :func:`export_files`: the files it writes.
* :func:`toml_string`: a TOML basic string (for the manifests and column maps the toolkit writes).
"""

from __future__ import annotations

import math
import os
from pathlib import Path

import numpy as np
import xarray as xr

from sysid_core.data.io import atomic_write
from sysid_core.data.schema import make_dataset, measured_mask, point_times, save_dataset
from sysid_core.errors import FileFormatError, MissingBiasError
from sysid_core.formats.engine import engines
from sysid_core.formats.sweepfiles import make_sweep, write_sweep

__all__ = [
    "EXPORT_FORMATS",
    "MANIFEST_NAME",
    "export_dataset",
    "export_extension",
    "export_files",
    "toml_string",
]

#: The built-in formats of :func:`export_dataset` (the response files' extensions); any engine
#: that writes (:mod:`sysid_core.formats.engine`) is one too, by its name or extension.
EXPORT_FORMATS = ("csv", "s2p", "mat", "nc")
#: The name of the manifest :func:`export_dataset` writes.
MANIFEST_NAME = "manifest.toml"


def export_extension(format: str) -> str:
    """The extension (no dot) of export format ``format``: an extension or a writing engine."""
    fmt = str(format).lower().lstrip(".")
    writers = [e for e in engines() if e.writes and e.extensions]
    for engine in writers:
        if fmt == engine.name or f".{fmt}" in engine.extensions:
            return engine.extensions[0].lstrip(".")
    known = ", ".join(dict.fromkeys([*EXPORT_FORMATS, *(e.extensions[0][1:] for e in writers)]))
    raise FileFormatError(f"unknown export format {format!r}; supported: {known}")


def export_files(ds: xr.Dataset, folder: str | os.PathLike[str], format: str = "csv") -> list[Path]:
    """The files :func:`export_dataset` writes: ``exp0.<format>``, ... and the manifest last."""
    fmt = export_extension(format)
    folder = Path(folder)
    names = [folder / f"exp{k}.{fmt}" for k in range(ds.sizes["experiment"])]
    return [*names, folder / MANIFEST_NAME]


def toml_string(text: str) -> str:
    """A TOML basic string."""
    out = []
    for ch in text:
        if ch in '"\\':
            out.append("\\" + ch)
        elif ord(ch) < 0x20 or ord(ch) == 0x7F:
            out.append(f"\\u{ord(ch):04X}")
        else:
            out.append(ch)
    return '"' + "".join(out) + '"'


def _toml_float(value: float) -> str:
    return repr(float(value))


def export_dataset(ds: xr.Dataset, folder: str | os.PathLike[str], format: str = "csv") -> Path:
    """Write a data set as one response file per experiment and a manifest; return the manifest.

    ``load_manifest(export_dataset(ds, folder, format))`` gives back the data set's responses,
    frequency grids, biases, electrodes, structure potential, device and response units: exactly
    for every format (the Touchstone files are written with every digit). Other attributes are
    not kept. Files are written atomically, the manifest last, over any files of the same names.

    Parameters
    ----------
    ds : xarray.Dataset
        A data set (:mod:`sysid_core.data.schema`); its channels are written in order as y1, y2 /
        u1, u2.
    folder : path-like
        Created if needed.
    format : {"csv", "s2p", "mat", "nc"}
        The response files' format (``nc``: one-experiment data sets, biases included).
    """
    fmt = export_extension(format)
    folder = Path(folder)
    files = export_files(ds, folder, fmt)
    bias = np.asarray(ds["bias"].values, dtype=float)
    vg = float(ds.attrs.get("structure_potential", float("nan")))
    if not np.isfinite(bias).all() or not math.isfinite(vg):
        raise MissingBiasError("the data set's biases or structure_potential are not all finite")
    electrodes = [str(e) for e in ds["electrode"].values]
    device = str(ds.attrs.get("device", "unknown"))
    units = str(ds.attrs.get("response_units", ""))
    mask = measured_mask(ds)
    f_all = np.asarray(ds["frequency"].values, dtype=float)
    values = np.asarray(ds["response"].transpose(*("experiment", "frequency", "output", "input")))
    lines = [
        "# Measured experiments (docs/measured-data.md), written by sysid-toolkit.",
        f"device = {toml_string(device)}",
        f"structure_potential_v = {_toml_float(vg)}",
        f"electrodes = [{', '.join(toml_string(e) for e in electrodes)}]",
    ]
    for k, target in enumerate(files[:-1]):
        f, resp = f_all[mask[k]], values[k][mask[k]]
        times = point_times(ds, k)
        if fmt == "nc":
            one = make_dataset(
                [resp],
                f,
                [bias[k]],
                electrodes,
                vg,
                device=device,
                outputs=[str(o) for o in ds["output"].values],
                inputs=[str(i) for i in ds["input"].values],
                response_units=units,
                times_s=[times],
            )
            save_dataset(one, target)
        else:
            write_sweep(target, make_sweep(f, resp, time_s=times), units)
        biases = ", ".join(_toml_float(b) for b in bias[k])
        lines += [
            "",
            "[[experiment]]",
            f"bias_v = [{biases}]",
            f"file = {toml_string(target.name)}",
        ]
    text = "\n".join(lines) + "\n"
    return atomic_write(files[-1], lambda tmp: tmp.write_text(text, encoding="utf-8"))
