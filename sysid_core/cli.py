"""The ``sysid`` command-line program.

Errors of the toolkit are printed as one line on stderr with a non-zero exit status, never a
traceback (set ``SYSID_DEBUG=1`` to see one).
"""

from __future__ import annotations

import json
import os
import sys
import warnings
from pathlib import Path
from typing import Annotated, Any

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")  # small dense algebra: one thread is faster

import click
import typer
from rich.console import Console
from rich.table import Table

from sysid_core.errors import SysidError

__all__ = ["app", "main"]

app = typer.Typer(
    name="sysid",
    help="Identify and tune electrostatically tuned vibratory gyros (Kim & M'Closkey 2006).",
    no_args_is_help=True,
    add_completion=False,
    pretty_exceptions_enable=False,
)
err = Console(stderr=True)
out = Console()

#: Options shared by the commands that run a configuration file.
OutDirOption = Annotated[
    Path | None, typer.Option("--out", help="Output directory (default: runs/<config>).")
]
JsonOption = Annotated[bool, typer.Option("--json", help="Last stdout line: one JSON object.")]


def _registry():
    from sysid_core.registry import get_registry

    return get_registry()


@app.command("plugins")
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


@app.command("fit")
def fit_cmd(
    data: Annotated[Path, typer.Argument(help="Data set (netCDF, see sysid_core.data).")],
    model: Annotated[str, typer.Option("--model", help="Model structure: act or sen.")] = "act",
    order: Annotated[int, typer.Option("--order", help="Polynomial order n_R / n_B.")] = 1,
    solver: Annotated[str, typer.Option("--solver", help="Solver backend.")] = "clarabel",
    objective: Annotated[
        str, typer.Option("--objective", help="Fit objective: minimax or least-squares.")
    ] = "minimax",
    out_path: Annotated[
        Path | None, typer.Option("--out", help="Write the model here (netCDF).")
    ] = None,
    as_json: Annotated[
        bool, typer.Option("--json", help="Last stdout line: one JSON object.")
    ] = False,
) -> None:
    """Fit one bias-dependent model to every experiment of DATA and report it."""
    from sysid_core.data import load_dataset
    from sysid_core.fit import fit

    ds = load_dataset(data)
    with err.status("fitting ...") as status:
        fitted = fit(
            ds, model, order, objective, solver, progress=lambda m: status.update(f"fitting: {m}")
        )
    target = out_path or data.with_name(f"{data.stem}.model.nc")
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
    try:
        from sysid_core import (
            cli_study,  # noqa: F401
            cli_tune,  # noqa: F401
        )
    except ImportError:  # pragma: no cover - during partial installs
        pass


def _format_warning(
    message: Any, category: Any, filename: str, lineno: int, line: Any = None
) -> str:
    return f"sysid: warning: {message}\n"


def main(argv: list[str] | None = None) -> int:
    """Entry point of the ``sysid`` program; returns the exit status."""
    warnings.formatwarning = _format_warning
    _register_late_commands()
    debug = bool(os.environ.get("SYSID_DEBUG"))
    try:
        app(args=argv, prog_name="sysid", standalone_mode=False)
    except click.exceptions.Exit as exc:
        return int(exc.exit_code)
    except click.ClickException as exc:
        exc.show()
        return int(exc.exit_code)
    except click.exceptions.Abort:
        err.print("sysid: aborted")
        return 130
    except KeyboardInterrupt:
        print("sysid: interrupted", file=sys.stderr)
        return 130
    except SysidError as exc:
        if debug:
            raise
        print(f"sysid: error: {exc}", file=sys.stderr)
        return 1
    except (OSError, ValueError) as exc:
        if debug:
            raise
        print(f"sysid: error: {type(exc).__name__}: {exc}", file=sys.stderr)
        return 1
    except Exception as exc:  # a bug: still one line, with the way to get the traceback
        if debug:
            raise
        print(
            f"sysid: internal error: {type(exc).__name__}: {exc} "
            "(set SYSID_DEBUG=1 for a traceback)",
            file=sys.stderr,
        )
        return 2
    return 0


if __name__ == "__main__":  # pragma: no cover
    # Run as a module, this file is "__main__": use the commands registered on sysid_core.cli.
    from sysid_core.cli import main as _main

    sys.exit(_main())
