"""A previous model of the gyro (``--from-model``), brought to the gyro of today.

A model fitted by an earlier run of the same gyro knows its bias law (``M``, ``C``, ``K_p``,
the polynomial); what has changed since is mostly a stiffness offset (temperature, charging, a
remount). So a run that starts from it measures one mode grid at its start bias, around the
modes the model predicts there, and anchors the model on the latest sweeps
(:func:`~sysid_core.identification.anchor.anchor`: a stiffness and damping offset and a gain per
sweep) instead of locating the modes over the band and measuring a design. Each iteration then
measures only its verification while verifying is the quicker way to the acceptance at the rate
the verified split falls, priced against the local design on the bench clock: the rule of a run
without a model (:func:`~sysid_core.measure.contraction.too_slow`), a split that its window does
not resolve giving no rate. Once it is not, or a verification fails, the run goes on as one
without a model (:class:`~sysid_core.run.lean_protocol.LeanProtocol`), measuring the local design.
"""

from __future__ import annotations

import numpy as np
import xarray as xr

from sysid_core.data.schema import concat_experiments, point_times
from sysid_core.errors import ConfigError, DataError
from sysid_core.identification.anchor import anchor
from sysid_core.measure.contraction import Costs, design_or_not
from sysid_core.measure.lean import ModeGuess, mode_grid
from sysid_core.measure.sweeps import SweepPlan
from sysid_core.measure.verification import Verification
from sysid_core.model.fitted import FittedModel

__all__ = ["PRIOR_BANDWIDTHS", "PRIOR_WINDOWS", "PreviousModel", "check_prior"]

#: The first sweep spans this many bandwidths of uncertainty around the modes the previous
#: model predicts (the gyro may have moved since).
PRIOR_BANDWIDTHS = 2.0
#: The latest sweeps that anchor the model.
PRIOR_WINDOWS = 2


class PreviousModel:
    """A previous model of the gyro and the sweeps that anchor it (see the module).

    Parameters
    ----------
    model : FittedModel
        The earlier run's model, over the electrodes this run tunes.
    acceptance_hz : float
        The split the run must reach (``[tuning] acceptance_hz``).
    """

    def __init__(self, model: FittedModel, acceptance_hz: float = 0.0) -> None:
        self.model = model
        self.acceptance_hz = acceptance_hz
        #: The sweeps measured so far that anchor it (the first grid, then the verifications).
        self.windows: list[xr.Dataset] = []
        self.last_split: float | None = None

    @classmethod
    def given(cls, model: FittedModel | None, acceptance_hz: float) -> PreviousModel | None:
        """The previous model for a run to ``acceptance_hz`` (None if none)."""
        if model is None:
            return None
        return cls(model, acceptance_hz)

    def first_grid(self, tuned_bias: np.ndarray, plan: SweepPlan) -> np.ndarray:
        """The first sweep's frequencies, at the tuned electrodes' biases ``tuned_bias``.

        A mode grid around the modes the model predicts there, :data:`PRIOR_BANDWIDTHS` wide.

        Raises
        ------
        DataError
            If the model has no usable modes there.
        """
        modes = self.model.modal(tuned_bias)
        guess = ModeGuess.of(
            modes.frequencies_hz, modes.bandwidth_hz, PRIOR_BANDWIDTHS * modes.bandwidth_hz
        )
        if not guess.usable():
            raise DataError(
                "the model given (--from-model) has no usable modes at the start bias: tune "
                "without it, or start where it holds"
            )
        return mode_grid(guess, plan, resolve=True)

    def anchored(self, settle_s: float) -> tuple[xr.Dataset, FittedModel, int]:
        """The latest :data:`PRIOR_WINDOWS` sweeps, and the model anchored on them.

        The model is moved to the time of the next sweep, ``settle_s`` after the latest stamp;
        also returned: how many sweeps anchored it.
        """
        windows = self.windows[-PRIOR_WINDOWS:]
        timed = all(point_times(w, 0) is not None for w in windows)
        found = anchor(self.model, windows, rate=False, untimed=not timed)
        model = found.model_at(self.model, found.t_ref + settle_s)
        model.meta.update(fit_time_s=0.0, from_model=True)
        ds = concat_experiments(windows).sel(electrode=list(self.model.electrodes))
        return ds, model, found.sweeps

    def judge(
        self,
        verification: Verification,
        left: int,
        costs: Costs | None = None,
        low_hz: float | None = None,
    ) -> tuple[str | None, str | None]:
        """Why the model no longer helps (or None), and a line for the progress (or None).

        With no reason, the verification's sweep anchors the model next. The model no longer
        helps when the verification failed, or when verifying its next answers is not the
        quicker way to the acceptance at the rate the verified split fell
        (:func:`~sysid_core.measure.contraction.too_slow`): the split did not fall, would still be
        over the acceptance after the iterations left (``left``, the bench-time budget's,
        :meth:`sysid_core.run.context.RunContext.left`), or the verifications it needs cost more
        than the local design (its sweeps not measured yet, ``costs``) and one verification. A
        model whose law is off by a third shrinks the split about 3 times per iteration (1.58 Hz,
        0.42, 0.15, 0.036 in four iterations of the cloverleaf, where the local design reached
        0.6 mHz). Where the latest window's 95 % interval reaches down to the acceptance
        (``low_hz``), its split gives no rate and the model stays; the line says so where the
        rate, were it read, would have ended it
        (:func:`~sysid_core.measure.contraction.unresolved`).
        """
        split = verification.split_hz if verification.verified else None
        if split is None:
            return "the model given did not bring the split down (not verified)", None
        last, acceptance = self.last_split, self.acceptance_hz
        slow, note = design_or_not(last, split, left, acceptance, costs, low_hz)
        if slow:
            return f"the model given no longer pays: {slow}", None
        self.last_split = split
        self.windows.append(verification.sweep)
        return None, note


def check_prior(model: FittedModel, tuned: list[str]) -> None:
    """Refuse a previous model (``--from-model``) whose electrodes are not the tuned ones.

    Raises
    ------
    ConfigError
        Naming both lists.
    """
    if list(model.electrodes) != list(tuned):
        raise ConfigError(
            f"the model given (--from-model) has electrodes {list(model.electrodes)}, the run "
            f"tunes {list(tuned)}: give a model fitted with the same [tuning] electrodes (a "
            "run that chose a pair of them, [tuning] pair, fitted those two: set [tuning] "
            "electrodes to that pair)"
        )
