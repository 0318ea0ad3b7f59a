"""Built-in tuning criteria: ``degenerate`` (eq. 14), ``target`` (eq. 23), ``min-max-bias``."""

from sysid_criteria.criteria import Degenerate, MinMaxBias, Target

__all__ = ["Degenerate", "MinMaxBias", "Target"]
