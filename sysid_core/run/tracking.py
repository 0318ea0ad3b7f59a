"""``[model] drift = "track"``: each answer solved for the gyro as it will be when it is verified.

The run's fit keeps its bias law; :class:`Tracker` anchors that model on the run's latest verified
windows (:func:`sysid_core.identification.anchor.anchor`: a stiffness offset, and its rate once
two verifications are at hand) and moves it ahead to the middle of the next verification window:
the latest time stamp, plus the settling after the bias change, plus half a window. The split
(and its orientation) of the moved model at the latest window's bias is then the one that
window's own fit measured (:func:`sysid_core.identification.anchor.split_offset`): the anchor
holds the model's mass and polynomial, and near degenerate modes what those miss it can take
for a split.

A window measured before a local design is stale by the design's duration (four sweeps: 90-110 s
on a 25 kHz gyro, in which charging moves the split by 2-4 mHz); when the latest window verified a
near-degenerate split and sweeps were measured after it, :meth:`Tracker.stale` says so and the
run measures the window again at its bias (:meth:`Tracker.refreshed`): the answer is then anchored
on a window seconds old, and the two measurements of one bias give the drift's rate.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import xarray as xr

from sysid_core.data.schema import requested_bias
from sysid_core.identification.anchor import anchor, split_offset
from sysid_core.identification.drift import OffsetDrift, offset_drift
from sysid_core.model.fitted import FittedModel
from sysid_core.run.evidence import WindowAssessment
from sysid_core.run.verification import Verification

__all__ = ["NEAR_ACCEPTANCES", "Tracker"]

#: Measures, saves and judges a sweep: ``(bias, frequencies, path, band)`` to ``(sweep, its
#: single-bias model, evidence)`` (the protocol's :meth:`~sysid_core.run.protocols.Protocol.sweep`).
Sweep = Callable[
    [np.ndarray, np.ndarray, Path, bool], tuple[xr.Dataset, FittedModel, WindowAssessment]
]

#: Earlier windows anchor the model when their split was under this many acceptances.
NEAR_ACCEPTANCES = 10.0


def _times(ds: xr.Dataset) -> np.ndarray:
    if "time_s" not in ds:
        return np.array([])
    t = np.asarray(ds["time_s"].values, dtype=float).ravel()
    return t[np.isfinite(t)]


@dataclass
class Tracker:
    """The verified windows of a run, and the model moved to the time of the next one.

    Parameters
    ----------
    settle_s : float
        The device's settling time after a bias change (0 if it does not say).
    near_hz : float
        Earlier windows anchor the model only if they measured a split under this.
    keep : int
        How many of the latest verified windows anchor the model.
    """

    settle_s: float = 0.0
    near_hz: float = float("inf")
    keep: int = 4
    windows: list[xr.Dataset] = field(default_factory=list)
    splits: list[float] = field(default_factory=list)
    #: Each window's own single-bias model.
    models: list[FittedModel] = field(default_factory=list)
    #: The rates the last :meth:`now` found (common and split), or None.
    rates: OffsetDrift | None = None

    def learned(self, ver: Verification) -> None:
        """Keep the verification's last window if it verified a split at known times."""
        t = _times(ver.sweep)
        if ver.verified and ver.split_hz is not None and t.size == ver.sweep["frequency"].size:
            self.windows.append(ver.sweep)
            self.splits.append(float(ver.split_hz))
            self.models.append(ver.model)

    def stale(self, ds: xr.Dataset) -> xr.Dataset | None:
        """The latest window, to be measured again, or None.

        Only a window that verified a split under ``near_hz`` and that ``ds`` has points
        measured after (a design measured since) is stale.
        """
        if not self.windows or self.splits[-1] > self.near_hz:
            return None
        last, stamps = _times(self.windows[-1]), _times(ds)
        if not last.size or not stamps.size:
            return None
        return self.windows[-1] if float(stamps.max()) > float(last.max()) else None

    def refresh(
        self,
        ds: xr.Dataset,
        sweep: Sweep,
        folder: Path,
        say: Callable[[str], None],
        it: int,
    ) -> None:
        """Measure the latest window again if it is :meth:`stale` (``window-again.nc``).

        ``sweep(bias, frequencies, path, band)`` measures, saves and judges a sweep (the
        protocol's); the window is kept if its evidence holds.
        """
        stale = self.stale(ds)
        if stale is None:
            return
        say(
            f"iteration {it}: the latest verified window is older than the design measured "
            "since; measuring it again"
        )
        freqs = np.asarray(stale["frequency"].values, dtype=float)
        path = folder / "window-again.nc"
        again, own, evidence = sweep(requested_bias(stale), freqs, path, False)
        if evidence.ok:
            self.refreshed(again, evidence.split_hz, own)

    def refreshed(self, sweep: xr.Dataset, split_hz: float | None, model: FittedModel) -> None:
        """Keep ``sweep``, the latest window measured again, if it verified ``split_hz``.

        ``model``: its own single-bias model.
        """
        t = _times(sweep)
        if split_hz is not None and t.size == sweep["frequency"].size:
            self.windows.append(sweep)
            self.splits.append(float(split_hz))
            self.models.append(model)

    def anchoring(self) -> list[xr.Dataset]:
        """The latest window, and up to ``keep - 1`` earlier ones with a split under ``near_hz``.

        Windows far from degenerate modes are at biases far from the latest: what the model's
        bias law misses between them (about a tenth of the split's change, measured) would be
        taken for a drift.
        """
        older = [
            w for w, s in zip(self.windows[:-1], self.splits[:-1], strict=True) if s <= self.near_hz
        ]
        return (
            [*older[-(self.keep - 1) :], self.windows[-1]] if self.keep > 1 else self.windows[-1:]
        )

    def ahead_s(self) -> float:
        """From the latest time stamp to the middle of the next window (seconds)."""
        t = _times(self.windows[-1]) if self.windows else np.array([])
        return self.settle_s + (0.5 * float(np.ptp(t)) if t.size else 0.0)

    def now(
        self, model: FittedModel, ds: xr.Dataset, say: Callable[[str], None], it: int
    ) -> FittedModel:
        """``model`` anchored on the latest windows, at the next window's middle.

        ``model`` itself when no window has verified a split yet.
        """
        if not self.windows:
            return model
        found = anchor(model, self.anchoring())
        stamps = _times(ds)
        at = max(found.t_ref, float(stamps.max()) if stamps.size else found.t_ref) + self.ahead_s()
        moved = found.model_at(model, at)
        # the split the latest window's own fit measured, which the anchor can miss
        last = self.windows[-1]
        then = found.model_at(model, float(_times(last).mean()))
        offset = split_offset(then, last, self.models[-1])
        moved = dataclasses.replace(moved, K0=np.asarray(moved.K0) + offset)
        self.rates = seen = offset_drift(moved)
        split = (
            "split's rate not told from the noise"
            if seen is None or abs(seen.split_hz_per_h) < 1e-9
            else f"split {seen.split_hz_per_h * 1e3:.3g} mHz/h"
        )
        rates = (
            ""
            if seen is None
            else f"; drift {seen.common_hz_per_h * 1e3:+.4g} mHz/h common, {split}"
        )
        say(
            f"iteration {it}: the model anchored on {found.sweeps} verified window(s), "
            f"{at - found.t_ref:.0f} s ahead{rates}"
        )
        return moved
