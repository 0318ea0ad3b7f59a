"""``sysid tune``: the tuning pipeline from a configuration file."""

from __future__ import annotations

import json
import shlex
import time
from pathlib import Path
from typing import Annotated

import typer

from sysid_core.cli.app import Interrupted, JsonOption, OutDirOption, command, err, out


@command("tune")
def tune_cmd(
    config: Annotated[Path, typer.Argument(help="Configuration file (TOML).")],
    out_dir: OutDirOption = None,
    as_json: JsonOption = False,
    resume: Annotated[
        bool, typer.Option("--resume", help="Continue the run in --out without re-measuring.")
    ] = False,
    no_plots: Annotated[bool, typer.Option("--no-plots", help="Skip the plots.")] = False,
    plot_format: Annotated[
        str, typer.Option("--plot-format", help="Plots as png (default), pdf or svg.")
    ] = "png",
    from_model: Annotated[
        Path | None,
        typer.Option(
            "--from-model",
            help="A previous model of this gyro (model.nc): skip the locating sweep and design.",
        ),
    ] = None,
) -> None:
    """Tune a gyro: identify, compute the biases, verify, iterate (paper Sec. II-D).

    Exits 0 only when the run converged (a verified split under the acceptance and every goal
    of the criterion met); 1 when it did not, with every result saved in --out.
    """
    from rich.markup import escape

    from sysid_core.api import load_model
    from sysid_core.errors import NotConvergedError
    from sysid_core.run.config import load_config
    from sysid_core.run.pipeline import TuningRun

    cfg = load_config(config)
    prior = None if from_model is None else load_model(from_model)
    target = out_dir or Path("runs") / config.stem
    resume_cmd = f"sysid tune {shlex.quote(str(config))} --out {shlex.quote(str(target))} --resume"
    with err.status("starting ...") as status:

        def progress(message: str) -> None:
            # a message is text, not markup: "[tuning] max_bench_minutes" must print as such
            status.update(escape(message))
            if not as_json:
                stamp = time.strftime("%H:%M:%S")
                err.print(f"[dim]{stamp}[/dim] {escape(message)}", highlight=False)

        run = TuningRun(
            cfg,
            target,
            resume=resume,
            progress=progress,
            plots=not no_plots,
            plot_format=plot_format,
            from_model=prior,
        )
        try:
            summary = run.run()
        except KeyboardInterrupt:
            raise Interrupted(
                f"interrupted; every measurement so far is saved in {target}/. "
                f"Continue with: {resume_cmd}"
            ) from None
    if as_json:
        print(json.dumps({k: v for k, v in summary.as_dict().items() if k != "history"}))
    else:
        out.print(f"{escape(summary.device)}: {escape(summary.status)}", highlight=False)
        out.print(
            "final bias: "
            + ", ".join(
                f"{e} = {b:.4f} V" for e, b in zip(summary.electrodes, summary.bias, strict=True)
            )
        )
        region = summary.confidence
        if region is not None:
            tuned = [summary.electrodes.index(e) for e in summary.tuned]
            out.print(
                f"{region['confidence_level']:.0%} region of the last answer: "
                + ", ".join(
                    f"{summary.electrodes[p]} {region['bias_ci'][p][0]:.4f}.."
                    f"{region['bias_ci'][p][1]:.4f} V"
                    for p in tuned
                )
                + f"; split {region['split_ci_hz'][0] * 1e3:.3g}-"
                f"{region['split_ci_hz'][1] * 1e3:.3g} mHz",
                highlight=False,
            )
        out.print(
            f"results and plots in {target}/ (summary.json, bias_path.{plot_format}, iterNN/)"
        )
    if not summary.converged:
        more = advice(summary.status, summary.stopped, summary.frequency_hz is not None)
        raise NotConvergedError(
            f"{summary.status}; results in {target}/ ({more}, or inspect {target}/summary.json)",
            summary,
        )


def advice(status: str, stopped: str | None, seen: bool) -> str:
    """What may help a run that did not converge, for its one error line.

    ``status``: the run's status line; ``stopped``: why the budget stopped it (None: it was
    not); ``seen``: whether its last verification showed both modes.
    """
    from sysid_core.run.summary import DAC_LIMITS

    if DAC_LIMITS in status:
        return "a finer DAC, another tuned electrode or a wider [tuning] acceptance_hz"
    if not seen:
        return (
            "the last sweeps did not show the modes: their plots (iterNN/verify*.png) show "
            "where they are; sharp modes need a finer [experiment] resolution_hz or more "
            "locate_points"
        )
    if stopped is not None:
        return "a larger [tuning] max_bench_minutes, in a new --out"
    return "run again with a larger [tuning] max_iterations in a new --out"
