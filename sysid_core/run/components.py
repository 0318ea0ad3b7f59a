"""From a configuration to the components of a run, built once, from one registry.

:func:`build_components` is the only place where a configuration's names become objects: the
device, the model structure, the objective, the solver and the tuning criterion, each from the
registry it is given (a run's or a study's, never silently the global one) with its options
checked by :func:`sysid_core.plugin.options.check_options`. The criterion receives the run's solver,
with the ``[solver]`` options, when its factory takes a ``solver`` parameter. The run then
passes these very objects down: the fits and the criterion use them.
"""

from __future__ import annotations

from dataclasses import dataclass

from sysid_core.conic.program import Solver
from sysid_core.device.protocol import Device, check_device
from sysid_core.identification.objective import Objective
from sysid_core.model.structures import ModelStructure
from sysid_core.plugin.options import accepted_options
from sysid_core.plugin.registry import Registry
from sysid_core.run.config import PipelineConfig
from sysid_core.tuning.criteria import TuningCriterion

__all__ = ["TWINS", "Components", "build_components"]

#: The structure each one is checked against: output dynamics and input dynamics.
TWINS = {"act": "sen", "sen": "act"}


@dataclass(frozen=True)
class Components:
    """The five components of a tuning run."""

    device: Device
    structure: ModelStructure
    objective: Objective
    solver: Solver
    criterion: TuningCriterion
    #: The structure on the other side (``sen`` for ``act`` and back), built with the same
    #: options, or None: the run checks with it that a converging window fits the configured
    #: one (:func:`sysid_core.verdict.judgement.twin_goal`).
    twin: ModelStructure | None = None


def build_components(
    config: PipelineConfig, registry: Registry, device: Device | None = None
) -> Components:
    """Build every component of ``config`` from ``registry`` (``device``: use this one instead).

    Raises
    ------
    ConfigError
        For an unknown option or a bad value of any component (naming it).
    PluginNotFoundError
        For a name no installed plugin provides (listing the installed ones).
    DeviceError
        For a device that does not follow the protocol.
    """
    factory = registry.get("model structure", config.model.structure).factory
    accepted, _ = accepted_options(factory)
    structure = registry.structure(
        config.model.structure, **config.model.structure_options(accepted)
    )
    objective = registry.objective(config.objective.name, **config.objective.options)
    solver = registry.solver(config.solver.name, **config.solver.options)
    options = config.tuning.criterion_options
    named, _ = accepted_options(registry.get("tuning criterion", config.tuning.criterion).factory)
    if "solver" in named and "solver" not in options:
        options["solver"] = solver
    criterion = registry.criterion(config.tuning.criterion, **options)
    if device is None:
        device = registry.device(config.device.name, **config.device.options)
    else:
        check_device(device, config.device.name)
    twin = None
    other = TWINS.get(config.model.structure)
    if other is not None and other in registry.names("model structure"):
        twin = registry.structure(other, **config.model.structure_options(accepted))
    return Components(device, structure, objective, solver, criterion, twin)
