"""``sysid fit`` and ``sysid plugins``."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Annotated

import typer
from rich.markup import escape
from rich.table import Table

from sysid_core.cli.app import command, err, out
from sysid_core.errors import ConfigError
from sysid_core.identification.objective import DEFAULT_OBJECTIVE, DEFAULT_SOLVER
from sysid_core.model.structures import (
    DEFAULT_BIAS_TERMS,
    DEFAULT_ORDER,
    DEFAULT_STIFFNESS,
    ModelStructure,
)


@command("plugins")
def plugins_cmd(
    as_json: Annotated[bool, typer.Option("--json", help="Print JSON instead of a table.")] = False,
) -> None:
    """List every installed component by kind, with the distribution it came from."""
    from sysid_core.plugin.registry import KINDS, get_registry

    reg = get_registry()
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
    for r in rows:  # a plugin's text is shown as written, never read as rich markup
        table.add_row(
            *(escape(r[key]) for key in ("kind", "name", "distribution", "plugin")),
            escape(r["description"]),
        )
    out.print(table)
    for _, message in reg.failures:
        err.print(f"[yellow]warning:[/] {escape(message)}")


@command("fit")
def fit_cmd(
    data: Annotated[
        Path,
        typer.Argument(help="Data set (netCDF, see sysid_core.data.schema) or manifest (.toml)."),
    ],
    model: Annotated[str, typer.Option("--model", help="Model structure: act or sen.")] = "act",
    order: Annotated[
        int, typer.Option("--order", help="Polynomial order n_R / n_B.")
    ] = DEFAULT_ORDER,
    bias_terms: Annotated[
        int,
        typer.Option("--bias-terms", help="Lowest polynomial degrees that depend on the bias."),
    ] = DEFAULT_BIAS_TERMS,
    stiffness: Annotated[
        str,
        typer.Option(
            "--stiffness",
            help="Stiffness law in v²: linear, quadratic or auto (the data decide).",
        ),
    ] = DEFAULT_STIFFNESS,
    solver: Annotated[str, typer.Option("--solver", help="Solver backend.")] = DEFAULT_SOLVER,
    objective: Annotated[
        str, typer.Option("--objective", help="Fit objective: least-squares or minimax.")
    ] = DEFAULT_OBJECTIVE,
    out_path: Annotated[
        Path | None,
        typer.Option("--out", help="Write the model here (netCDF; default DATA.model.nc)."),
    ] = None,
    force: Annotated[bool, typer.Option("--force", help="Replace an existing model file.")] = False,
    as_json: Annotated[
        bool, typer.Option("--json", help="Last stdout line: one JSON object.")
    ] = False,
) -> None:
    """Fit one bias-dependent model to every experiment of DATA and report it.

    DATA is a netCDF data set or a manifest of measured response files (docs/measured-data.md).
    """
    from sysid_core.api import fit
    from sysid_core.data.io import check_output_file
    from sysid_core.formats.manifest import data_files, load_data

    if stiffness not in ModelStructure.STIFFNESS_LAWS:
        raise ConfigError(
            f"--stiffness {stiffness}: use one of {', '.join(ModelStructure.STIFFNESS_LAWS)}"
        )
    target = out_path or data.with_name(f"{data.stem}.model.nc")
    inputs = data_files(data)
    check_output_file(target, inputs=inputs, force=force)
    ds = load_data(data)
    with err.status("fitting ...") as status:
        fitted = fit(
            ds,
            model,
            order,
            objective,
            solver,
            progress=lambda m: status.update(f"fitting: {m}"),
            bias_terms=bias_terms,
            stiffness=stiffness,
        )
    check_output_file(target, inputs=inputs, force=force)  # nothing appeared meanwhile
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
                    "stiffness_law": meta.get("stiffness_law", fitted.structure.stiffness),
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
        f"model {fitted.structure.name} (order {fitted.structure.order}, "
        f"{meta.get('stiffness_law', fitted.structure.stiffness)} stiffness law), objective "
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
