"""The five interfaces of sysid-toolkit, in one place.

Data flows one way; each arrow is one interface, defined in the module of its step::

    Device ──measure──▶ Dataset (xarray)                 sysid_core.measuring   (Device)
    Dataset + ModelStructure ──▶ FitProblem              sysid_core.structures  (ModelStructure)
    FitProblem ──Objective──▶ ConicProgram               sysid_core.objective   (Objective)
    ConicProgram ──Solver──▶ ConicSolution               sysid_core.conic       (Solver)
    ──▶ FittedModel ──TuningCriterion──▶ bias ──▶ Device  sysid_core.tuning      (TuningCriterion)

Plugins implement them and register through the hooks of :mod:`sysid_core.hookspec`;
``docs/architecture.md`` follows one data set through every module.
"""

from __future__ import annotations

from sysid_core.conic import ConicProgram, ConicSolution, Solver, SolveStatus
from sysid_core.device import Device, SimulatedDevice
from sysid_core.objective import Objective, ObjectiveResult, Progress
from sysid_core.structures import ModelStructure
from sysid_core.tuning import BiasSpace, Goal, TuningCriterion, TuningResult

__all__ = [
    "BiasSpace",
    "ConicProgram",
    "ConicSolution",
    "Device",
    "Goal",
    "ModelStructure",
    "Objective",
    "ObjectiveResult",
    "Progress",
    "SimulatedDevice",
    "SolveStatus",
    "Solver",
    "TuningCriterion",
    "TuningResult",
]
