"""The five interfaces of sysid-toolkit, in one place.

Data flows one way; each arrow is one interface, defined in the module of its step::

    Device ──measure──▶ Dataset (xarray)            device.measuring       (Device)
    Dataset + ModelStructure ──▶ FitProblem         model.structures       (ModelStructure)
    FitProblem ──Objective──▶ ConicProgram          identification         (Objective)
    ConicProgram ──Solver──▶ ConicSolution          conic.program          (Solver)
    ──▶ FittedModel ──TuningCriterion──▶ bias       tuning.criteria        (TuningCriterion)
    bias ──▶ Device (the loop)                      run.pipeline

Plugins implement them and register through the hooks of :mod:`sysid_core.plugin.spec`;
``docs/architecture.md`` follows one data set through every module.
"""

from __future__ import annotations

from sysid_core.conic.program import ConicProgram, ConicSolution, Solver, SolveStatus
from sysid_core.device.protocol import Device, SimulatedDevice
from sysid_core.identification.objective import Objective, ObjectiveResult, Progress
from sysid_core.model.structures import ModelStructure
from sysid_core.tuning.criteria import BiasSpace, Goal, TuningCriterion, TuningResult

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
