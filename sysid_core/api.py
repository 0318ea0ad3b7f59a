"""The toolkit from Python (notebooks, scripts): fit, load a model, tune, predict the bias.

The functions are :func:`fit`, :func:`load_model`, :func:`tune` and :func:`predict_bias`.
Components are named (``"act"``, ``"minimax"``) and looked up in the plugin registry passed in,
or the process-wide one; component objects passed in are used as they are.

``tune`` is the same run as ``sysid tune``, with the configuration given as a file, a mapping
(the TOML tables as dicts) or a :class:`~sysid_core.run.config.PipelineConfig`; the answer is
the run's :class:`~sysid_core.run.summary.RunSummary` (final bias, verified split, goals,
history, and the paths of every file written). A run that does not converge is returned, not
raised: look at ``result.converged`` and ``result.status``.

Examples
--------
>>> from sysid_core import tune
>>> result = tune("examples/cloverleaf-2electrode.toml", out="runs/nb")  # doctest: +SKIP
>>> result.converged, result.bias, result.split_hz  # doctest: +SKIP
>>> result.paths["bias_path"]  # doctest: +SKIP
"""

from __future__ import annotations

import os
import warnings
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any, TypeVar

import numpy as np
import xarray as xr

from sysid_core.conic.program import Solver
from sysid_core.data.schema import read_netcdf
from sysid_core.device.protocol import Device
from sysid_core.errors import ConfigError, DataError, FitWarning
from sysid_core.identification.fitting import fit_structure
from sysid_core.identification.objective import (
    DEFAULT_OBJECTIVE,
    DEFAULT_SOLVER,
    Objective,
    Progress,
)
from sysid_core.model.fitted import FittedModel, model_from_dataset
from sysid_core.model.structures import (
    DEFAULT_BIAS_TERMS,
    DEFAULT_ORDER,
    DEFAULT_STIFFNESS,
    ModelStructure,
)
from sysid_core.plugin.options import accepted_options
from sysid_core.plugin.registry import Registry, get_registry
from sysid_core.run.config import PipelineConfig, load_config, parse_config
from sysid_core.run.pipeline import TuningRun
from sysid_core.run.summary import RunSummary
from sysid_core.tuning.confidence import confidence_region
from sysid_core.tuning.criteria import BiasSpace, TuningResult, solve_criterion

__all__ = ["fit", "load_model", "predict_bias", "tune"]


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
    from_model: str | os.PathLike[str] | FittedModel | None = None,
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
    from_model : path or FittedModel, optional
        A previous model of the same gyro (a ``model.nc`` of an earlier run): the run skips
        the locating sweep and the design while that model's answers, anchored on the latest
        sweeps, bring the split down (``docs/bench-time.md``).

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
        from_model=(
            load_model(from_model, registry)
            if isinstance(from_model, (str, os.PathLike))
            else from_model
        ),
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
        (:class:`~sysid_core.tuning.criteria.ConfidenceRegion`; ``None`` for a ``minimax`` fit).

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


_T = TypeVar("_T")


def _component(
    registry: Registry | None, value: Any, cls: type[_T], what: str, kind: str, **options: Any
) -> _T:
    if isinstance(value, cls):
        return value
    if isinstance(value, str):
        return (registry or get_registry()).create(kind, value, **options)
    raise TypeError(
        f"{what} must be a name (str) or a {cls.__name__}, not {type(value).__name__} ({value!r})"
    )


