"""Response-file formats as engines: what a format declares, and how a file finds its engine.

A format is an *engine*, registered through the toolkit's plugin system like a device (the hook
``sysid_response_formats``, :mod:`sysid_core.plugin.spec`): the built-in ones (own CSV,
Touchstone, MATLAB ``.mat``, netCDF and column-mapped text) come from the ``sysid_formats``
plugin, and a third party adds its own from its package exactly the same way
(``docs/contracts.md``). An engine subclasses :class:`ResponseFormat`:

* ``name`` (what a manifest's ``format = ...`` or ``sysid export --format`` says), ``extensions``
  (lower case, with the dot) and a one-line ``description``;
* :meth:`~ResponseFormat.guess_can_open`: whether a file looks like one of its files (by default:
  its extension), as xarray's backends do;
* :meth:`~ResponseFormat.open_sweep`: the file's sweep, checked (a complex
  ``(frequency, output, input)`` DataArray, :func:`sysid_core.data.sweep.make_sweep`), or a
  :class:`~sysid_core.errors.FileFormatError` naming the file and what is wrong in it;
* optionally :meth:`~ResponseFormat.write_sweep` (``writes = True``).

:func:`engine_for` picks the engine of a file: the one named, else the first (by name) whose
:meth:`~ResponseFormat.guess_can_open` claims it.
"""

from __future__ import annotations

from abc import ABC, abstractmethod
from pathlib import Path
from typing import Any, ClassVar

import numpy as np
import xarray as xr

from sysid_core.errors import FileFormatError, PluginError
from sysid_core.plugin.registry import Registry, get_registry

__all__ = ["KIND", "ResponseFormat", "engine_for", "engines", "format_names", "sweep_extensions"]

#: The registry's kind of a format engine.
KIND = "response format"


class ResponseFormat(ABC):
    """One response-file format: a sweep (2x2 complex response per frequency) per file."""

    #: The engine's name.
    name: ClassVar[str]
    #: File extensions, lower case with the dot (``(".csv",)``).
    extensions: ClassVar[tuple[str, ...]] = ()
    #: One line for ``sysid plugins``.
    description: ClassVar[str] = ""
    #: Whether :meth:`write_sweep` is implemented.
    writes: ClassVar[bool] = False

    def guess_can_open(self, path: Path) -> bool:
        """Whether ``path`` looks like a file of this format (default: by its extension)."""
        return path.suffix.lower() in self.extensions

    @abstractmethod
    def open_sweep(self, path: Path, **options: Any) -> xr.DataArray:
        """The sweep in ``path``, checked; :class:`~sysid_core.errors.FileFormatError` if not.

        ``options``: what a manifest gives the engine (the column-mapped engine's
        ``column_map`` and ``files``); an engine that takes none refuses unknown ones.
        """

    def write_sweep(
        self,
        path: Path,
        frequency_hz: np.ndarray,
        response: np.ndarray,
        units: str,
        time_s: np.ndarray | None,
    ) -> None:
        """Write one checked sweep to ``path`` (a temporary file the caller renames)."""
        raise FileFormatError(f"the {self.name!r} format is read-only; write another format")


def engines(registry: Registry | None = None) -> list[ResponseFormat]:
    """Every registered format engine, by name (the first provider of each name)."""
    registry = registry if registry is not None else get_registry()
    found = []
    for name in registry.names(KIND):
        engine = registry.create(KIND, name)
        if not isinstance(engine, ResponseFormat):
            raise PluginError(
                f"response format {name!r} ({registry.get(KIND, name).plugin}) is a "
                f"{type(engine).__name__}, not a sysid_core.formats.engine.ResponseFormat"
            )
        found.append(engine)
    return found


def format_names(registry: Registry | None = None, *, writes: bool = False) -> list[str]:
    """The names of the registered engines (only those that write, with ``writes``)."""
    return [e.name for e in engines(registry) if e.writes or not writes]


def sweep_extensions(registry: Registry | None = None) -> tuple[str, ...]:
    """Every extension a registered engine claims, the built-in ones first."""
    return _extensions(engines(registry))


def _extensions(every: list[ResponseFormat]) -> tuple[str, ...]:
    found = [ext for e in every for ext in e.extensions]
    first = [ext for ext in (".csv", ".s2p", ".mat", ".nc") if ext in found]
    return tuple(dict.fromkeys([*first, *found]))


def engine_for(
    path: Path, name: str | None = None, registry: Registry | None = None
) -> ResponseFormat:
    """The engine of ``path``: the one called ``name``, else the first that claims the file.

    Raises
    ------
    FileFormatError
        No engine of that name, or none claims the file (the message lists the engines and
        their extensions).
    """
    every = engines(registry)
    if name is not None:
        for engine in every:
            if engine.name == name:
                return engine
        raise FileFormatError(
            f"{path}: no response format {name!r}; the formats are "
            f"{', '.join(e.name for e in every) or 'none (is sysid-toolkit installed?)'}"
        )
    for engine in every:
        if engine.guess_can_open(path):
            return engine
    known = ", ".join(_extensions(every))
    raise FileFormatError(
        f"{path}: unknown response-file extension {path.suffix or '(none)'!r}; supported: "
        f"{known or 'none (no format is registered: is sysid-toolkit installed?)'}; or name "
        "the file's format (a manifest's format = \"csv\"; sysid plugins lists the formats)"
    )
