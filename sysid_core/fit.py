"""One call from a data set to a fitted model: :func:`fit`."""

from __future__ import annotations

import time
from typing import Any

import xarray as xr
from threadpoolctl import threadpool_limits

from sysid_core.interfaces import ModelStructure, Objective, ProgressCallback, Solver
from sysid_core.model import FittedModel
from sysid_core.problem import FitProblem
from sysid_core.registry import get_registry

__all__ = ["fit"]


def fit(
    dataset: xr.Dataset,
    structure: str | ModelStructure = "act",
    order: int = 1,
    objective: str | Objective = "minimax",
    solver: str | Solver = "clarabel",
    progress: ProgressCallback | None = None,
    objective_options: dict[str, Any] | None = None,
    solver_options: dict[str, Any] | None = None,
) -> FittedModel:
    """Fit one bias-dependent model to every experiment of ``dataset`` at once.

    Parameters
    ----------
    dataset : xarray.Dataset
        Multi-experiment frequency-response data (validated here).
    structure : str or ModelStructure
        ``"act"`` (output dynamics, eq. 8) or ``"sen"`` (input dynamics, eq. 10), or an instance.
    order : int
        Polynomial order ``n_R`` / ``n_B`` when ``structure`` is a name.
    objective : str or Objective
        ``"minimax"`` (the paper's criterion) or ``"least-squares"``, or an instance.
    solver : str or Solver
        ``"clarabel"`` or ``"scs"``, or an instance.
    progress : callable, optional
        Receives one-line progress messages.
    objective_options, solver_options : dict, optional
        Passed to the objective's / solver's factory when given by name.

    Returns
    -------
    FittedModel
        In physical units; ``model.meta`` holds the fit time, objective, solver and sizes.

    Examples
    --------
    >>> model = fit(load_dataset("examples/cloverleaf-3exp.nc"), "act", order=1)  # doctest: +SKIP
    >>> model.modal([2.04, 4.39]).split_hz  # doctest: +SKIP
    """
    reg = get_registry()
    if isinstance(structure, str):
        structure = reg.create("model structure", structure, order=order)
    if isinstance(objective, str):
        objective = reg.create("objective", objective, **(objective_options or {}))
    if isinstance(solver, str):
        solver = reg.create("solver", solver, **(solver_options or {}))
    t0 = time.perf_counter()
    with threadpool_limits(limits=1, user_api="blas"):
        problem = FitProblem(dataset, structure)
        result = objective.fit(problem, solver, progress)
    elapsed = time.perf_counter() - t0
    return problem.to_model(result, solver=solver.name, fit_time_s=elapsed)
