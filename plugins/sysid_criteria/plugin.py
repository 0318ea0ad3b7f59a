"""Entry point of the built-in tuning criteria."""

from __future__ import annotations

from collections.abc import Callable, Mapping

from sysid_core import hookimpl
from sysid_core.plugin.interfaces import TuningCriterion
from sysid_criteria.criteria import Degenerate, MinMaxBias, Target


@hookimpl
def sysid_tuning_criteria() -> Mapping[str, Callable[..., TuningCriterion]]:
    return {"degenerate": Degenerate, "target": Target, "min-max-bias": MinMaxBias}
