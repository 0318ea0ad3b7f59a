"""The built-in format engines: own CSV, Touchstone, MATLAB, netCDF and column-mapped text."""

from __future__ import annotations

from collections.abc import Mapping
from pathlib import Path
from typing import Any

import numpy as np
import xarray as xr

from sysid_core.errors import FileFormatError
from sysid_core.formats.columnmap import ColumnMap
from sysid_core.formats.columnsweep import read_columns
from sysid_core.formats.csvsweep import csv_text, read_csv
from sysid_core.formats.engine import ResponseFormat
from sysid_core.formats.matsweep import read_mat, write_mat
from sysid_core.formats.netcdf import read_nc, write_nc
from sysid_core.formats.touchstone import read_s2p, s2p_text

__all__ = ["ColumnsFormat", "CsvFormat", "MatFormat", "NetcdfFormat", "TouchstoneFormat"]


def _no_options(engine: ResponseFormat, path: Path, options: Mapping[str, Any]) -> None:
    if options:
        raise FileFormatError(
            f"{path}: the {engine.name!r} format takes no options (got "
            f"{', '.join(sorted(options))}); a column map applies to text files only"
        )


class CsvFormat(ResponseFormat):
    """The toolkit's own CSV: a header of 9 (or 10, with time stamps) columns, a row a point."""

    name = "csv"
    extensions = (".csv",)
    description = "the toolkit's own CSV (frequency_hz, y1_u1_re, ..., optional time_s)"
    writes = True

    def open_sweep(self, path: Path, **options: Any) -> xr.DataArray:
        _no_options(self, path, options)
        return read_csv(path)

    def write_sweep(
        self,
        path: Path,
        frequency_hz: np.ndarray,
        response: np.ndarray,
        units: str,
        time_s: np.ndarray | None,
    ) -> None:
        path.write_text(csv_text(frequency_hz, response, units, time_s), encoding="utf-8")


class TouchstoneFormat(ResponseFormat):
    """Touchstone ``.s2p`` with scikit-rf (``S_ij`` = output ``i`` over input ``j``)."""

    name = "touchstone"
    extensions = (".s2p",)
    description = "Touchstone .s2p (scikit-rf); no time stamps"
    writes = True

    def open_sweep(self, path: Path, **options: Any) -> xr.DataArray:
        _no_options(self, path, options)
        return read_s2p(path)

    def write_sweep(
        self,
        path: Path,
        frequency_hz: np.ndarray,
        response: np.ndarray,
        units: str,
        time_s: np.ndarray | None,
    ) -> None:
        # Touchstone has no place for time stamps
        path.write_text(s2p_text(frequency_hz, response, units), encoding="utf-8")


class MatFormat(ResponseFormat):
    """MATLAB ``.mat`` (v4 to v7.3): ``frequency_hz``, ``response`` (n, 2, 2) complex."""

    name = "mat"
    extensions = (".mat",)
    description = "MATLAB .mat, v4 to v7.3 (frequency_hz, response, optional time_s)"
    writes = True

    def open_sweep(self, path: Path, **options: Any) -> xr.DataArray:
        _no_options(self, path, options)
        return read_mat(path)

    def write_sweep(
        self,
        path: Path,
        frequency_hz: np.ndarray,
        response: np.ndarray,
        units: str,
        time_s: np.ndarray | None,
    ) -> None:
        write_mat(path, frequency_hz, response, units, time_s)


class NetcdfFormat(ResponseFormat):
    """netCDF: a one-experiment data set, or a bare DataArray of one sweep."""

    name = "netcdf"
    extensions = (".nc",)
    description = "netCDF: a one-experiment data set or a bare (frequency, output, input) array"
    writes = True

    def open_sweep(self, path: Path, **options: Any) -> xr.DataArray:
        _no_options(self, path, options)
        return read_nc(path)

    def write_sweep(
        self,
        path: Path,
        frequency_hz: np.ndarray,
        response: np.ndarray,
        units: str,
        time_s: np.ndarray | None,
    ) -> None:
        write_nc(path, frequency_hz, response, units, time_s)


class ColumnsFormat(ResponseFormat):
    """An instrument's text export read with a column map (``docs/column-maps.md``).

    Never guessed from a file: a manifest's ``[columns]`` table selects it. Options:
    ``column_map`` (a :class:`~sysid_core.formats.columnmap.ColumnMap`) and ``files``, the
    experiment's files by layout key (``{"": path}`` for one file, ``{"u1": ..., "u2": ...}``
    or one per channel); without ``files``, ``path`` is the one file.
    """

    name = "columns"
    extensions = ()
    description = "an instrument's text export, read with a column map ([columns])"

    def guess_can_open(self, path: Path) -> bool:
        return False

    def open_sweep(self, path: Path, **options: Any) -> xr.DataArray:
        column_map = options.pop("column_map", None)
        files = options.pop("files", None)
        if not isinstance(column_map, ColumnMap):
            raise FileFormatError(
                f"{path}: the 'columns' format needs a column map (a [columns] table in the "
                "manifest; docs/column-maps.md)"
            )
        _no_options(self, path, options)
        return read_columns(dict(files) if files else {"": path}, column_map)
