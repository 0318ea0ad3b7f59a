"""Tuning from Python (notebooks, scripts): :func:`tune`.

The same run as ``sysid tune``, with the configuration given as a file, a mapping (the TOML
tables as dicts) or a :class:`~sysid_core.config.PipelineConfig`; the answer is the run's
:class:`~sysid_core.run_summary.RunSummary` (final bias, verified split, goals, history, and the
paths of every file written). A run that does not converge is returned, not raised: look at
``result.converged`` and ``result.status``.

Example
-------
>>> from sysid_core import tune
>>> result = tune("examples/cloverleaf-2electrode.toml", out="runs/nb")  # doctest: +SKIP
>>> result.converged, result.bias, result.split_hz  # doctest: +SKIP
>>> result.paths["bias_path"]  # doctest: +SKIP
"""

from __future__ import annotations

import os
from collections.abc import Mapping
from pathlib import Path
from typing import Any

from sysid_core.config import PipelineConfig, load_config, parse_config
from sysid_core.device import Device
from sysid_core.objective import Progress
from sysid_core.pipeline import TuningRun
from sysid_core.registry import Registry
from sysid_core.run_summary import RunSummary

__all__ = ["tune"]


def tune(
    config: str | os.PathLike[str] | Mapping[str, Any] | PipelineConfig,
    out: str | os.PathLike[str],
    *,
    resume: bool = False,
    progress: Progress | None = None,
    plots: bool = True,
    plot_format: str = "png",
    device: Device | None = None,
    registry: Registry | None = None,
) -> RunSummary:
    """Run the tuning loop of ``config`` into the folder ``out``; return its summary.

    Parameters
    ----------
    config : path, mapping or PipelineConfig
        A TOML file, the same tables as a dict (``{"device": {"name": "cloverleaf"}, ...}``), or
        a validated configuration.
    out : path
        The run's folder: absent or empty for a new run, the run's own folder with ``resume``.
    resume : bool
        Continue the run in ``out`` (measurements on disk are read, not measured again).
    progress : callable, optional
        Receives one line per step (e.g. ``print``).
    plots : bool
        Write the plots (default true).
    plot_format : str
        ``png`` (default), ``pdf`` or ``svg``.
    device : Device, optional
        Use this device object instead of the configuration's ``[device]``.
    registry : Registry, optional
        Where plugins are looked up (default: the installed ones).

    Returns
    -------
    RunSummary
        ``bias``, ``split_hz`` (verified, or None), ``converged``, ``status``, ``goals``,
        ``history`` (one record per iteration) and ``paths``.

    Raises
    ------
    ConfigError, DeviceError, SysidError
        As ``sysid tune`` (see ``docs/errors.md``); ``TypeError`` for a ``config`` of another
        type.
    """
    if isinstance(config, PipelineConfig):
        cfg = config
    elif isinstance(config, Mapping):
        cfg = parse_config(dict(config), "tune(config)")
    elif isinstance(config, (str, os.PathLike)):
        cfg = load_config(config)
    else:
        raise TypeError(
            f"config must be a TOML file path, a dict of tables or a PipelineConfig, not "
            f"{type(config).__name__}"
        )
    run = TuningRun(
        cfg,
        Path(out),
        resume=resume,
        progress=progress,
        device=device,
        registry=registry,
        plots=plots,
        plot_format=plot_format,
    )
    return run.run()
