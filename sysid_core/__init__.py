"""sysid-toolkit core: identify and tune electrostatically tuned vibratory gyros.

Implements Kim & M'Closkey, "A systematic method for tuning the dynamics of electrostatically
actuated vibratory gyros", IEEE TCST 14(1), 2006. Components (model structures, objectives,
solvers, devices, tuning criteria) are plugins; see :mod:`sysid_core.hookspec`.
"""

from sysid_core.data import load_dataset, make_dataset, save_dataset, to_frd
from sysid_core.errors import SysidError
from sysid_core.fit import fit, load_model
from sysid_core.hookspec import hookimpl, hookspec
from sysid_core.interfaces import Device, ModelStructure, Objective, Solver, TuningCriterion
from sysid_core.model import FittedModel
from sysid_core.registry import Registry, get_registry
from sysid_core.runs import predict_bias, tune
from sysid_core.validation import check_rank_condition, validate

__version__ = "0.1.0"

__all__ = [
    "Device",
    "FittedModel",
    "ModelStructure",
    "Objective",
    "Registry",
    "Solver",
    "SysidError",
    "TuningCriterion",
    "__version__",
    "check_rank_condition",
    "fit",
    "get_registry",
    "hookimpl",
    "hookspec",
    "load_dataset",
    "load_model",
    "make_dataset",
    "predict_bias",
    "save_dataset",
    "to_frd",
    "tune",
    "validate",
]
