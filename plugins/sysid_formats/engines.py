"""The built-in format engines: own CSV, Touchstone, MATLAB, netCDF and column-mapped text.

Each file format's reader and writer live in :mod:`sysid_core.formats`; an engine here only
names them, with the format's extensions.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from pathlib import Path
from typing import Any, ClassVar

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

Writer = Callable[[Path, np.ndarray, np.ndarray, str, "np.ndarray | None"], None]


def _no_options(engine: ResponseFormat, path: Path, options: Mapping[str, Any]) -> None:
    if options:
        raise FileFormatError(
            f"{path}: the {engine.name!r} format takes no options (got "
            f"{', '.join(sorted(options))}); a column map applies to text files only"
        )


def _write_csv(
    path: Path, f: np.ndarray, resp: np.ndarray, units: str, times: np.ndarray | None
) -> None:
    path.write_text(csv_text(f, resp, units, times), encoding="utf-8")


def _write_s2p(
    path: Path, f: np.ndarray, resp: np.ndarray, units: str, times: np.ndarray | None
) -> None:
    path.write_text(s2p_text(f, resp, units), encoding="utf-8")  # no place for time stamps


class _FileFormat(ResponseFormat):
    """An engine of one reader and one writer function, taking no options."""

    reader: ClassVar[Callable[[Path], xr.DataArray]]
    writer: ClassVar[Writer]
    writes = True

    def open_sweep(self, path: Path, **options: Any) -> xr.DataArray:
        _no_options(self, path, options)
        return type(self).reader(path)

    def write_sweep(
        self,
        path: Path,
        frequency_hz: np.ndarray,
        response: np.ndarray,
        units: str,
        time_s: np.ndarray | None,
    ) -> None:
        type(self).writer(path, frequency_hz, response, units, time_s)


class CsvFormat(_FileFormat):
    """The toolkit's own CSV: a header of 9 (or 10, with time stamps) columns, a row a point."""

    name = "csv"
    extensions = (".csv",)
    description = "the toolkit's own CSV (frequency_hz, y1_u1_re, ..., optional time_s)"
    reader = staticmethod(read_csv)
    writer = staticmethod(_write_csv)


class TouchstoneFormat(_FileFormat):
    """Touchstone ``.s2p`` with scikit-rf (``S_ij`` = output ``i`` over input ``j``)."""

    name = "touchstone"
    extensions = (".s2p",)
    description = "Touchstone .s2p (scikit-rf); no time stamps"
    reader = staticmethod(read_s2p)
    writer = staticmethod(_write_s2p)


class MatFormat(_FileFormat):
    """MATLAB ``.mat`` (v4 to v7.3): ``frequency_hz``, ``response`` (n, 2, 2) complex."""

    name = "mat"
    extensions = (".mat",)
    description = "MATLAB .mat, v4 to v7.3 (frequency_hz, response, optional time_s)"
    reader = staticmethod(read_mat)
    writer = staticmethod(write_mat)


class NetcdfFormat(_FileFormat):
    """netCDF: a one-experiment data set, or a bare DataArray of one sweep."""

    name = "netcdf"
    extensions = (".nc",)
    description = "netCDF: a one-experiment data set or a bare (frequency, output, input) array"
    reader = staticmethod(read_nc)
    writer = staticmethod(write_nc)


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
