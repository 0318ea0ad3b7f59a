"""The ``sysid`` program's common parts: the typer app, the consoles, the failure mapping.

Exit status: 0 on success; 2 for a usage error (with the usual usage message); 130 when
interrupted (Ctrl-C), with one line saying how to resume; 1 for every other failure, with one
line ``sysid: error: ...`` on stderr and no traceback (set ``SYSID_DEBUG=1`` to see one). A
failure that is a bug in the toolkit says so (``sysid: internal error: ...``), also with 1.

Each command handles its own failures (:func:`command`), so the exit status does not depend on
how the installed typer/click versions treat exceptions; usage errors are left to typer. The
commands live in ``cli_fit``, ``cli_tune`` and ``cli_study``; ``cli`` runs the program.
"""

from __future__ import annotations

import contextlib
import functools
import os
import sys
from collections.abc import Callable, Iterator
from pathlib import Path
from typing import Annotated, Any, TypeVar

import typer
from rich.console import Console, ConsoleDimensions

from sysid_core.errors import SysidError

__all__ = [
    "Interrupted",
    "JsonOption",
    "OutDirOption",
    "add_plugin_commands",
    "app",
    "command",
    "err",
    "failure",
    "out",
]

F = TypeVar("F", bound=Callable[..., Any])


class _Console(Console):
    """A rich console that never cuts lines when its stream is not a terminal (pipes, logs)."""

    @property
    def size(self) -> ConsoleDimensions:
        if not self.is_terminal:
            return ConsoleDimensions(100_000, 25)
        return Console.size.fget(self)  # type: ignore[attr-defined]

    @size.setter
    def size(self, new_size: tuple[int, int]) -> None:
        Console.size.fset(self, new_size)  # type: ignore[attr-defined]


err = _Console(stderr=True, soft_wrap=True)
out = _Console(soft_wrap=True)


def _version(value: bool) -> None:
    if value:
        from importlib.metadata import version

        print(f"sysid {version('sysid-toolkit')}")
        raise typer.Exit()


app = typer.Typer(
    name="sysid",
    help="Identify and tune electrostatically tuned vibratory gyros (Kim & M'Closkey 2006).",
    no_args_is_help=True,
    add_completion=False,
    pretty_exceptions_enable=False,
)


@app.callback()
def _root(
    version: Annotated[
        bool,
        typer.Option(
            "--version", callback=_version, is_eager=True, help="Print the version and exit."
        ),
    ] = False,
) -> None:
    """Identify and tune electrostatically tuned vibratory gyros (Kim & M'Closkey 2006)."""


#: Options shared by the commands that run a configuration file.
OutDirOption = Annotated[
    Path | None, typer.Option("--out", help="Output directory (default: runs/<config>).")
]
JsonOption = Annotated[bool, typer.Option("--json", help="Last stdout line: one JSON object.")]
#: Options of the commands that run many jobs on dask (study, tune-fleet).
WorkersOption = Annotated[
    int | None, typer.Option("--workers", help="Local worker processes (default: cores).")
]
SchedulerOption = Annotated[
    str | None, typer.Option("--scheduler", help="Address of a running dask scheduler.")
]


@contextlib.contextmanager
def batch_bar(
    name: str, as_json: bool, line: Callable[[str], str | None]
) -> Iterator[Callable[[int, int, str], None]]:
    """A progress bar on stderr for a batch of jobs; yields its ``(done, total, message)`` callback.

    ``line(message)`` gives the (rich markup) line to print for a message, or None;
    nothing is printed with ``--json``, and into a file or pipe the bar is off too.
    """
    from rich.progress import BarColumn, MofNCompleteColumn, Progress, TextColumn, TimeElapsedColumn

    with Progress(
        TextColumn("{task.description}"),
        BarColumn(),
        MofNCompleteColumn(),
        TimeElapsedColumn(),
        console=err,
        transient=as_json,
        disable=as_json and not err.is_terminal,  # --json into a file or pipe: errors only
    ) as bar:
        task = bar.add_task(name, total=None)

        def progress(done: int, total: int, message: str) -> None:
            bar.update(task, completed=done, total=total, description=message[:60])
            shown = line(message)
            if shown is not None and not as_json:
                err.print(shown, highlight=False)

        yield progress


class Interrupted(KeyboardInterrupt):
    """Ctrl-C, with a message saying how to continue (exit status 130)."""


def failure(exc: BaseException) -> tuple[str, int]:
    """The one line and the exit status for an exception that ends a command."""
    if isinstance(exc, KeyboardInterrupt):
        return f"sysid: {exc or 'interrupted'}", 130
    if isinstance(exc, SysidError):
        return f"sysid: error: {exc}", 1
    if isinstance(exc, OSError):
        where = f"{exc.filename}: " if exc.filename else ""
        return f"sysid: error: {where}{exc.strerror or exc}", 1
    if isinstance(exc, MemoryError):
        return "sysid: error: out of memory (reduce the sweep sizes or the data)", 1
    return (
        f"sysid: internal error: {type(exc).__name__}: {exc} (this is a bug in sysid-toolkit; "
        "please report it with the output of SYSID_DEBUG=1)",
        1,
    )


def command(name: str) -> Callable[[F], F]:
    """Register a command whose failures become one line and an exit status (see module)."""

    def decorate(func: F) -> F:
        @functools.wraps(func)
        def guarded(*args: Any, **kwargs: Any) -> Any:
            try:
                return func(*args, **kwargs)
            except (SystemExit, typer.Exit, typer.Abort, typer.BadParameter):
                raise  # (a usage error: typer prints the usage, exit status 2)
            except BaseException as exc:
                if os.environ.get("SYSID_DEBUG") and not isinstance(exc, KeyboardInterrupt):
                    raise
                line, code = failure(exc)
                print(line, file=sys.stderr)
                raise SystemExit(code) from None

        app.command(name)(guarded)
        return func

    return decorate


def add_plugin_commands() -> None:
    """Register the commands that plugins add (hook ``sysid_cli_commands``) on :data:`app`.

    A plugin command whose name a registered command already has is skipped with a
    :class:`~sysid_core.plugin.registry.PluginLoadWarning`.
    """
    import warnings

    from sysid_core.plugin.registry import PluginLoadWarning, get_registry

    taken = {c.name for c in app.registered_commands}
    for component in get_registry().components("command"):
        if component.name in taken:
            warnings.warn(
                f'sysid plugin "{component.plugin}" adds a command {component.name!r} that '
                "sysid already has; it is not added",
                PluginLoadWarning,
                stacklevel=2,
            )
            continue
        command(component.name)(component.factory)
        taken.add(component.name)
