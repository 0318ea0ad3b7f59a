"""Manifests of measured experiments: one TOML file naming a response file per bias.

A manifest (``docs/measured-data.md``)::

    device = "cloverleaf"              # optional, metadata
    structure_potential_v = 15.58      # v_gyro, volts
    electrodes = ["B1", "B2"]
    [[experiment]]
    bias_v = [0.0, 0.0]                # one δv per electrode, volts relative to ground
    file = "exp0.csv"                  # relative to the manifest; .csv, .s2p, .mat or .nc

* :func:`read_manifest`: the manifest's contents, checked (no response file is read).
* :func:`load_manifest`: every response file read (:func:`sysid_core.data.sweepfiles.read_sweep`),
  the data set built (:func:`sysid_core.data.schema.make_dataset`; grids may differ) and validated
  (:func:`sysid_core.data.validation.validate`, rank condition (6) included).
* :func:`export_dataset`: the other way, one response file per experiment and a manifest.
* :func:`load_data` / :func:`data_files`: a data path of either kind (``.toml`` or netCDF).

Experiments are numbered from 0 in the order of the ``[[experiment]]`` tables; every error names
the manifest and, where it applies, that number.
"""

from __future__ import annotations

import math
import os
import tomllib
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
import xarray as xr

from sysid_core.data.io import atomic_write
from sysid_core.data.schema import (
    load_dataset,
    make_dataset,
    measured_mask,
    point_times,
    save_dataset,
)
from sysid_core.data.sweepfiles import make_sweep, read_sweep, write_sweep
from sysid_core.data.validation import validate
from sysid_core.errors import DataError, FileFormatError, ManifestError, MissingBiasError

__all__ = [
    "EXPORT_FORMATS",
    "MANIFEST_NAME",
    "Manifest",
    "ManifestExperiment",
    "data_files",
    "export_dataset",
    "export_files",
    "load_data",
    "load_manifest",
    "read_manifest",
]

#: Formats of :func:`export_dataset` (the response files' extensions).
EXPORT_FORMATS = ("csv", "s2p", "mat", "nc")
#: The name of the manifest :func:`export_dataset` writes.
MANIFEST_NAME = "manifest.toml"
_TOP_KEYS = ("device", "structure_potential_v", "electrodes", "experiment")
_EXPERIMENT_KEYS = ("bias_v", "file")


@dataclass(frozen=True)
class ManifestExperiment:
    """One ``[[experiment]]`` table: its number, bias (V, one per electrode) and response file."""

    index: int
    bias_v: tuple[float, ...]
    file: Path


@dataclass(frozen=True)
class Manifest:
    """A checked manifest; ``file`` paths are resolved against the manifest's folder."""

    path: Path
    structure_potential_v: float
    electrodes: tuple[str, ...]
    experiments: tuple[ManifestExperiment, ...]
    device: str = "unknown"


def _number(value: object, where: str) -> float:
    if isinstance(value, bool) or not isinstance(value, int | float):
        raise ManifestError(f"{where} is {value!r}; expected a number (volts)")
    if not math.isfinite(value):
        raise ManifestError(f"{where} is {value}; expected a finite number (volts)")
    return float(value)


def _unknown(table: dict[str, Any], allowed: tuple[str, ...], where: str) -> None:
    for key in table:
        if key not in allowed:
            raise ManifestError(f"{where}: unknown key {key!r} (allowed: {', '.join(allowed)})")


