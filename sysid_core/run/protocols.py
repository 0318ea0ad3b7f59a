"""The measuring protocols of a run, as strategies that own their state.

A protocol decides what each iteration measures and fits, and how it verifies an answer:

* :class:`FullProtocol` (``[experiment] protocol = "full"``): the paper's; every iteration
  measures the design of eq. (18) over the band (then a window around the modes the previous
  verification measured) and fits it alone.
* :class:`~sysid_core.run.lean_protocol.LeanProtocol` (the default, in
  :mod:`sysid_core.run.lean_protocol`): points where the modes are; every sweep is kept and
  fitted again while the verifications agree with the model of all of them, the sweeps near
  the bias once they do not.

Both are :class:`~sysid_core.run.protocol_base.Protocol` and share :class:`RunContext`: the
bench, the fitter, the sweeps' plan, the experiment design and the progress callback.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import xarray as xr

from sysid_core.data.schema import concat_experiments
from sysid_core.errors import ConfigError
from sysid_core.measure.verification import Verification
from sysid_core.model.fitted import FittedModel
from sysid_core.run.context import RunContext
from sysid_core.run.lean_protocol import LeanProtocol
from sysid_core.run.protocol_base import Found, Prefit, Protocol
from sysid_core.tuning.criteria import TuningResult

__all__ = [
    "Found",
    "FullProtocol",
    "LeanProtocol",
    "Prefit",
    "Protocol",
    "RunContext",
    "make_protocol",
]


class FullProtocol(Protocol):
    """The paper's protocol: every iteration measures and fits its own design."""

    def data(
        self, it: int, bias: np.ndarray, folder: Path, center_hz: float | None, split_hz: float
    ) -> tuple[xr.Dataset, Prefit | None]:
        """The iteration's own design around ``bias``, measured afresh (no prior fit)."""
        ctx, self.local = self.ctx, it > 1
        design = ctx.design(bias, it)
        freqs = ctx.plan.refine(center_hz, split_hz)
        parts = [ctx.bench.measure(b, freqs, folder / f"exp{j}.nc") for j, b in enumerate(design)]
        ds = concat_experiments(parts).sel(electrode=ctx.space.tuned)
        ctx.say(
            f"iteration {it}: fitting {ctx.fitter.structure.name} model to {len(design)} "
            "experiments"
        )
        return ds, None

    def verify(
        self, bias: np.ndarray, predicted: TuningResult, model: FittedModel, folder: Path
    ) -> Verification:
        """Step 4 at ``bias`` with the run's own sweep plan."""
        return self._verify_with(bias, predicted, model, folder, self.ctx.plan)


def make_protocol(ctx: RunContext, prior: FittedModel | None = None) -> Protocol:
    """The protocol the configuration names (``[experiment] protocol``).

    ``prior``: a previous model of the gyro (``--from-model``), used by the lean protocol.
    """
    if ctx.config.experiment.protocol == "lean":
        return LeanProtocol(ctx, prior)
    if prior is not None:
        raise ConfigError(
            '--from-model needs the lean protocol ([experiment] protocol = "lean", the '
            "default): the full protocol measures its own design every iteration"
        )
    return FullProtocol(ctx)
