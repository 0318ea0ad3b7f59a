"""``sysid tune``: the tuning pipeline from a configuration file."""

from __future__ import annotations

import json
import time
from pathlib import Path
from typing import Annotated

import typer

from sysid_core.cli import JsonOption, OutDirOption, app, err, out


@app.command("tune")
def tune_cmd(
    config: Annotated[Path, typer.Argument(help="Configuration file (TOML).")],
    out_dir: OutDirOption = None,
    as_json: JsonOption = False,
    resume: Annotated[
        bool, typer.Option("--resume", help="Continue the run in --out without re-measuring.")
    ] = False,
    no_plots: Annotated[bool, typer.Option("--no-plots", help="Skip the PNG report.")] = False,
) -> None:
    """Tune a gyro: identify, compute the biases, verify, iterate (paper Sec. II-D)."""
    from sysid_core.config import load_config
    from sysid_core.pipeline import TuningRun

    cfg = load_config(config)
    target = out_dir or Path("runs") / config.stem
    with err.status("starting ...") as status:

        def progress(message: str) -> None:
            status.update(message)
            if not as_json:
                err.print(f"[dim]{time.strftime('%H:%M:%S')}[/dim] {message}", highlight=False)

        run = TuningRun(cfg, target, resume=resume, progress=progress, plots=not no_plots)
        summary = run.run()
    if as_json:
        print(json.dumps({k: v for k, v in summary.as_dict().items() if k != "history"}))
        return
    state = "converged" if summary.converged else "NOT converged"
    out.print(
        f"{summary.device}: {state} after {summary.iterations} iteration(s), "
        f"{summary.experiments} measurements"
    )
    out.print(
        "final bias: "
        + ", ".join(
            f"{e} = {b:.4f} V" for e, b in zip(summary.electrodes, summary.bias, strict=True)
        )
    )
    out.print(
        f"measured split {summary.split_hz * 1e3:.2f} mHz at {summary.frequency_hz:.3f} Hz "
        f"(acceptance {cfg.tuning.acceptance_hz * 1e3:.1f} mHz)"
    )
    out.print(f"results and plots in {target}/ (summary.json, bias_path.png, iterNN/)")