def read_manifest(path: str | os.PathLike[str]) -> Manifest:
    """Read and check a manifest, without reading its response files.

    Raises
    ------
    ManifestError
        A missing or unparsable manifest, an unknown key, a missing or mistyped value, an empty
        experiment list, a bias with the wrong number of values, a response file that does not
        exist; naming the manifest and the experiment's number.
    """
    path = Path(path)
    doc = _read_toml(path)
    _unknown(doc, _TOP_KEYS, str(path))
    for key in ("structure_potential_v", "electrodes", "experiment"):
        if key not in doc:
            raise ManifestError(f"{path}: missing key {key!r}")
    device = doc.get("device", "unknown")
    if not isinstance(device, str):
        raise ManifestError(f"{path}: device is {device!r}; expected a string")
    vg = _number(doc["structure_potential_v"], f"{path}: structure_potential_v")
    electrodes = _electrodes(doc["electrodes"], path)
    tables = _experiment_tables(doc["experiment"], path)
    experiments = [_experiment(k, table, path, electrodes) for k, table in enumerate(tables)]
    return Manifest(path, vg, tuple(electrodes), tuple(experiments), device)


def _read_toml(path: Path) -> dict[str, Any]:
    """The manifest file's TOML document."""
    if not path.is_file():
        raise ManifestError(f"{path}: no such manifest file")
    try:
        with open(path, "rb") as fh:
            return tomllib.load(fh)
    except tomllib.TOMLDecodeError as exc:
        raise ManifestError(f"{path}: not valid TOML: {exc}") from exc
    except UnicodeDecodeError as exc:
        raise ManifestError(f"{path}: not a UTF-8 text file ({exc.reason})") from exc


def _electrodes(electrodes: object, path: Path) -> list[str]:
    """The manifest's ``electrodes``: a non-empty list of distinct, non-empty names."""
    if (
        not isinstance(electrodes, list)
        or not electrodes
        or not all(isinstance(e, str) and e for e in electrodes)
    ):
        raise ManifestError(
            f"{path}: electrodes is {electrodes!r}; expected a non-empty list of names, "
            'e.g. ["B1", "B2"]'
        )
    if len(set(electrodes)) != len(electrodes):
        raise ManifestError(f"{path}: electrodes {electrodes} has a name twice")
    return electrodes


def _experiment_tables(tables: object, path: Path) -> list[dict[str, Any]]:
    """The manifest's ``[[experiment]]`` tables: a non-empty list."""
    if not isinstance(tables, list) or not all(isinstance(t, dict) for t in tables):
        raise ManifestError(
            f"{path}: experiment must be a list of [[experiment]] tables (note the double brackets)"
        )
    if not tables:
        raise ManifestError(f"{path}: the experiment list is empty")
    return tables


def _experiment(
    k: int, table: dict[str, Any], path: Path, electrodes: list[str]
) -> ManifestExperiment:
    """Experiment ``k`` of the manifest at ``path``, checked; its response file must exist."""
    where = f"{path}, experiment {k}"
    _unknown(table, _EXPERIMENT_KEYS, where)
    for key in _EXPERIMENT_KEYS:
        if key not in table:
            raise ManifestError(f"{where}: missing key {key!r}")
    bias = table["bias_v"]
    if not isinstance(bias, list) or len(bias) != len(electrodes):
        count = f"{len(bias)} value(s)" if isinstance(bias, list) else repr(bias)
        raise ManifestError(
            f"{where}: bias_v has {count}; expected one per electrode ({len(electrodes)}: "
            f"{', '.join(electrodes)})"
        )
    values = tuple(_number(b, f"{where}: bias_v[{p}]") for p, b in enumerate(bias))
    name = table["file"]
    if not isinstance(name, str) or not name:
        raise ManifestError(f"{where}: file is {name!r}; expected a file name")
    file = path.parent / name
    if not file.is_file():
        what = "is not a file" if file.exists() else "does not exist"
        raise ManifestError(f"{where}: response file {file} {what}")
    return ManifestExperiment(k, values, file)


