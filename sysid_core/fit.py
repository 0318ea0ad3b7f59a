"""From a data set to a fitted model and back: :func:`fit`, :func:`check_fit`, :func:`load_model`.

These are the entry points for Python users, who name components (``"act"``, ``"minimax"``);
names are looked up in the plugin registry passed in, or the process-wide one. Component
objects passed in are used as they are (the pipeline passes the ones it built).
"""

from __future__ import annotations

import copy
import os
import time
import warnings
from typing import Any, TypeVar

import numpy as np
import xarray as xr
from threadpoolctl import threadpool_limits

from sysid_core.config import DEFAULT_BIAS_TERMS, DEFAULT_OBJECTIVE, DEFAULT_ORDER
from sysid_core.conic import Solver
from sysid_core.data import measured_mask, read_netcdf
from sysid_core.errors import DataError, FitWarning, RankConditionError, TooFewExperimentsError
from sysid_core.model import FittedModel, model_from_dataset, model_from_problem, unit_mass
from sysid_core.objective import Objective, Progress
from sysid_core.options import accepted_options
from sysid_core.problem import FitProblem
from sysid_core.registry import Registry, get_registry
from sysid_core.structures import ModelStructure
from sysid_core.validation import check_rank_condition

__all__ = ["RESONANCE_RATIO", "check_fit", "fit", "load_model"]

