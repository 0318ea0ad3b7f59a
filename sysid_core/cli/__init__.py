"""The ``sysid`` command-line program: :func:`main`.

The commands register themselves on the app of :mod:`sysid_core.cli.app` when their modules are
imported here; plugins add theirs through the ``sysid_cli_commands`` hook
(:func:`~sysid_core.cli.app.add_plugin_commands`, e.g. ``sysid instrument-sim`` from the
``visa`` device package). Exit statuses and messages are described in :mod:`.app`.
"""

from __future__ import annotations

import os
import sys
import warnings
from pathlib import Path
from typing import Any

from sysid_core.cli import data, fit, fleet, study, tune  # noqa: F401 - register commands
from sysid_core.cli.app import add_plugin_commands, app, failure
from sysid_core.errors import SysidWarning

#: The order of ``sysid --help``: the main job first.
COMMAND_ORDER = (
    "tune",
    "tune-fleet",
    "fit",
    "import",
    "export",
    "study",
    "instrument-sim",
    "plugins",
)
add_plugin_commands()
app.registered_commands.sort(
    key=lambda c: COMMAND_ORDER.index(c.name) if c.name in COMMAND_ORDER else len(COMMAND_ORDER)
)

__all__ = ["app", "main"]


def _format_warning(
    message: Any, category: Any, filename: str, lineno: int, line: Any = None
) -> str:
    """A warning as one line.

    One that is not the toolkit's own (numpy's ``invalid value encountered in sqrt``) also
    says its class and where it arose, so that it can be reported.
    """
    if isinstance(category, type) and issubclass(category, SysidWarning):
        return f"sysid: warning: {message}\n"
    where = Path(filename)
    parts = where.parts
    short = "/".join(parts[parts.index("sysid_core") :]) if "sysid_core" in parts else where.name
    kind = getattr(category, "__name__", str(category))
    return f"sysid: warning: {message} ({kind} at {short}:{lineno})\n"


def main(argv: list[str] | None = None) -> int:
    """Entry point of the ``sysid`` program; returns the exit status (see the module)."""
    warnings.formatwarning = _format_warning
    try:
        app(args=argv, prog_name="sysid", standalone_mode=True)
    except SystemExit as exc:
        code = exc.code
        return code if isinstance(code, int) else (0 if code is None else 1)
    except BaseException as exc:  # outside a command (e.g. Ctrl-C while starting up)
        if os.environ.get("SYSID_DEBUG") and not isinstance(exc, KeyboardInterrupt):
            raise
        line, code = failure(exc)
        print(line, file=sys.stderr)
        return code
    return 0
