"""``sysid import`` and ``sysid export``: measured response files to and from a data set.

* ``sysid import MANIFEST.toml [--out DATA.nc] [--force]``: read a manifest and its response
  files, validate them (rank condition (6) included) and save one netCDF data set.
* ``sysid import --guess FILE``: print a column map proposed for an instrument's text export
  (TOML for the manifest, with what it could not decide as comments); nothing is written.
* ``sysid export DATA --format csv|s2p|mat|nc --out DIR [--force]``: one response file per
  experiment and ``DIR/manifest.toml``; DATA is a netCDF data set or a manifest.

Neither writes over its inputs; without ``--force`` neither writes over an existing file nor
into a folder that is not empty. Formats: ``docs/measured-data.md``.
"""

from __future__ import annotations

import enum
from pathlib import Path
from typing import Annotated

import typer
import xarray as xr

from sysid_core.cli.app import command, out
from sysid_core.data.io import check_output_file
from sysid_core.data.schema import measured_mask, save_dataset
from sysid_core.errors import FileFormatError, ManifestError, OutputError
from sysid_core.formats.columnguess import guess_column_map
from sysid_core.formats.export import export_extension
from sysid_core.formats.manifest import (
    data_files,
    export_dataset,
    export_files,
    load_data,
    load_manifest,
)

__all__ = ["ExportFormat", "export_cmd", "import_cmd"]


class ExportFormat(enum.StrEnum):
    """The built-in response-file formats of ``sysid export`` (a format plugin adds its own)."""

    csv = "csv"
    s2p = "s2p"
    mat = "mat"
    nc = "nc"


def _describe(ds: xr.Dataset) -> str:
    """``3 experiment(s), 61 points each`` (or ``59-61 points``)."""
    points = measured_mask(ds).sum(axis=1)
    lo, hi = int(points.min()), int(points.max())
    grid = f"{lo} points each" if lo == hi else f"{lo}-{hi} points"
    return f"{points.size} experiment(s), {grid}"


@command("import")
def import_cmd(
    manifest: Annotated[
        Path | None, typer.Argument(help="Manifest of measured experiments (.toml, see docs).")
    ] = None,
    out_path: Annotated[
        Path | None,
        typer.Option("--out", help="Write the data set here (netCDF; default MANIFEST.nc)."),
    ] = None,
    force: Annotated[bool, typer.Option("--force", help="Replace an existing file.")] = False,
    guess: Annotated[
        Path | None,
        typer.Option(
            "--guess",
            help="Print a column map proposed for this text export (TOML to check and paste "
            "into a manifest) and exit.",
        ),
    ] = None,
) -> None:
    """Read a manifest and its response files into one validated netCDF data set."""
    if guess is not None:
        if manifest is not None or out_path is not None or force:
            raise typer.BadParameter("takes no MANIFEST, --out or --force", param_hint="--guess")
        typer.echo(guess_column_map(guess).toml(), nl=False)
        return
    if manifest is None:
        raise typer.BadParameter("missing (or give --guess FILE)", param_hint="'MANIFEST'")
    if manifest.suffix.lower() != ".toml":
        raise ManifestError(f"{manifest}: sysid import reads a manifest (.toml)")
    target = out_path or manifest.with_suffix(".nc")
    inputs = data_files(manifest)
    check_output_file(target, inputs=inputs, force=force)
    ds = load_manifest(manifest)
    check_output_file(target, inputs=inputs, force=force)  # nothing appeared meanwhile
    save_dataset(ds, target)
    out.print(
        f"wrote {target}: {_describe(ds)}, electrodes "
        f"{', '.join(str(e) for e in ds['electrode'].values)}"
    )


@command("export")
def export_cmd(
    data: Annotated[Path, typer.Argument(help="Data set (netCDF) or manifest (.toml).")],
    out_dir: Annotated[Path, typer.Option("--out", help="Folder for the files and manifest.")],
    fmt: Annotated[
        str,
        typer.Option(
            "--format",
            help="Format of the response files: csv, s2p, mat, nc, or a format plugin's name.",
        ),
    ] = ExportFormat.csv.value,
    force: Annotated[
        bool,
        typer.Option("--force", help="Write into a folder that is not empty, over its files."),
    ] = False,
) -> None:
    """Write one response file per experiment of DATA and a manifest.toml into a folder."""
    try:
        export_extension(fmt)
    except FileFormatError as exc:
        raise typer.BadParameter(str(exc), param_hint="--format") from exc
    if out_dir.exists() and not out_dir.is_dir():
        raise OutputError(f"refusing to write into {out_dir}: not a folder")
    if out_dir.is_dir() and any(out_dir.iterdir()) and not force:
        raise OutputError(f"{out_dir} is not empty; pass --force to write into it")
    inputs = data_files(data)
    ds = load_data(data)
    targets = export_files(ds, out_dir, fmt)
    for target in targets:
        check_output_file(target, inputs=inputs, force=force)
    manifest = export_dataset(ds, out_dir, fmt)
    kind = targets[0].suffix.lstrip(".")
    out.print(f"wrote {len(targets) - 1} {kind} file(s) and {manifest}: {_describe(ds)}")