#: An experiment whose largest response is less than this many times its smallest shows no
#: resonance (a narrow window beside the modes, or a disconnected sensor).
RESONANCE_RATIO = 1.5

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
    solver: str | Solver = "clarabel",
    progress: Progress | None = None,
    objective_options: dict[str, Any] | None = None,
    solver_options: dict[str, Any] | None = None,
    registry: Registry | None = None,
    bias_terms: int | None = None,
    stiffness: str | None = None,
) -> FittedModel:
    """Fit one bias-dependent model to every experiment of ``dataset`` at once.

    Parameters
    ----------
    dataset : xarray.Dataset
        Multi-experiment frequency-response data (validated here).
    structure : str or ModelStructure
        ``"act"`` (output dynamics, eq. 8) or ``"sen"`` (input dynamics, eq. 10), or an instance.
    order : int
        Polynomial order ``n_R`` / ``n_B`` when ``structure`` is a name (default 2).
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
        :class:`~sysid_core.structures.ModelStructure`).
    stiffness : str, optional
        When ``structure`` is a name: the stiffness law in ``w``, ``"linear"`` (default, the
        paper's), ``"quadratic"`` (adds ``L_p w_p²``; needs a two-sided design) or ``"auto"``
        (the quadratic law if a Wald test of its terms rejects them being zero at 99 %, else
        the linear law on the same data; ``model.meta["stiffness_law"]`` says which).

    Returns
    -------
    FittedModel
        In physical units; ``model.meta`` holds the fit time, objective, solver and sizes.

    Raises
    ------
    TypeError
        For arguments of the wrong type.
    DataError
        For data that cannot be fitted (see :func:`sysid_core.data.validate`).

    Warns
    -----
    FitWarning
        When the result is probably meaningless (:func:`check_fit`).

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
        if stiffness is not None:
            extra["stiffness"] = stiffness
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
    if getattr(structure, "stiffness", "linear") == "auto":
        model = _fit_auto_law(dataset, structure, objective, solver, progress)
    else:
        model = _fit_one(dataset, structure, objective, solver, progress)
    for message in check_fit(dataset, model):
        warnings.warn(message, FitWarning, stacklevel=2)
    if model.meta.get("law_fallback"):
        warnings.warn(str(model.meta["law_test"]), FitWarning, stacklevel=2)
    return model


#: The quadratic law is not identified by a design whose normal matrix, in the plain centred
#: basis ``x, x² − mean(x²)``, has a larger condition number
#: (:meth:`~sysid_core.problem.FitProblem.normal_condition`): the solver's relative accuracy of
#: about 1e-8 then becomes more than 1e-3 of ``L_p`` (the error grows as the square root of
#: the condition). Measured: a two-sided design has 8; one whose two levels of an electrode
#: differ by 1e-4 of the step, 1e8; by 1e-6, 1e12.
LAW_CONDITION_LIMIT = 1e10


def _fit_one(
    dataset: xr.Dataset,
    structure: ModelStructure,
    objective: Objective,
    solver: Solver,
    progress: Progress | None,
) -> FittedModel:
    """Fit ``structure`` to ``dataset``; a quadratic law the design does not identify (see
    :data:`LAW_CONDITION_LIMIT`) falls back to the linear law, saying so in ``progress``, in
    ``meta["law_test"]`` and as a :class:`FitWarning` (from :func:`fit`)."""
    t0 = time.perf_counter()
    facts: dict[str, object] = {}
    with threadpool_limits(limits=1, user_api="blas"):
        problem = FitProblem(dataset, structure)
        if problem.layout.quadratic:
            law_condition = problem.normal_condition(law_basis=True)
            facts["law_condition"] = law_condition
            if not law_condition <= LAW_CONDITION_LIMIT:
                linear = copy.copy(structure)
                linear.stiffness = "linear"
                problem = FitProblem(dataset, linear)
                facts.update(
                    stiffness_law="linear",
                    law_fallback=True,
                    law_test=(
                        f"quadratic law not identified by this design (normal matrix condition "
                        f"{law_condition:.3g} > {LAW_CONDITION_LIMIT:.0e}): fitted the linear "
                        "law; step each electrode to two levels clearly apart"
                    ),
                )
                if progress is not None:
                    progress(str(facts["law_test"]))
        facts["normal_condition"] = problem.normal_condition()
        result = objective.fit(problem, solver, progress)
    elapsed = time.perf_counter() - t0
    result, mass_factor = unit_mass(problem, result)
    if mass_factor is not None:
        facts["mass_normalised"] = mass_factor
    return model_from_problem(problem, result, solver=solver.name, fit_time_s=elapsed, **facts)


#: Confidence level of the test that keeps the quadratic stiffness law (``stiffness = "auto"``).
LAW_TEST_LEVEL = 0.99


def law_statistic(model: FittedModel) -> tuple[float, int] | None:
    """Wald statistic of the quadratic terms ``L_p`` of a least-squares fit, and its degrees
    of freedom: ``l^T Cov(l)^+ l`` over the entries (11, 12, 22) of every ``L_p``; χ²-distributed
    when the law is linear. ``None`` without ``L_p`` or without a covariance (minimax)."""
    if model.Lp is None or model.stiffness_factor is None or not len(model.electrodes):
        return None
    n_l = 3 * len(model.electrodes)
    rows = model.stiffness_factor[-n_l:]
    cov = rows @ rows.T
    values = np.concatenate([[lp[0, 0], lp[0, 1], lp[1, 1]] for lp in model.Lp])
    lam, vec = np.linalg.eigh(cov)
    keep = lam > 1e-12 * max(float(lam.max()), 1e-300)
    proj = vec[:, keep].T @ values
    return float(np.sum(proj**2 / lam[keep])), int(keep.sum())


def _fit_auto_law(
    dataset: xr.Dataset,
    structure: ModelStructure,
    objective: Objective,
    solver: Solver,
    progress: Progress | None,
) -> FittedModel:
    """``stiffness = "auto"``: the quadratic law where the data show it, else the linear one.

    With a design that identifies it (two-sided), the quadratic law is fitted and kept if the
    Wald test of its terms (:func:`law_statistic`) rejects ``L_p = 0`` at
    :data:`LAW_TEST_LEVEL`; otherwise (or without a covariance, or with a one-sided design) the
    linear law is fitted to the same data. ``model.meta["stiffness_law"]`` says which, with the
    statistic and the threshold.
    """
    import scipy.stats

    linear, quadratic = copy.copy(structure), copy.copy(structure)
    linear.stiffness, quadratic.stiffness = "linear", "quadratic"
    bias = np.asarray(dataset["bias"].values, dtype=float)
    vg = float(dataset.attrs["structure_potential"])
    try:
        if bias.shape[1] == 0:
            raise TooFewExperimentsError("no bias electrodes: nothing depends on w")
        check_rank_condition(bias, vg, quadratic=True)
    except (RankConditionError, TooFewExperimentsError):
        model = _fit_one(dataset, linear, objective, solver, progress)
        model.meta.update(stiffness_law="linear", law_test="design does not identify L_p")
        return model
    quad = _fit_one(dataset, quadratic, objective, solver, progress)
    if quad.meta.get("law_fallback"):
        return quad
    found = law_statistic(quad)
    if found is not None:
        stat, dof = found
        threshold = float(scipy.stats.chi2.ppf(LAW_TEST_LEVEL, dof))
        facts: dict[str, object] = {"law_statistic": stat, "law_threshold": threshold}
        if stat > threshold:
            quad.meta.update(stiffness_law="quadratic", **facts)
            return quad
    else:
        facts = {"law_test": "no covariance (minimax): the linear law is kept"}
    model = _fit_one(dataset, linear, objective, solver, progress)
    model.meta.update(stiffness_law="linear", **facts)
    return model


def check_fit(dataset: xr.Dataset, model: FittedModel) -> list[str]:
    """Reasons to distrust a fit of ``dataset``: data without resonance, modes outside the data.

    Returns one message per finding (empty when nothing is suspicious):

    * an experiment whose largest response is less than :data:`RESONANCE_RATIO` times its
      smallest (constant data, or a window with no mode in it);
    * a fitted modal frequency, at an experiment's bias, outside that experiment's measured
      frequencies (the model extrapolates: its modes are guesses).
    """
    found: list[str] = []
    mask = measured_mask(dataset)
    f = np.asarray(dataset["frequency"].values, dtype=float)
    bias = np.asarray(dataset["bias"].values, dtype=float)
    flat = []
    for k in range(mask.shape[0]):
        s = np.linalg.norm(np.asarray(dataset["response"].values[k])[mask[k]], 2, axis=(-2, -1))
        if s.max() < RESONANCE_RATIO * max(s.min(), 1e-300):
            flat.append(k)
    if flat:
        found.append(
            f"experiment(s) {flat} show no resonance (largest response less than "
            f"{RESONANCE_RATIO:g} times the smallest): the fitted modes are not supported by "
            "the data; measure over the band where the modes are"
        )
    outside = []
    for k in range(mask.shape[0]):
        lo, hi = f[mask[k]].min(), f[mask[k]].max()
        try:
            modes = model.modal(bias[k]).frequencies_hz
        except ValueError:  # no oscillating modes at this bias: as bad as outside
            outside.append(f"experiment {k}: no oscillating modes")
            continue
        if modes.min() < lo or modes.max() > hi:
            outside.append(
                f"experiment {k}: {modes[0]:.4g} / {modes[1]:.4g} Hz outside {lo:.6g}-{hi:.6g} Hz"
            )
    if outside:
        found.append(
            "fitted modes lie outside the measured frequencies ("
            + "; ".join(outside)
            + "): the model extrapolates; measure over a band that contains both modes"
        )
    return found


def load_model(path: str | os.PathLike[str], registry: Registry | None = None) -> FittedModel:
    """Read a model written by :meth:`FittedModel.save`.

    The model structure is rebuilt by name and order from ``registry`` (default: the
    process-wide one). Files written before channel names were saved load with the default
    names ``y1, y2`` / ``u1, u2``.
    """
    ds = read_netcdf(path, "model")
    if "structure" not in ds.attrs or "M" not in ds:
        raise DataError(f"{path} is not a model file written by sysid (no structure, no M)")
    structure = (registry or get_registry()).structure(
        str(ds.attrs["structure"]),
        order=int(ds.attrs["order"]),
        **({"bias_terms": int(ds.attrs["bias_terms"])} if "bias_terms" in ds.attrs else {}),
        **(
            {"stiffness": str(ds.attrs["stiffness"])}
            if ds.attrs.get("stiffness", "linear") != "linear"
            else {}
        ),
    )
    return model_from_dataset(ds, structure)
