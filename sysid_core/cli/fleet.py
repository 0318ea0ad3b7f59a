"""``sysid tune-fleet``: tune many gyros concurrently (:mod:`sysid_core.batch.fleet`)."""

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


@command("tune-fleet")
def tune_fleet_cmd(
    fleet: Annotated[Path, typer.Argument(help="Fleet file (TOML): a config and the gyros.")],
    out_dir: OutDirOption = None,
    as_json: JsonOption = False,
    resume: Annotated[
        bool,
        typer.Option("--resume", help="Keep converged gyros; continue the others from disk."),
    ] = False,
    workers: WorkersOption = None,
    scheduler: SchedulerOption = None,
    no_plots: Annotated[bool, typer.Option("--no-plots", help="Skip each gyro's plots.")] = False,
) -> None:
    """Tune every gyro of a fleet file, each in its own run folder, on dask.

    A gyro that fails (bad configuration, device error, dead worker) never stops the others.
    Writes OUT/fleet.json and OUT/fleet.md (the table of all). Exits 0 only when every gyro
    converged; otherwise 1, naming the gyros that did not (run again with --resume).
    """
    from rich.markup import escape

    from sysid_core.batch.fleet import check_fleet, run_fleet
    from sysid_core.errors import RunsFailedError

    target = out_dir or Path("runs") / fleet.stem
    check_fleet(fleet, target, resume)  # refuse a bad fleet file before showing progress
    with batch_bar("fleet", as_json, escape) as progress:
        results = run_fleet(fleet, target, resume, workers, scheduler, progress, plots=not no_plots)
    bad = [r for r in results if r.get("error") or not r.get("converged")]
    if as_json:
        compact = [{k: v for k, v in r.items() if k != "traceback"} for r in results]
        print(
            json.dumps(
                {
                    "gyros": compact,
                    "converged": len(results) - len(bad),
                    "failed": len([r for r in results if r.get("error")]),
                    "out": str(target),
                }
            ),
            flush=True,
        )
    else:
        out.print((target / "fleet.md").read_text(), highlight=False, markup=False)
        out.print(f"{len(results) - len(bad)} of {len(results)} gyros converged; see {target}/")
    if bad:
        names = ", ".join(r["name"] for r in bad)
        raise RunsFailedError(
            f"{len(bad)} of {len(results)} gyro(s) did not converge or failed ({names}); see "
            f"{target}/fleet.md, continue with --resume"
        )
