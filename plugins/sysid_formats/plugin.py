"""Entry point of the built-in response-file formats."""

from __future__ import annotations

from collections.abc import Callable, Mapping

from sysid_core import hookimpl
from sysid_core.formats.engine import ResponseFormat
from sysid_formats.engines import (
    ColumnsFormat,
    CsvFormat,
    MatFormat,
    NetcdfFormat,
    TouchstoneFormat,
)


@hookimpl
def sysid_response_formats() -> Mapping[str, Callable[[], ResponseFormat]]:
    return {
        "csv": CsvFormat,
        "touchstone": TouchstoneFormat,
        "mat": MatFormat,
        "netcdf": NetcdfFormat,
        "columns": ColumnsFormat,
    }
