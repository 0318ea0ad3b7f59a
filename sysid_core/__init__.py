"""sysid-toolkit core: identify and tune electrostatically tuned vibratory gyros.

Implements Kim & M'Closkey, "A systematic method for tuning the dynamics of electrostatically
actuated vibratory gyros", IEEE TCST 14(1), 2006. Components (model structures, objectives,
solvers, devices, tuning criteria) are plugins; see :mod:`sysid_core.plugin.spec`.

The package is built in rooms whose imports flow one way (``docs/architecture.md``):
:mod:`~sysid_core.errors` → :mod:`~sysid_core.data` → :mod:`~sysid_core.conic` →
:mod:`~sysid_core.model` → :mod:`~sysid_core.identification`, :mod:`~sysid_core.tuning`,
:mod:`~sysid_core.device` → :mod:`~sysid_core.plugin` → :mod:`~sysid_core.run` →
:mod:`~sysid_core.batch` → :mod:`~sysid_core.api`, :mod:`~sysid_core.testing` →
:mod:`~sysid_core.cli`. The names below are the public API.
"""

# first, before the heavy imports: a Ctrl-C while ``sysid`` starts is one line (``_launch``)
from sysid_core import _compat, _launch  # noqa: F401
from sysid_core.api import fit, load_model, predict_bias, tune
from sysid_core.data.schema import load_dataset, make_dataset, save_dataset, to_frd
from sysid_core.data.validation import check_rank_condition, validate
from sysid_core.errors import SysidError
from sysid_core.model.fitted import FittedModel
from sysid_core.plugin.interfaces import Device, ModelStructure, Objective, Solver, TuningCriterion
from sysid_core.plugin.registry import Registry, get_registry
from sysid_core.plugin.spec import hookimpl, hookspec
from sysid_core.run.config import PipelineConfig
from sysid_core.run.summary import RunSummary
from sysid_core.tuning.criteria import TuningResult

_compat.install()

__version__ = "0.1.0"

__all__ = [
    "Device",
    "FittedModel",
    "ModelStructure",
    "Objective",
    "PipelineConfig",
    "Registry",
    "RunSummary",
    "Solver",
    "SysidError",
    "TuningCriterion",
    "TuningResult",
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
