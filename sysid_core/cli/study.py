"""``sysid study``: the paper's statistical study (Sec. III-B), in parallel."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Annotated

import typer

from sysid_core.cli.app import (
    JsonOption,
    OutDirOption,
    SchedulerOption,
    WorkersOption,
    batch_bar,
    command,
    out,
)


@command("study")
def study_cmd(
    config: Annotated[Path, typer.Argument(help="Study configuration (TOML with a study table).")],
    out_dir: OutDirOption = None,
    as_json: JsonOption = False,
    workers: WorkersOption = None,
    scheduler: SchedulerOption = None,
    executor: Annotated[
        str, typer.Option("--executor", help="dask (default) or local (in this process).")
    ] = "dask",
    no_plots: Annotated[bool, typer.Option("--no-plots", help="Skip the PNG figures.")] = False,
) -> None:
    """Tune from every start point of a grid, with each model; compare with the truth.

    Every run is checked before any starts. If some runs fail, the others' results and every
    output are still written, then the command fails (exit status 1) naming the first failed
    run; running the same command again retries only the failed runs.
    """
    import shlex
    import sys

    from rich.markup import escape

    from sysid_core.batch.study.runner import (
        failure_message,
        load_study_config,
        plan_study,
        run_study,
    )
    from sysid_core.errors import ConfigError, RunsFailedError

    if executor not in ("dask", "local"):
        raise ConfigError(f"--executor must be 'dask' or 'local', not {executor!r}")
    cfg = load_study_config(config)
    target = out_dir or Path("runs") / config.stem
    plan = plan_study(cfg, target)  # refuse a bad study before showing progress
    invocation = "sysid " + " ".join(shlex.quote(a) for a in sys.argv[1:])
    with batch_bar(
        "study", as_json, lambda m: f"[yellow]{escape(m)}[/]" if "failed" in m else None
    ) as progress:
        full = run_study(
            cfg,
            target,
            executor,
            workers,
            scheduler,
            progress,
            plots=not no_plots,
            command=invocation,
            plan=plan,
        )
    primary = full["summary"][full["primary_objective"]]
    if as_json:
        keys = ("runs", "mean_bias", "std_bias", "under_10mHz", "under_300mHz", "median_split_hz")
        compact = {
            model: {it: {k: v[k] for k in keys} for it, v in per_it.items()}
            for model, per_it in primary.items()
        }
        compact["by_objective"] = full["summary"]
        compact["elapsed_s"] = full["elapsed_s"]
        compact["failed"] = full["failed"]
        print(json.dumps(compact), flush=True)
    else:
        for obj, per_model in full["summary"].items():
            for model, per_it in per_model.items():
                for it, v in per_it.items():
                    bias = (
                        ""
                        if v["mean_bias"] is None
                        else f" mean bias {v['mean_bias']}, std {v['std_bias']},"
                    )
                    out.print(
                        f"{obj:>13} {model} iteration {it}: {v['runs']} runs,{bias} true split "
                        f"< 2 mHz: {v['under_2mHz']}, < 10 mHz: "
                        f"{v['under_10mHz']}, < 300 mHz: {v['under_300mHz']}, median "
                        f"{(v['median_split_hz'] or float('nan')) * 1e3:.2f} mHz"
                    )
        out.print(f"{full['runs']} runs in {full['elapsed_s']:.0f} s; results in {target}/")
    if full["failed"]:
        raise RunsFailedError(failure_message(full))
