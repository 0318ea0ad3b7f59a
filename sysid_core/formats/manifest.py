"""Manifests of measured experiments: one TOML file naming the response files of each bias.

A manifest (``docs/measured-data.md``)::

    device = "cloverleaf"              # optional, metadata
    structure_potential_v = 15.58      # v_gyro, volts
    electrodes = ["B1", "B2"]
    [[experiment]]
    bias_v = [0.0, 0.0]                # one δv per electrode, volts relative to ground
    file = "exp0.csv"                  # relative to the manifest; .csv, .s2p, .mat or .nc

Files that are not in the toolkit's own layout (an instrument's text export) are read with a
column map (:mod:`sysid_core.formats.columnmap`): a top-level ``[columns]`` table for every
experiment, overridden key by key by an experiment's ``[experiment.columns]``. An experiment may
then have several files, ``files = { u1 = "a.csv", u2 = "b.csv" }`` (one per drive input) or
``files = { y1_u1 = ..., y1_u2 = ..., y2_u1 = ..., y2_u2 = ... }`` (one per channel), instead of
``file``. A column map applies to text files only: ``.s2p``, ``.mat`` and ``.nc`` files are read
as always.

* :func:`read_manifest`: the manifest's contents, checked (no response file is read).
* :func:`load_manifest`: every response file read (:func:`sysid_core.formats.sweepfiles.read_sweep`,
  or :func:`sysid_core.formats.columnsweep.read_columns` with a column map), the data set built
  (:func:`sysid_core.data.schema.make_dataset`; grids may differ) and validated
  (:func:`sysid_core.data.validation.validate`, rank condition (6) included).
* :func:`export_dataset`: the other way, one response file per experiment and a manifest
  (:mod:`sysid_core.formats.export`).
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

from sysid_core.data.schema import load_dataset, make_dataset
from sysid_core.data.validation import validate
from sysid_core.errors import DataError, FileFormatError, ManifestError
from sysid_core.formats.columnmap import (
    LAYOUTS,
    TEXT_FORMATS,
    ColumnMap,
    experiment_column_map,
)
from sysid_core.formats.engine import format_names
from sysid_core.formats.export import EXPORT_FORMATS, MANIFEST_NAME, export_dataset, export_files
from sysid_core.formats.sweepfiles import read_sweep

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

_TOP_KEYS = ("device", "structure_potential_v", "electrodes", "format", "columns", "experiment")
_EXPERIMENT_KEYS = ("bias_v", "file", "files", "format", "columns")


@dataclass(frozen=True)
class ManifestExperiment:
    """One ``[[experiment]]`` table: its number, bias (V, one per electrode) and response files.

    ``file`` is its response file (the first of ``files`` when it has several); ``files`` gives
    every file with its key (``""`` for a single file, ``u1``/``u2`` or ``y1_u1`` ...);
    ``columns`` is the column map it is read with, or ``None`` (the file's own format);
    ``format`` the engine the manifest names for it (``format = ...``), or ``None`` (the engine
    that claims the file by its extension, :mod:`sysid_core.formats.engine`).
    """

    index: int
    bias_v: tuple[float, ...]
    file: Path
    files: tuple[tuple[str, Path], ...] = ()
    columns: ColumnMap | None = None
    format: str | None = None

    def __post_init__(self) -> None:
        """Without ``files`` (made as before they existed): the one ``file``."""
        if not self.files:
            object.__setattr__(self, "files", (("", self.file),))


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
        exist, a column map that is not valid or does not fit the experiment's files; naming the
        manifest, the experiment's number and the key.
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
    top = doc.get("columns", {})
    if not isinstance(top, dict):
        raise ManifestError(f"{path}: columns is {top!r}; expected a table ([columns])")
    tables = _experiment_tables(doc["experiment"], path)
    names = format_names()
    top_format = _format(doc.get("format"), str(path), names)
    experiments = [
        _experiment(k, table, path, electrodes, top, top_format, names)
        for k, table in enumerate(tables)
    ]
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


def _format(value: object, where: str, names: list[str]) -> str | None:
    """A ``format`` key: ``None``, or the name of a registered engine."""
    if value is None:
        return None
    if not isinstance(value, str) or value not in names:
        raise ManifestError(
            f"{where}: format is {value!r}; expected one of {', '.join(names)} "
            "(sysid plugins lists them)"
        )
    return value


def _experiment(
    k: int,
    table: dict[str, Any],
    path: Path,
    electrodes: list[str],
    top: dict[str, Any],
    top_format: str | None,
    names: list[str],
) -> ManifestExperiment:
    """Experiment ``k`` of the manifest at ``path``, checked; its response files must exist.

    ``top`` is the manifest's ``[columns]`` table (empty without one), ``top_format`` its
    ``format`` (an experiment's own overrides it), ``names`` the registered formats.
    """
    where = f"{path}, experiment {k}"
    _unknown(table, _EXPERIMENT_KEYS, where)
    if "bias_v" not in table:
        raise ManifestError(f"{where}: missing key 'bias_v'")
    bias = table["bias_v"]
    if not isinstance(bias, list) or len(bias) != len(electrodes):
        count = f"{len(bias)} value(s)" if isinstance(bias, list) else repr(bias)
        raise ManifestError(
            f"{where}: bias_v has {count}; expected one per electrode ({len(electrodes)}: "
            f"{', '.join(electrodes)})"
        )
    values = tuple(_number(b, f"{where}: bias_v[{p}]") for p, b in enumerate(bias))
    files = _files(table, where, path)
    fmt = _format(table.get("format", top_format), where, names)
    if fmt is not None and fmt not in TEXT_FORMATS:
        if len(files) > 1 or "columns" in table:
            raise ManifestError(
                f"{where}: format = {fmt!r} reads one file of its own format; a column map "
                "(and files = {...}) is for text exports"
            )
        return ManifestExperiment(k, values, files[0][1], files, None, fmt)
    columns = experiment_column_map(table, top if fmt != "csv" else {}, where, files)
    if fmt == "columns" and columns is None:
        raise ManifestError(
            f"{where}: format = 'columns' needs a column map ([columns] or [experiment.columns])"
        )
    return ManifestExperiment(k, values, files[0][1], files, columns, fmt)


def _files(table: dict[str, Any], where: str, path: Path) -> tuple[tuple[str, Path], ...]:
    """An experiment's ``file`` (key ``""``) or ``files`` (keyed by input or channel)."""
    if ("file" in table) == ("files" in table):
        both = "both 'file' and 'files'" if "file" in table else "no key 'file' (or 'files')"
        raise ManifestError(f"{where}: {both}; give one response file, or several as files")
    if "file" in table:
        names = {"": table["file"]}
    else:
        names = table["files"]
        layouts = [keys for keys, _ in LAYOUTS.values() if keys != ("",)]
        if not isinstance(names, dict) or set(names) not in [set(k) for k in layouts]:
            given = ", ".join(names) if isinstance(names, dict) else repr(names)
            raise ManifestError(
                f"{where}: files has {given or 'no key'}; expected one file per drive input, "
                "files = { u1 = ..., u2 = ... }, or per channel, "
                "files = { y1_u1 = ..., y1_u2 = ..., y2_u1 = ..., y2_u2 = ... }"
            )
        names = {key: names[key] for keys in layouts if set(keys) == set(names) for key in keys}
    files = []
    for key, name in names.items():
        label = f"files.{key}" if key else "file"
        if not isinstance(name, str) or not name:
            raise ManifestError(f"{where}: {label} is {name!r}; expected a file name")
        file = path.parent / name
        if not file.is_file():
            what = "is not a file" if file.exists() else "does not exist"
            raise ManifestError(f"{where}: response file {file} {what}")
        files.append((key, file))
    return tuple(files)


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
            if exp.columns is None:
                sweeps.append(read_sweep(exp.file, exp.format))
            else:
                by_key = dict(exp.files)
                sweeps.append(read_sweep(exp.file, "columns", column_map=exp.columns, files=by_key))
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
            f"{e.index} = "
            + " + ".join(os.path.relpath(f, manifest.path.parent) for _, f in e.files)
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
    return [path, *(f for e in read_manifest(path).experiments for _, f in e.files)]
