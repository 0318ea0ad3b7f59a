"""Hook specifications of sysid-toolkit.

A plugin is a module (or object) registered under the entry-point group ``sysid``. It implements
any of the hooks below with the :data:`hookimpl` marker; every hook returns a mapping from
component names to factories. The built-in components are registered exactly the same way.

Example
-------
A third-party package adds a device with, in its ``pyproject.toml``::

    [project.entry-points.sysid]
    my-gyro = "my_gyro.plugin"

and in ``my_gyro/plugin.py``::

    from sysid_core import hookimpl

    @hookimpl
    def sysid_devices():
        return {"my-gyro": MyGyro}
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from typing import TYPE_CHECKING, Any

import pluggy

if TYPE_CHECKING:
    from sysid_core.plugin.interfaces import (
        Device,
        ModelStructure,
        Objective,
        Solver,
        TuningCriterion,
    )

__all__ = [
    "KIND_HOOKS",
    "PROJECT",
    "hookimpl",
    "hookspec",
    "sysid_cli_commands",
    "sysid_devices",
    "sysid_model_structures",
    "sysid_objectives",
    "sysid_response_formats",
    "sysid_solvers",
    "sysid_tuning_criteria",
]

#: The pluggy project name of sysid-toolkit; also the entry-point group.
PROJECT = "sysid"

hookspec = pluggy.HookspecMarker(PROJECT)
hookimpl = pluggy.HookimplMarker(PROJECT)


@hookspec
def sysid_devices() -> Mapping[str, Callable[..., Device]]:  # type: ignore[empty-body]
    """Return the devices this plugin provides.

    Called once when the registry loads plugins. Returns a mapping from device names (as used in
    the ``[device] name`` key of a configuration file) to factories. A factory is called with the
    keyword options of the config's ``[device]`` table, minus ``name``, and returns an object that
    follows the :class:`sysid_core.plugin.interfaces.Device` protocol.
    """


@hookspec
def sysid_model_structures() -> Mapping[str, Callable[..., ModelStructure]]:  # type: ignore[empty-body]
    """Return the model structures this plugin provides.

    Returns a mapping from names (``[model] structure``) to factories called as
    ``factory(order=n)``, returning a :class:`sysid_core.plugin.interfaces.ModelStructure`.
    """


@hookspec
def sysid_objectives() -> Mapping[str, Callable[..., Objective]]:  # type: ignore[empty-body]
    """Return the fit objectives this plugin provides.

    Returns a mapping from names (``[model] objective``) to factories called with the keyword
    options of the objective, returning a :class:`sysid_core.plugin.interfaces.Objective`.
    """


@hookspec
def sysid_solvers() -> Mapping[str, Callable[..., Solver]]:  # type: ignore[empty-body]
    """Return the conic-solver backends this plugin provides.

    Returns a mapping from names (``[solver] name``) to factories called with the keyword options
    of the ``[solver]`` table (minus ``name``), returning a
    :class:`sysid_core.plugin.interfaces.Solver`.
    """


@hookspec
def sysid_tuning_criteria() -> Mapping[str, Callable[..., TuningCriterion]]:  # type: ignore[empty-body]
    """Return the tuning criteria this plugin provides.

    Returns a mapping from names (``[tuning] criterion``) to factories called with the keyword
    options of the criterion (for example ``target_hz``), returning a
    :class:`sysid_core.plugin.interfaces.TuningCriterion`.
    """


@hookspec
def sysid_response_formats() -> Mapping[str, Callable[[], Any]]:  # type: ignore[empty-body]
    """Return the response-file formats this plugin provides.

    Returns a mapping from format names (a manifest's ``format = ...``, ``sysid export
    --format``) to factories called without arguments, each returning an engine: a subclass of
    :class:`sysid_core.formats.engine.ResponseFormat` (its ``extensions``,
    ``guess_can_open(path)``, ``open_sweep(path, **options)`` and, if it ``writes``,
    ``write_sweep``). The built-in CSV, Touchstone, MATLAB, netCDF and column-mapped engines
    come from the ``sysid_formats`` plugin this way.
    """


@hookspec
def sysid_cli_commands() -> Mapping[str, Callable[..., None]]:  # type: ignore[empty-body]
    """Return the ``sysid`` commands this plugin adds.

    Returns a mapping from command names (``sysid NAME``) to functions. Each function is
    registered with typer as it is (its parameters, annotated with ``typer.Option`` or
    ``typer.Argument``, are the command's options; its docstring is its help), and its failures
    are handled like a built-in command's: a :class:`~sysid_core.errors.SysidError` becomes one
    line ``sysid: error: ...`` and exit status 1. A name that a built-in command has is refused
    with a warning. The ``visa`` device package adds ``sysid instrument-sim`` this way.
    """


#: Hook name of each component kind, in the order ``sysid plugins`` lists them.
KIND_HOOKS: dict[str, str] = {
    "device": "sysid_devices",
    "model structure": "sysid_model_structures",
    "objective": "sysid_objectives",
    "solver": "sysid_solvers",
    "tuning criterion": "sysid_tuning_criteria",
    "response format": "sysid_response_formats",
    "command": "sysid_cli_commands",
}