def fit(
    dataset: xr.Dataset,
    structure: str | ModelStructure = "act",
    order: int = DEFAULT_ORDER,
    objective: str | Objective = DEFAULT_OBJECTIVE,
    solver: str | Solver = DEFAULT_SOLVER,
    progress: Progress | None = None,
    objective_options: dict[str, Any] | None = None,
    solver_options: dict[str, Any] | None = None,
    registry: Registry | None = None,
    bias_terms: int | None = None,
    stiffness: str | None = None,
    drift: bool | str = False,
) -> FittedModel:
    """Fit one bias-dependent model to every experiment of ``dataset`` at once.

    Parameters
    ----------
    dataset : xarray.Dataset
        Multi-experiment frequency-response data (validated here).
    structure : str or ModelStructure
        ``"act"`` (output dynamics, eq. 8) or ``"sen"`` (input dynamics, eq. 10), or an instance.
    order : int
        Polynomial order ``n_R`` / ``n_B`` when ``structure`` is a name (default
        :data:`~sysid_core.model.structures.DEFAULT_ORDER`, 2).
    objective : str or Objective
        ``"minimax"`` (the paper's criterion) or ``"least-squares"``, or an instance.
    solver : str or Solver
        ``"clarabel"`` or ``"scs"``, or an instance.
    progress : callable, optional
        Receives one-line progress messages.
    objective_options, solver_options : dict, optional
        Passed to the objective's / solver's factory when given by name.
    registry : Registry, optional
        Where names are looked up (default: the process-wide registry).
    bias_terms : int, optional
        When ``structure`` is a name: the polynomial's lowest degrees that depend on the bias
        (default 1 for structures that take it; 0 is the paper's model, see
        :class:`~sysid_core.model.structures.ModelStructure`).
    stiffness : str, optional
        When ``structure`` is a name: the stiffness law in ``w``, ``"linear"`` (the paper's),
        ``"quadratic"`` (adds ``L_p w_p²``; needs a two-sided design) or ``"auto"`` (the
        default: the quadratic law if a Wald test of its terms (on data with time stamps, of
        their part that splits the modes) rejects 0 at
        99 %, else the linear law on the same data, which a one-sided design always gets;
        ``model.meta["stiffness_law"]`` says which).
    drift : bool or str
        ``True`` or ``"common"``: estimate a common frequency drift from the time stamps
        (``time_s``) and fit the model of the gyro at the latest one
        (``model.meta["drift_rate_per_h"]``, relative per hour). ``"offsets"``: a common offset
        for every earlier epoch of the data's ``epoch`` coordinate (per experiment); ``"trend"``:
        a stiffness trend in time (``model.meta["drift_offsets"]``, ``["drift_trend"]``). See
        :mod:`sysid_core.identification.drift` and docs/drift.md.
        Default false.

    Returns
    -------
    FittedModel
        In physical units; ``model.meta`` holds the fit time, objective, solver and sizes.

    Raises
    ------
    TypeError
        For arguments of the wrong type.
    DataError
        For data that cannot be fitted (see :func:`sysid_core.data.validation.validate`).

    Warns
    -----
    FitWarning
        When the result is probably meaningless
        (:func:`~sysid_core.identification.fitting.check_fit`).

    Examples
    --------
    >>> model = fit(load_dataset("examples/cloverleaf-3exp.nc"), "act", order=1)  # doctest: +SKIP
    >>> model.modal([2.04, 4.39]).split_hz  # doctest: +SKIP
    """
    if not isinstance(dataset, xr.Dataset):
        raise TypeError(
            f"dataset must be an xarray.Dataset (see sysid_core.load_dataset), not "
            f"{type(dataset).__name__}"
        )
    extra: dict[str, Any] = {}
    if isinstance(structure, str):
        factory = (registry or get_registry()).get("model structure", structure).factory
        accepted, _ = accepted_options(factory)
        if bias_terms is not None or "bias_terms" in accepted:
            extra["bias_terms"] = DEFAULT_BIAS_TERMS if bias_terms is None else bias_terms
        if stiffness is not None or "stiffness" in accepted:
            extra["stiffness"] = DEFAULT_STIFFNESS if stiffness is None else stiffness
    structure = _component(
        registry,
        structure,
        ModelStructure,
        "structure",
        "model structure",
        order=order,
        **extra,
    )
    # The ignores: mypy rejects an abstract class (Objective, Solver) as type[T]
    # (python/mypy#4717); _component only isinstance()s it.
    objective = _component(
        registry,
        objective,
        Objective,  # type: ignore[type-abstract]
        "objective",
        "objective",
        **(objective_options or {}),
    )
    solver = _component(
        registry,
        solver,
        Solver,  # type: ignore[type-abstract]
        "solver",
        "solver",
        **(solver_options or {}),
    )
    if progress is not None and not callable(progress):
        raise TypeError(f"progress must be callable, not {type(progress).__name__}")
    if drift not in (True, False, "none", "common", "offsets", "trend"):
        raise ConfigError(
            f"drift {drift!r} is not one of false, true, 'common', 'offsets', 'trend' (the "
            "offsets and a trend together are not identified: both tell the epochs apart)"
        )
    terms = drift if isinstance(drift, str) else ""
    model, notes = fit_structure(
        dataset,
        structure,
        objective,
        solver,
        progress,
        drift=drift is True or drift == "common",
        offsets="offsets" in terms,
        trend="trend" in terms,
    )
    for message in notes:
        warnings.warn(message, FitWarning, stacklevel=2)
    return model


def load_model(path: str | os.PathLike[str], registry: Registry | None = None) -> FittedModel:
    """Read a model written by :meth:`FittedModel.save`.

    The model structure is rebuilt by name and order from ``registry`` (default: the
    process-wide one). Files written before channel names were saved load with the default
    names ``y1, y2`` / ``u1, u2``.
    """
    ds = read_netcdf(path, "model")
    if "structure" not in ds.attrs or "M" not in ds:
        raise DataError(f"{path} is not a model file written by sysid (no structure, no M)")
    # Files written before bias terms or the quadratic law existed hold the paper's model.
    structure = (registry or get_registry()).structure(
        str(ds.attrs["structure"]),
        order=int(ds.attrs["order"]),
        bias_terms=int(ds.attrs.get("bias_terms", 0)),
        stiffness=str(ds.attrs.get("stiffness", "linear")),
    )
    return model_from_dataset(ds, structure)
