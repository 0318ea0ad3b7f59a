"""``[model] drift`` parsed once into what a run does about a drifting gyro (:class:`DriftPolicy`).

The key's values and what each turns on:

===========  ======================================  ==============================
value        the run tracks the gyro                 terms in the fit itself
===========  ======================================  ==============================
``auto``     on a bench with a clock (time stamps)   none
``track``    always                                  none
``none``     never                                   none
``common``   never                                   a common frequency drift
``offsets``  never                                   a stiffness offset per epoch
``trend``    never                                   a stiffness trend in time
===========  ======================================  ==============================

Tracking (:mod:`sysid_core.run.tracking`) solves every answer for the gyro as it will be at
its verification; the fit terms (:mod:`sysid_core.identification.drift`) are experimental. A
tracking run's fit carries the trend over long spans (:mod:`sysid_core.run.fitter`).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Literal

__all__ = ["DRIFT_VALUES", "DriftPolicy"]

#: The values of ``[model] drift``.
DRIFT_VALUES = ("auto", "none", "common", "offsets", "trend", "track")

Tracks = Literal["on a clock", "always", "never"]


@dataclass(frozen=True)
class DriftPolicy:
    """What ``[model] drift`` asks of a run (see the module)."""

    value: str
    tracks: Tracks
    common: bool = False
    offsets: bool = False
    trend: bool = False

    @classmethod
    def parse(cls, value: str) -> DriftPolicy:
        """The policy of ``value`` (one of :data:`DRIFT_VALUES`).

        Raises
        ------
        ValueError
            Naming the values allowed.
        """
        if value not in DRIFT_VALUES:
            raise ValueError(f"drift {value!r} is not one of {', '.join(DRIFT_VALUES)}")
        tracks: Tracks = (
            "on a clock" if value == "auto" else "always" if value == "track" else "never"
        )
        return cls(
            value,
            tracks,
            common=value == "common",
            offsets=value == "offsets",
            trend=value == "trend",
        )

    @property
    def may_track(self) -> bool:
        """Whether the run keeps a tracker (it tracks always, or on a clock)."""
        return self.tracks != "never"

    def tracking(self, clock: bool) -> bool:
        """Whether the run tracks the gyro, its measurements having time stamps (``clock``)."""
        return self.tracks == "always" or (self.tracks == "on a clock" and clock)
