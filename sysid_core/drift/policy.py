"""``[model] drift`` parsed once into what a run does about a drifting gyro (:class:`DriftPolicy`).

The key's values:

===========  ===============================================================================
value        the run tracks the gyro
===========  ===============================================================================
``auto``     on a bench with a clock (every measurement so far carried time stamps)
``track``    always
``none``     never: the gyro is fitted as if it were frozen
===========  ===============================================================================

Tracking (:mod:`sysid_core.drift.tracker`) solves every answer for the gyro as its windows'
forecast (:mod:`sysid_core.identification.splittrend`) puts it at its verification; a tracking
run's fit carries a stiffness trend over long spans (:mod:`sysid_core.measure.fitter`). The drift
terms that a fit of measured data may carry on its own (``sysid_core.api.fit(drift=...)``) are
not run policies: the values ``common``, ``offsets`` and ``trend`` are refused with that advice
(:data:`REMOVED`).
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass
from typing import Literal

from sysid_core.identification.splittrend import LAB_TREND, TrendModel

__all__ = ["DRIFT_VALUES", "REMOVED", "DriftPolicy"]

#: The values of ``[model] drift``.
DRIFT_VALUES = ("auto", "none", "track")

#: Former values of ``[model] drift`` (fit terms, now only in ``sysid_core.api.fit``), and the
#: advice a configuration that still names one gets.
REMOVED = {
    value: (
        f'[model] drift = "{value}" is no longer a run policy: a run on a bench with a clock '
        'tracks the drifting gyro with drift = "auto" (the default) or "track" '
        "(docs/drift-model.md); to fit the drift terms to measured data, use "
        f'sysid_core.api.fit(data, drift="{value}")'
    )
    for value in ("common", "offsets", "trend")
}

Tracks = Literal["on a clock", "always", "never"]


@dataclass(frozen=True)
class DriftPolicy:
    """What ``[model] drift`` asks of a run (see the module).

    ``trend``: how a tracking run's forecast takes the split to move
    (:data:`~sysid_core.identification.splittrend.LAB_TREND`, with the lab's own prior on the
    split's rate where ``[model] drift_split_hz_per_h`` sets it).
    """

    value: str
    tracks: Tracks
    trend: TrendModel = LAB_TREND

    @classmethod
    def parse(cls, value: str, split_rate_hz_per_h: float | None = None) -> DriftPolicy:
        """The policy of ``value`` (one of :data:`DRIFT_VALUES`).

        ``split_rate_hz_per_h``: the prior standard deviation of each component of the split's
        rate (Hz/h) in place of the stated trend's (None: :data:`LAB_TREND`'s).

        Raises
        ------
        ValueError
            Naming the values allowed (or, for a former value, what to use instead).
        """
        if value in REMOVED:
            raise ValueError(REMOVED[value])
        if value not in DRIFT_VALUES:
            raise ValueError(f"drift {value!r} is not one of {', '.join(DRIFT_VALUES)}")
        tracks: Tracks = (
            "on a clock" if value == "auto" else "always" if value == "track" else "never"
        )
        trend = LAB_TREND
        if split_rate_hz_per_h is not None:
            trend = dataclasses.replace(LAB_TREND, rate_hz_per_s=split_rate_hz_per_h / 3600.0)
        return cls(value, tracks, trend)

    @property
    def may_track(self) -> bool:
        """Whether the run keeps a tracker (it tracks always, or on a clock)."""
        return self.tracks != "never"

    def tracking(self, clock: bool) -> bool:
        """Whether the run tracks the gyro, its measurements having time stamps (``clock``)."""
        return self.tracks == "always" or (self.tracks == "on a clock" and clock)
