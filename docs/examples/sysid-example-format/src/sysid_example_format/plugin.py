"""The plugin module the entry point names: it registers the format's engine."""

from __future__ import annotations

from collections.abc import Callable, Mapping

from sysid_core import hookimpl
from sysid_core.formats.engine import ResponseFormat
from sysid_example_format.engine import NpzFormat


@hookimpl
def sysid_response_formats() -> Mapping[str, Callable[[], ResponseFormat]]:
    return {"npz": NpzFormat}