def load_manifest(path: str | os.PathLike[str]) -> xr.Dataset:
    """Read a manifest and its response files into a validated data set.

    Parameters
    ----------
    path : path-like
        The manifest (TOML, see the module).

    Returns
    -------
    xarray.Dataset
        Following :mod:`sysid_core.data.schema`'s schema: one experiment per ``[[experiment]]``
        table in order, with a ``measured`` mask when their frequency grids differ; attributes
        ``device`` and ``response_units`` from the manifest and the files.

    Raises
    ------
    ManifestError
        See :func:`read_manifest`; also response files with different units.
    FileFormatError
        A response file that cannot be read (naming the manifest, the experiment, the file and
        the line or variable).
    DataError
        The data set fails :func:`~sysid_core.data.validation.validate` (its subclass, e.g.
        ``RankConditionError`` naming the experiments), prefixed with the manifest's path.
    """
    manifest = read_manifest(path)
    sweeps = []
    for exp in manifest.experiments:
        try:
            sweeps.append(read_sweep(exp.file))
        except FileFormatError as exc:
            raise FileFormatError(f"{manifest.path}, experiment {exp.index}: {exc}") from exc
    units = {str(s.attrs["units"]) for s in sweeps} - {""}
    if len(units) > 1:
        which = ", ".join(f"{k}: {s.attrs['units']!r}" for k, s in enumerate(sweeps))
        raise ManifestError(f"{manifest.path}: the response files have different units ({which})")
    ds = make_dataset(
        [s.values for s in sweeps],
        [s["frequency"].values for s in sweeps],
        [e.bias_v for e in manifest.experiments],
        manifest.electrodes,
        manifest.structure_potential_v,
        device=manifest.device,
        response_units=units.pop() if units else "",
        times_s=[
            np.asarray(s["time_s"].values, dtype=float) if "time_s" in s.coords else None
            for s in sweeps
        ],
    )
    try:
        return validate(ds)
    except DataError as exc:
        files = ", ".join(
            f"{e.index} = {os.path.relpath(e.file, manifest.path.parent)}"
            for e in manifest.experiments
        )
        raise type(exc)(f"{manifest.path}: {exc} (experiments: {files})") from exc


def _is_manifest(path: Path) -> bool:
    return path.suffix.lower() == ".toml"


def load_data(path: str | os.PathLike[str]) -> xr.Dataset:
    """A data set from a manifest (``.toml``) or a netCDF file.

    A manifest is read with :func:`load_manifest`, a netCDF file with
    :func:`~sysid_core.data.schema.load_dataset` (not validated here: the fit does that).
    """
    path = Path(path)
    return load_manifest(path) if _is_manifest(path) else load_dataset(path)


def data_files(path: str | os.PathLike[str]) -> list[Path]:
    """The files a data path stands for: a manifest and its response files, or the netCDF file.

    The command-line program refuses to write over any of them.
    """
    path = Path(path)
    if not _is_manifest(path):
        return [path]
    return [path, *(e.file for e in read_manifest(path).experiments)]


# ------------------------------------------------------------------------------------ export
def _format(format: str) -> str:
    fmt = str(format).lower().lstrip(".")
    if fmt not in EXPORT_FORMATS:
        raise FileFormatError(
            f"unknown export format {format!r}; supported: {', '.join(EXPORT_FORMATS)}"
        )
    return fmt


def export_files(ds: xr.Dataset, folder: str | os.PathLike[str], format: str = "csv") -> list[Path]:
    """The files :func:`export_dataset` writes: ``exp0.<format>``, ... and the manifest last."""
    fmt = _format(format)
    folder = Path(folder)
    names = [folder / f"exp{k}.{fmt}" for k in range(ds.sizes["experiment"])]
    return [*names, folder / MANIFEST_NAME]


def _toml_string(text: str) -> str:
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
    fmt = _format(format)
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
        f"device = {_toml_string(device)}",
        f"structure_potential_v = {_toml_float(vg)}",
        f"electrodes = [{', '.join(_toml_string(e) for e in electrodes)}]",
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
            f"file = {_toml_string(target.name)}",
        ]
    text = "\n".join(lines) + "\n"
    return atomic_write(files[-1], lambda tmp: tmp.write_text(text, encoding="utf-8"))
