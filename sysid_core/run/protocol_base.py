"""What every measuring protocol of a run is (:class:`Protocol`): a strategy that owns its state.

It decides what each iteration measures and fits (:meth:`Protocol.data`) and how it verifies an
answer (:meth:`Protocol.verify`); every sweep goes through :meth:`Protocol.sweep`, which repeats
a narrow window whose noise hides the split. The protocols themselves are in
:mod:`sysid_core.run.protocols`.
"""

from __future__ import annotations

from abc import ABC, abstractmethod
from collections.abc import Mapping
from pathlib import Path
from typing import Any

import numpy as np
import xarray as xr

from sysid_core.measure.evidence import WindowAssessment
from sysid_core.measure.passes import repeat_window
from sysid_core.measure.sweeps import SweepPlan
from sysid_core.measure.verification import (
    COARSE_ENOUGH,
    Band,
    Verification,
    Window,
    modes_at,
    verify,
)
from sysid_core.model.fitted import FittedModel
from sysid_core.run.context import RunContext
from sysid_core.tuning.criteria import TuningResult

__all__ = ["Found", "Prefit", "Protocol"]

#: A fit already made of the data an iteration will fit: the data, the model, its notes.
Prefit = tuple[xr.Dataset, FittedModel, list[str]]
#: One sweep's data, its single-bias model and its evidence.
Found = tuple[xr.Dataset, FittedModel, WindowAssessment]


class Protocol(ABC):
    """What an iteration measures and fits, and how it verifies; one per run."""

    #: The latest iteration fitted only the sweeps near its bias (answers hold only near them).
    local = False
    #: Every configured electrode while the run tunes a pair of them (else None).
    offered: list[str] | None = None

    def __init__(self, ctx: RunContext) -> None:
        self.ctx = ctx

    @abstractmethod
    def data(
        self, it: int, bias: np.ndarray, folder: Path, center_hz: float | None, split_hz: float
    ) -> tuple[xr.Dataset, Prefit | None]:
        """The data iteration ``it`` fits (measured into ``folder`` as needed), and a prior fit.

        The fit is there if one was already made of exactly that data (else None).
        """

    @abstractmethod
    def verify(
        self, bias: np.ndarray, predicted: TuningResult, model: FittedModel, folder: Path
    ) -> Verification:
        """Step 4 at ``bias``, with evidence (:func:`sysid_core.measure.verification.verify`)."""

    def every_sweep(self, it: int, bias: np.ndarray) -> xr.Dataset | None:
        """Every sweep so far, if iteration ``it`` fitted fewer (None: it fitted them all)."""
        return None

    def learned(
        self,
        moved: bool,
        bias: np.ndarray,
        ver: Verification,
        info: Mapping[str, Any] | None = None,
    ) -> None:
        """Keep what the iteration ended with (the lean protocol does; the full one, nothing).

        A move (to the best reachable bias, or back), the bias verified, its verification, and
        the answer's ``TuningResult.info``.
        """
        return None

    def sweep(
        self, bias: np.ndarray, freqs: np.ndarray, path: Path, band: bool, enough: float = np.inf
    ) -> tuple[xr.Dataset, FittedModel, WindowAssessment]:
        """One sweep at ``bias``, its own model and the evidence that it shows both modes.

        A narrow window that shows both modes but whose noise hides the split is measured again
        and averaged (:mod:`sysid_core.measure.passes`); every pass is saved (``-pass2.nc``, ...).
        A window too coarse but with a split over ``enough`` (Hz) stands
        (:meth:`~sysid_core.measure.evidence.WindowAssessment.enough`).
        """
        sweep = self.ctx.bench.measure(bias, freqs, path)
        model, evidence = self.ctx.fitter.window(sweep, band)
        evidence = evidence.enough(enough)
        if band or not evidence.ok:
            return sweep, model, evidence
        ctx, first = self.ctx, (sweep, model, evidence)
        return repeat_window(ctx.bench, ctx.fitter, ctx.passes, ctx.say, bias, freqs, path, first)

    def _verify_with(
        self,
        bias: np.ndarray,
        predicted: TuningResult,
        model: FittedModel,
        folder: Path,
        plan: SweepPlan,
        lean: Window | None = None,
        band: Band | None = None,
    ) -> Verification:
        enough = COARSE_ENOUGH * self.ctx.config.tuning.acceptance_hz

        def sweep(
            freqs: np.ndarray, name: str, band: bool
        ) -> tuple[xr.Dataset, FittedModel, WindowAssessment]:
            return self.sweep(bias, freqs, folder / name, band, enough)

        modes = modes_at(model, bias[self.ctx.space.index])
        return verify(modes, predicted, plan, sweep, self.ctx.say, lean=lean, band=band)
