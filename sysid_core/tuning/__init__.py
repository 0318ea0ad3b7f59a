"""Tuning: from a fitted model to the bias that meets a criterion (step 3 of the method).

Lives here: the criterion interface, the bias space and the answer (:mod:`.criteria`), the
spread programs in the squared potentials (:mod:`.spread`) and the answer's confidence region
(:mod:`.confidence`).

May import: :mod:`sysid_core.errors`, :mod:`sysid_core.data`, :mod:`sysid_core.conic`,
:mod:`sysid_core.model`. Not :mod:`sysid_core.identification` or :mod:`sysid_core.device`.
"""

from sysid_core.tuning.criteria import (
    BiasSpace,
    ConfidenceRegion,
    Goal,
    TuningCriterion,
    TuningResult,
    bias_from_w,
    degenerate_bias,
    degenerate_w,
    frequencies_from_w,
    solve_criterion,
    w_interval,
)

__all__ = [
    "BiasSpace",
    "ConfidenceRegion",
    "Goal",
    "TuningCriterion",
    "TuningResult",
    "bias_from_w",
    "degenerate_bias",
    "degenerate_w",
    "frequencies_from_w",
    "solve_criterion",
    "w_interval",
]
