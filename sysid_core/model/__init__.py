"""The model: structures with the toolkit's defaults, the fitted model, modal analysis, exports.

Lives here: :class:`ModelStructure` and ``DEFAULT_ORDER``, ``DEFAULT_BIAS_TERMS``,
``DEFAULT_STIFFNESS`` (:mod:`.structures`), :class:`FittedModel` with its files
(:mod:`.fitted`) and what its fit found, typed (:mod:`.facts`), modal frequencies, Q, SNR loss
and the closed-form degenerate bias (:mod:`.modal`), and the python-control exports
(:mod:`.export`).

May import: :mod:`sysid_core.errors`, :mod:`sysid_core.data`, :mod:`sysid_core.conic`.
"""

from sysid_core.model.fitted import (
    DEFAULT_INPUTS,
    DEFAULT_OUTPUTS,
    FittedModel,
    channel_names,
    model_from_dataset,
)

__all__ = [
    "DEFAULT_INPUTS",
    "DEFAULT_OUTPUTS",
    "FittedModel",
    "channel_names",
    "model_from_dataset",
]
