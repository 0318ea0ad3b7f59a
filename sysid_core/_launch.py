"""A Ctrl-C while the ``sysid`` program starts ends it quietly, with exit status 130.

The program's imports (numpy, xarray, the plugins) take a second or two, before any of its
own code can catch an interrupt; Python would print a ``KeyboardInterrupt`` traceback from
deep inside them. Imported first by ``sysid_core`` (stdlib only), :func:`install` replaces
``sys.excepthook`` for the ``sysid`` program alone (its script, or ``python -m
sysid_core.cli``): an interrupt that escapes prints one line, and the exit status stays the
interrupt's (130 from a shell). A library user's process is left as it is.
"""

from __future__ import annotations

import itertools
import os
import sys
from types import TracebackType

__all__ = ["install", "is_the_program"]


def is_the_program() -> bool:
    """Whether this process is the ``sysid`` program (its script or ``-m sysid_core.cli``)."""
    name = os.path.basename(sys.argv[0]) if sys.argv else ""
    orig = list(getattr(sys, "orig_argv", []))
    module = any(a == "-m" and b == "sysid_core.cli" for a, b in itertools.pairwise(orig))
    return name in ("sysid", "sysid.exe", "sysid-script.py") or module


def _interrupted(value: BaseException | None) -> bool:
    """Whether ``value`` or an exception it was raised from or during is an interrupt."""
    seen = 0
    while value is not None and seen < 50:
        if isinstance(value, KeyboardInterrupt):
            return True
        value, seen = value.__cause__ or value.__context__, seen + 1
    return False


def install() -> None:
    """Make an interrupt that escapes the ``sysid`` program print one line (see the module)."""
    if not is_the_program() or getattr(sys.excepthook, "_sysid_quiet", False):
        return
    previous = sys.excepthook

    def quiet(kind: type[BaseException], value: BaseException, tb: TracebackType | None) -> None:
        if issubclass(kind, KeyboardInterrupt):
            print("sysid: interrupted while starting; nothing was done", file=sys.stderr)
            return  # Python then ends the process by the interrupt: status 130
        if _interrupted(value):  # a C extension's init turns the interrupt into ImportError
            print("sysid: interrupted while starting; nothing was done", file=sys.stderr)
            sys.stderr.flush()
            os._exit(130)
        previous(kind, value, tb)

    quiet._sysid_quiet = True  # type: ignore[attr-defined]
    sys.excepthook = quiet


install()
