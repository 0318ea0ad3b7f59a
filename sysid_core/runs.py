"""Tuning from Python (notebooks, scripts): :func:`tune` and :func:`predict_bias`.

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
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

import numpy as np

from sysid_core.confidence import confidence_region
from sysid_core.config import PipelineConfig, load_config, parse_config
from sysid_core.device import Device
from sysid_core.model import FittedModel
from sysid_core.objective import Progress
from sysid_core.pipeline import TuningRun
from sysid_core.registry import Registry, get_registry
from sysid_core.run_summary import RunSummary
from sysid_core.tuning import BiasSpace, TuningResult, solve_criterion

__all__ = ["predict_bias", "tune"]


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


def predict_bias(
    model: FittedModel,
    criterion: str = "degenerate",
    *,
    bias_limits: tuple[float, float],
    start_bias: Sequence[float] | None = None,
    solver: str = "clarabel",
    registry: Registry | None = None,
    **options: Any,
) -> TuningResult:
    """The biases that tune a fitted model (step 3 alone, no measurement).

    Parameters
    ----------
    model : FittedModel
        E.g. ``fit(load_data("manifest.toml"), "act")``.
    criterion : str
        ``"degenerate"``, ``"target"`` (give ``target_hz=``), ``"min-max-bias"`` or a plugin's.
    bias_limits : (low, high)
        Allowed bias of every electrode (volts): the answer is always inside.
    start_bias : sequence of float, optional
        Where the electrodes are now (default 0 V); used to pick among equally good answers.
    solver : str
        Conic solver backend for the criterion's program.
    registry : Registry, optional
        Where plugins are looked up (default: the installed ones).
    **options
        The criterion's options (``target_hz``, ``tolerance_hz``, ...).

    Returns
    -------
    TuningResult
        ``bias`` (volts, one per model electrode), the predicted modal ``frequencies_hz`` and
        ``split_hz`` there, and ``confidence``: the 95 % region of the answer
        (:class:`~sysid_core.tuning.ConfidenceRegion`; ``None`` for a ``minimax`` fit).

    Raises
    ------
    UnreachableTuningError
        If the goal is out of reach inside ``bias_limits`` (with the best reachable bias).
    """
    reg = registry or get_registry()
    chosen = reg.criterion(criterion, solver=reg.solver(solver), **options)
    start = np.zeros(model.n_electrodes) if start_bias is None else np.asarray(start_bias)
    space = BiasSpace(
        electrodes=list(model.electrodes),
        tuned=list(model.electrodes),
        start_bias=np.asarray(start, dtype=float),
        limits=(float(bias_limits[0]), float(bias_limits[1])),
        structure_potential=model.structure_potential,
    )
    result, local = solve_criterion(chosen, model, space)
    result.confidence = confidence_region(local, result, space)
    return result
