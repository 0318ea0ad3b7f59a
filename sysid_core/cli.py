"""The ``sysid`` command-line program.

Exit status: 0 on success; 2 for a usage error (with the usual usage message); 130 when
interrupted (Ctrl-C), with one line saying how to resume; 1 for every other failure, with one
line ``sysid: error: ...`` on stderr and no traceback (set ``SYSID_DEBUG=1`` to see one). A
failure that is a bug in the toolkit says so (``sysid: internal error: ...``), also with 1.

Each command handles its own failures (:func:`command`), so the exit status does not depend on
how the installed typer/click versions treat exceptions; usage errors are left to typer.
"""

from __future__ import annotations

import functools
import json
import os
import sys
import warnings
from collections.abc import Callable
from pathlib import Path
from typing import Annotated, Any, TypeVar

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")  # small dense algebra: one thread is faster

import typer
from rich.console import Console, ConsoleDimensions
from rich.table import Table

from sysid_core import __version__
from sysid_core.errors import SysidError

__all__ = ["Interrupted", "app", "command", "main"]

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
        print(f"sysid {__version__}")
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


class Interrupted(KeyboardInterrupt):
    """Ctrl-C, with a message saying how to continue (exit status 130)."""


def _failure(exc: BaseException) -> tuple[str, int]:
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
            except (SystemExit, typer.Exit, typer.Abort):
                raise
            except BaseException as exc:
                if os.environ.get("SYSID_DEBUG") and not isinstance(exc, KeyboardInterrupt):
                    raise
                line, code = _failure(exc)
                print(line, file=sys.stderr)
                raise SystemExit(code) from None

        app.command(name)(guarded)
        return func

    return decorate


def _registry():
    from sysid_core.registry import get_registry

    return get_registry()


@command("plugins")
def plugins_cmd(
    as_json: Annotated[bool, typer.Option("--json", help="Print JSON instead of a table.")] = False,
) -> None:
    """List every installed component by kind, with the distribution it came from."""
    from sysid_core.registry import KINDS

    reg = _registry()
    rows = [
        {
            "kind": kind,
            "name": c.name,
            "plugin": c.plugin,
            "distribution": c.distribution,
            "description": c.description,
        }
        for kind in KINDS
        for c in reg.components(kind)
    ]
    if as_json:
        print(json.dumps({"components": rows, "failures": [m for _, m in reg.failures]}))
        return
    table = Table(title="sysid components")
    for col in ("kind", "name", "distribution", "plugin", "description"):
        table.add_column(col)
    for r in rows:
        table.add_row(r["kind"], r["name"], r["distribution"], r["plugin"], r["description"])
    out.print(table)
    for _, message in reg.failures:
        err.print(f"[yellow]warning:[/] {message}")


@command("fit")
def fit_cmd(
    data: Annotated[Path, typer.Argument(help="Data set (netCDF, see sysid_core.data).")],
    model: Annotated[str, typer.Option("--model", help="Model structure: act or sen.")] = "act",
    order: Annotated[int, typer.Option("--order", help="Polynomial order n_R / n_B.")] = 1,
    solver: Annotated[str, typer.Option("--solver", help="Solver backend.")] = "clarabel",
    objective: Annotated[
        str, typer.Option("--objective", help="Fit objective: minimax or least-squares.")
    ] = "minimax",
    out_path: Annotated[
        Path | None,
        typer.Option("--out", help="Write the model here (netCDF; default DATA.model.nc)."),
    ] = None,
    force: Annotated[
        bool, typer.Option("--force", help="Replace an existing model file.")
    ] = False,
    as_json: Annotated[
        bool, typer.Option("--json", help="Last stdout line: one JSON object.")
    ] = False,
) -> None:
    """Fit one bias-dependent model to every experiment of DATA and report it."""
    from sysid_core.data import load_dataset
    from sysid_core.fit import fit
    from sysid_core.io import check_output_file

    target = out_path or data.with_name(f"{data.stem}.model.nc")
    check_output_file(target, inputs=[data], force=force)
    ds = load_dataset(data)
    with err.status("fitting ...") as status:
        fitted = fit(
            ds, model, order, objective, solver, progress=lambda m: status.update(f"fitting: {m}")
        )
    check_output_file(target, inputs=[data], force=force)  # nothing appeared meanwhile
    fitted.save(target)
    bias = ds["bias"].values
    reports = [fitted.modal(b) for b in bias]
    meta = fitted.meta
    if as_json:
        print(
            json.dumps(
                {
                    "model": str(target),
                    "structure": fitted.structure.name,
                    "order": fitted.structure.order,
                    "objective": meta["objective"],
                    "solver": meta["solver"],
                    "gamma": fitted.gamma,
                    "max_residual": fitted.max_residual,
                    "fit_time_s": meta["fit_time_s"],
                    "n_parameters": meta["n_parameters"],
                    "experiments": [r.as_dict() for r in reports],
                }
            )
        )
        return
    out.print(
        f"model {fitted.structure.name} (order {fitted.structure.order}), objective "
        f"{meta['objective']}, solver {meta['solver']}: {meta['n_parameters']} parameters, "
        f"{meta['n_points']} points in {meta['n_experiments']} experiments"
    )
    out.print(
        f"gamma = {fitted.gamma:.6g} (largest residual {fitted.max_residual:.6g}), "
        f"fit time {meta['fit_time_s']:.3f} s, {meta['solves']} solve(s), "
        f"certified on all points: {meta['certified']}"
    )
    table = Table()
    for col in ("exp", "bias [V]", "f1 [Hz]", "f2 [Hz]", "split [Hz]", "Q1", "Q2", "SNR loss [dB]"):
        table.add_column(col, justify="right")
    for k, r in enumerate(reports):
        table.add_row(
            str(k),
            ", ".join(f"{b:.3f}" for b in r.bias),
            f"{r.frequencies_hz[0]:.4f}",
            f"{r.frequencies_hz[1]:.4f}",
            f"{r.split_hz:.4f}",
            f"{r.q[0]:.0f}",
            f"{r.q[1]:.0f}",
            f"{r.snr_loss_db:.1f}",
        )
    out.print(table)
    out.print(f"model written to {target}")


def _register_late_commands() -> None:
    """Commands defined in other modules (kept out of the import of this one)."""
    from sysid_core import (
        cli_study,  # noqa: F401
        cli_tune,  # noqa: F401
    )


def _format_warning(
    message: Any, category: Any, filename: str, lineno: int, line: Any = None
) -> str:
    return f"sysid: warning: {message}\n"


def main(argv: list[str] | None = None) -> int:
    """Entry point of the ``sysid`` program; returns the exit status (see the module)."""
    warnings.formatwarning = _format_warning
    _register_late_commands()
    try:
        app(args=argv, prog_name="sysid", standalone_mode=True)
    except SystemExit as exc:
        code = exc.code
        return code if isinstance(code, int) else (0 if code is None else 1)
    except BaseException as exc:  # outside a command (e.g. Ctrl-C while starting up)
        if os.environ.get("SYSID_DEBUG") and not isinstance(exc, KeyboardInterrupt):
            raise
        line, code = _failure(exc)
        print(line, file=sys.stderr)
        return code
    return 0


if __name__ == "__main__":  # pragma: no cover
    # Run as a module, this file is "__main__": use the commands registered on sysid_core.cli.
    from sysid_core.cli import main as _main

    sys.exit(_main())
