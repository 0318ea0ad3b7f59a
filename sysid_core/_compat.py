"""The module paths of release 0.1, kept for one release: each warns and forwards.

Until 0.2, ``from sysid_core.problem import FitProblem`` still works: it gives the same object as
``from sysid_core.identification.problem import FitProblem`` with a :class:`DeprecationWarning`
that names the new path. :func:`install` puts one forwarding module per old path into
``sys.modules`` (the target is imported only when a name is used), so that an old path is never
imported as a module of its own and never rebinds a name of the package (``sysid_core.hookspec``
stays the hook marker, ``sysid_core.fit`` the function).
"""

from __future__ import annotations

import importlib
import sys
import types
import warnings
from typing import Any

__all__ = ["MOVED", "install"]

#: Old module (``sysid_core.<key>``) -> its new home (``sysid_core.<value>``).
MOVED: dict[str, str] = {
    "validation": "data.validation",
    "io": "data.io",
    "sweepfiles": "formats.sweepfiles",
    "manifest": "formats.manifest",
    "runfolder": "clock.runfolder",
    "structures": "model.structures",
    "modal": "model.modal",
    "export": "model.export",
    "problem": "identification.problem",
    "programs": "identification.programs",
    "covariance": "identification.covariance",
    "objective": "identification.objective",
    "fit": "api",
    "spread": "tuning.spread",
    "confidence": "tuning.confidence",
    "measuring": "device.measuring",
    "simulation": "device.simulation",
    "hookspec": "plugin.spec",
    "registry": "plugin.registry",
    "options": "plugin.options",
    "interfaces": "plugin.interfaces",
    "components": "run.components",
    "config": "run.config",
    "sweeps": "measure.sweeps",
    "lean": "measure.lean",
    "knowledge": "measure.knowledge",
    "evidence": "measure.evidence",
    "verification": "measure.verification",
    "dac": "verdict.dac",
    "bench": "clock.benchtime",
    "run_summary": "run.summary",
    "report": "run.plots",
    "pipeline": "run.pipeline",
    "runs": "api",
    "fleet": "batch.fleet",
    "study": "batch.study.runner",
    "study_plan": "batch.study.plan",
    "study_exec": "batch.study.execute",
    "study_report": "batch.study.report",
    "study_plots": "batch.study.plots",
    "cli_app": "cli.app",
    "cli_fit": "cli.fit",
    "cli_tune": "cli.tune",
    "cli_study": "cli.study",
    "cli_fleet": "cli.fleet",
    "cli_data": "cli.data",
    # release 0.2: the files a lab brings left the data set's room
    "data.sweepfiles": "formats.sweepfiles",
    "data.manifest": "formats.manifest",
    "data.export": "formats.export",
    "data.columnmap": "formats.columnmap",
    "data.columnsweep": "formats.columnsweep",
    "data.columnguess": "formats.columnguess",
    "data.csvsweep": "formats.csvsweep",
    "data.touchstone": "formats.touchstone",
    "data.matsweep": "formats.matsweep",
    "data.mat73": "formats.mat73",
    "data.textfile": "formats.textfile",
    "data.runfolder": "clock.runfolder",
}

#: Names that left an old module for another home than the module's own new one.
_SPLIT: dict[tuple[str, str], str] = {
    ("fit", "check_fit"): "identification.fitting",
    ("fit", "law_statistic"): "identification.law",
    ("fit", "RESONANCE_RATIO"): "identification.fitting",
    ("fit", "LAW_TEST_LEVEL"): "identification.law",
    ("fit", "LAW_CONDITION_LIMIT"): "identification.fitting",
    ("problem", "sigma_max_2x2"): "conic.program",
    ("config", "DEFAULT_ORDER"): "model.structures",
    ("config", "DEFAULT_BIAS_TERMS"): "model.structures",
    ("config", "DEFAULT_STIFFNESS"): "model.structures",
    ("config", "DEFAULT_OBJECTIVE"): "identification.objective",
}


class _MovedModule(types.ModuleType):
    """A stand-in for an old module path: every name read from it warns and is forwarded."""

    def __init__(self, old: str, new: str) -> None:
        super().__init__(f"sysid_core.{old}", f"Moved to sysid_core.{new}.")
        self._old, self._new = old, new

    def __getattr__(self, name: str) -> Any:
        if name.startswith("__"):
            raise AttributeError(name)
        home = _SPLIT.get((self._old, name), self._new)
        warnings.warn(
            f"sysid_core.{self._old} moved to sysid_core.{home}: import {name} from there "
            "(the old path is removed in sysid-toolkit 0.2)",
            DeprecationWarning,
            stacklevel=2,
        )
        return getattr(importlib.import_module(f"sysid_core.{home}"), name)


def install() -> None:
    """Register the stand-ins for every old path not already imported."""
    for old, new in MOVED.items():
        sys.modules.setdefault(f"sysid_core.{old}", _MovedModule(old, new))
