"""``[model] drift = "track"``: each answer solved for the gyro as it will be when it is verified.

The run's fit keeps its bias law; :class:`Tracker` anchors that model on the run's latest verified
windows (:func:`sysid_core.identification.anchor.anchor`: a stiffness offset, and its rate once two
verifications are at hand) and moves it ahead to the time of the next verification window: the
latest time stamp, plus the settling after the bias change, plus as long as the latest window took
to its own time (:func:`sysid_core.drift.windows.window_time`). The split (and its orientation) of
the moved model at the latest window's bias is then the one that window's own fit measured
(:func:`sysid_core.identification.anchor.split_offset`): the anchor holds the model's mass and
polynomial, and near degenerate modes what those miss it can take for a split.

A window measured before a local design is stale by the design's duration (90-110 s on a 25 kHz
gyro: charging moves the split by 2-4 mHz): :meth:`Tracker.stale` has a near-degenerate one
measured again at its bias (:meth:`Tracker.refreshed`), which also gives the drift's rate.

The split at the next window is what the windows near degenerate modes predict together (one
Kalman filter: :func:`~sysid_core.drift.forecast.windows_forecast`), else the latest one alone.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import xarray as xr

from sysid_core.clock.runclock import stamps
from sysid_core.data.schema import requested_bias
from sysid_core.drift.forecast import interval_variance, windows_forecast, with_split_rate
from sysid_core.drift.looks import next_look, rayleigh_point, split_bound
from sysid_core.drift.policy import DriftPolicy
from sysid_core.drift.windows import blind, least_of, to_end_s, window_time
from sysid_core.errors import ModelError
from sysid_core.identification.anchor import anchor
from sysid_core.identification.drift import OffsetDrift, offset_drift
from sysid_core.identification.splittrend import (
    LAB_TREND,
    SplitForecast,
    TrendModel,
    variance_after,
)
from sysid_core.identification.trendnoise import noise_said
from sysid_core.measure.evidence import WindowAssessment
from sysid_core.measure.verification import Verification
from sysid_core.model.fitted import FittedModel
from sysid_core.model.modal import split_vector_hz
from sysid_core.tuning.confidence import split_interval

__all__ = ["NEAR_ACCEPTANCES", "Tracker"]

#: Measures, saves and judges a sweep: ``(bias, frequencies, path, band)`` to ``(sweep, its
#: single-bias model, evidence)`` (:meth:`~sysid_core.run.protocol_base.Protocol.sweep`).
Sweep = Callable[
    [np.ndarray, np.ndarray, Path, bool], tuple[xr.Dataset, FittedModel, WindowAssessment]
]
#: Values kept per window, for the windows chosen (None: not every one was kept).
Kept = list[float] | None

#: Earlier windows anchor the model when their split was under this many acceptances.
NEAR_ACCEPTANCES = 10.0


@dataclass
class Tracker:
    """The verified windows of a run, and the model moved to the time of the next one.

    Parameters
    ----------
    settle_s : float
        The device's settling time after a bias change (0 if it does not say), unless
        ``settling`` gives it for a model (the run's clock: the device's, the configuration's,
        or the model's estimate).
    near_hz : float
        Earlier windows anchor the model only if they measured a split under this.
    keep : int
        How many of the latest verified windows anchor the model.
    trend : TrendModel
        How the forecast takes the split to move (the drift policy's).
    """

    settle_s: float = 0.0
    settling: Callable[[FittedModel | None], float] | None = None
    near_hz: float = float("inf")
    keep: int = 4
    trend: TrendModel = LAB_TREND
    windows: list[xr.Dataset] = field(default_factory=list)
    #: Each window's split as near degenerate modes as its fit allows (``windows.least_split``).
    splits: list[float] = field(default_factory=list)
    #: Each window's own split's variance (:func:`~sysid_core.drift.forecast.split_variance`)
    #: and its time (:func:`~sysid_core.drift.windows.window_time`; NaN: its stamps' mean).
    variances: list[float] = field(default_factory=list)
    times: list[float] = field(default_factory=list)
    #: Each window's own single-bias model.
    models: list[FittedModel] = field(default_factory=list)
    #: Whether each window's own fit has a mode none of its points came near (``windows.blind``).
    blind: list[bool] = field(default_factory=list)
    #: The rates the last :meth:`now` found (common and split), or None.
    rates: OffsetDrift | None = None
    #: Whether the last :meth:`now` measured the common rate (windows at two times or more, or
    #: a fit that carries the trend); otherwise the common part of :attr:`rates` is none.
    common_measured: bool = False
    #: The split the windows predicted at the next window by the last :meth:`now`, or None.
    forecast: SplitForecast | None = None
    #: The split the windows predicted at the end of the latest by the last :meth:`end_split`.
    at_end: SplitForecast | None = None
    #: How many windows in a row :meth:`end_split` has judged at one split, each held to its
    #: level (:func:`~sysid_core.drift.looks.look_level`), and the bias of the latest
    #: (electrode: volts): a code that moves the split by no more than the forecast's standard
    #: deviation from there continues the count (:func:`~sysid_core.drift.looks.next_look`).
    looks: int = 0
    looked_at: dict[str, float] | None = None

    @classmethod
    def of(
        cls,
        drift: DriftPolicy,
        acceptance_hz: float,
        settling: Callable[[FittedModel | None], float] | None = None,
    ) -> Tracker | None:
        """The tracker of a run whose ``[model] drift`` is ``drift``, or None.

        ``"track"`` and ``"auto"`` (on a bench with a clock) keep one; earlier windows anchor
        it when under :data:`NEAR_ACCEPTANCES` acceptances.
        """
        if not drift.may_track:
            return None
        return cls(settling=settling, near_hz=NEAR_ACCEPTANCES * acceptance_hz, trend=drift.trend)

    def learned(self, ver: Verification) -> None:
        """Keep the verification's last window if it verified a split at known times.

        A verification whose modes only a whole-band sweep found (``"located"``) refutes the
        windows the model was anchored on: it placed the verification's window where the
        modes were not. They are dropped, and the next answer comes from the fit of the
        sweeps, which holds the band sweep, until a window verifies again (a model anchored on
        a window 5.6 Hz apart at another bias predicted six answers in a row under 2 mHz
        where band sweeps located the modes 10-13 Hz apart).
        """
        t = stamps(ver.sweep)
        if ver.verified and ver.split_hz is not None and t.size == ver.sweep["frequency"].size:
            unseen = bool(ver.windows) and blind(ver.sweep, ver.windows[-1])
            self._keep(ver.sweep, float(ver.split_hz), ver.model, unseen)
        elif ver.status == "located":
            self.windows, self.splits, self.models, self.blind = [], [], [], []
            self.variances, self.times = [], []

    def _keep(
        self, sweep: xr.Dataset, split_hz: float, model: FittedModel | None, unseen: bool
    ) -> None:
        """Keep a window: its least split and its own split's variance from one interval."""
        interval = None if model is None else split_interval(model)
        self.windows.append(sweep)
        self.splits.append(least_of(split_hz, interval))
        self.variances.append(
            float("nan") if model is None else interval_variance(model.split_hz([]), interval)
        )
        self.times.append(float("nan") if (when := window_time(sweep, model)) is None else when)
        self.models.append(model)  # type: ignore[arg-type]
        self.blind.append(unseen)

    def stale(self, ds: xr.Dataset) -> xr.Dataset | None:
        """The latest window, to be measured again, or None.

        Only a window that verified a split under ``near_hz`` and that ``ds`` has points
        measured after (a design measured since) is stale.
        """
        if not self.windows or self.splits[-1] > self.near_hz:
            return None
        last, since = stamps(self.windows[-1]), stamps(ds)
        if not last.size or not since.size:
            return None
        return self.windows[-1] if float(since.max()) > float(last.max()) else None

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
            self.refreshed(again, evidence.split_hz, own, unseen=blind(again, evidence))

    def refreshed(
        self, sweep: xr.Dataset, split_hz: float | None, model: FittedModel, unseen: bool = False
    ) -> None:
        """Keep ``sweep``, the latest window measured again, if it verified ``split_hz``.

        ``model``: its own single-bias model; ``unseen``: its fit has a mode that none of its
        points came near (:func:`~sysid_core.drift.windows.blind`).
        """
        t = stamps(sweep)
        if split_hz is not None and t.size == sweep["frequency"].size:
            self._keep(sweep, float(split_hz), model, unseen)

    def anchoring(self) -> list[xr.Dataset]:
        """The latest window, and up to ``keep - 1`` earlier ones with a split under ``near_hz``.

        Windows far from degenerate modes are at biases far from the latest: what the model's
        bias law misses between them (about a tenth of the split's change, measured) would be
        taken for a drift.
        """
        if not self.windows:
            return []
        older = [
            w for w, s in zip(self.windows[:-1], self.splits[:-1], strict=True) if s <= self.near_hz
        ]
        return (
            [*older[-(self.keep - 1) :], self.windows[-1]] if self.keep > 1 else self.windows[-1:]
        )

    def ahead_s(self, model: FittedModel | None = None) -> float:
        """From the latest time stamp to the time of the next window (seconds).

        The settling after the bias change (:attr:`settling` of ``model``, else
        :attr:`settle_s`) and what the latest window took to its own time
        (:func:`~sysid_core.drift.windows.window_time`).
        """
        t = stamps(self.windows[-1]) if self.windows else np.array([])
        settle = self.settle_s if self.settling is None else self.settling(model)
        return settle + (float(np.ptp(t)) - self._to_end_s() if t.size else 0.0)

    def _to_end_s(self) -> float:
        """:func:`~sysid_core.drift.windows.to_end_s` of the latest window, by its own fit."""
        own = self.models[-1] if len(self.models) == len(self.windows) else None
        return to_end_s(self.windows[-1], own)

    def now(
        self, model: FittedModel, ds: xr.Dataset, say: Callable[[str], None], it: int
    ) -> FittedModel:
        """``model`` anchored on the latest windows, at the next window's time (:meth:`ahead_s`).

        ``model`` itself when no window has verified a split yet.
        """
        if not self.windows:
            return model
        chosen = self.anchoring()
        found = anchor(model, chosen)
        measured = stamps(ds)
        latest = float(measured.max()) if measured.size else found.t_ref
        at = max(found.t_ref, latest) + self.ahead_s(model)
        moved = found.model_at(model, at)
        chosen_own, refused = self.filtered()
        self.forecast = None
        if chosen_own:
            offset, self.forecast = windows_forecast(
                model, moved, chosen_own, at, self.trend, *self.kept(chosen_own)
            )
            moved = dataclasses.replace(moved, K0=np.asarray(moved.K0) + offset)
            span = np.concatenate([stamps(w) for w, _ in chosen_own])
            moved = with_split_rate(moved, self.forecast, float(np.ptp(span)))
        self.rates = seen = offset_drift(moved)
        self.common_measured = found.rate is not None or model.facts.trend_per_s is not None
        rates = (
            ""
            if seen is None or found.rate is None  # one time: no common rate measured
            else f"; drift {seen.common_hz_per_h * 1e3:+.4g} mHz/h common"
        )
        own = ""
        if self.forecast is not None:
            window = self.windows[-1].sel(electrode=list(model.electrodes))
            try:
                there = moved.split_hz(np.asarray(window["bias"].values[0], dtype=float))
                at_latest = f"{there * 1e3:.3g} ± {1.96 * self.forecast.sigma_hz * 1e3:.2g} mHz"
            except ModelError:  # no modes there: the rate alone is said
                at_latest = "no split"
            own = (
                f"; {self.forecast.windows} window(s) predict {at_latest} at the latest bias "
                f"then, the split moving {np.hypot(*self.forecast.rate_hz_per_s) * 6e4:.2g} "
                f"mHz/min{noise_said(self.forecast.trend)}"
            )
        if refused:
            own += (
                f"; {refused} window(s) give no split of their own (a fitted mode that none of "
                "their points came near)"
            )
        say(
            f"iteration {it}: the model anchored on {found.sweeps} verified window(s), "
            f"{at - found.t_ref:.0f} s ahead{rates}{own}"
        )
        return moved

    def filtered(self) -> tuple[list[tuple[xr.Dataset, FittedModel]], int]:
        """The windows the filter reads, and how many give no split of their own.

        A window whose fit has a mode none of its points came near gives no split (that mode
        may be a phantom, ``blind``). The windows near degenerate modes (the least split their
        fit allows, ``least_split``: :mod:`sysid_core.drift.windows`, under ``near_hz``) while the
        latest is one of them; else the latest window that gives its own split, alone: far from
        degenerate modes, windows sit at biases between which the model's law misses more than
        the drift.
        """
        usable = [
            (w, own, s)
            for w, own, s, unseen in zip(
                self.windows, self.models, self.splits, self.blind, strict=True
            )
            if not unseen
        ]
        near = [(w, own) for w, own, s in usable if s <= self.near_hz]
        if near and near[-1][0] is self.windows[-1]:
            return near, len(self.windows) - len(usable)
        return [(w, own) for w, own, _ in usable[-1:]], len(self.windows) - len(usable)

    def kept(self, chosen: list[tuple[xr.Dataset, FittedModel]]) -> tuple[Kept, Kept]:
        """The kept variances and times of ``chosen`` windows (each None unless all kept)."""
        index = {id(w): k for k, w in enumerate(self.windows)}
        at = [index.get(id(sweep), len(self.windows)) for sweep, _ in chosen]

        def of(values: list[float]) -> Kept:
            found = [values[k] if k < len(values) else np.nan for k in at]
            return None if np.isnan(found).any() else found

        return of(self.variances), of(self.times)

    def end_split(self, model: FittedModel, sweep: xr.Dataset) -> tuple[float, float] | None:
        """The split at the end of the latest window by the windows' forecast, or None.

        Its upper bound and its mean (Hz): ``model`` given the split vector the windows'
        filter predicts at the window's last time stamp, at that window's bias, with the
        filter's variance; the bound is the Rice distribution's point at this look's level
        (:func:`~sysid_core.drift.looks.split_bound`: 95 % at the first look at a split, more at
        each later one in a row at it, :attr:`looks` counts them). None unless ``sweep`` is the
        latest window kept and gives a split of its own.
        """
        self.at_end = None
        if not self.windows or self.windows[-1] is not sweep or self.blind[-1]:
            return None
        chosen, _ = self.filtered()
        end = float(stamps(sweep).max())
        offset, found = windows_forecast(model, model, chosen, end, self.trend, *self.kept(chosen))
        self.at_end = found
        at_end = dataclasses.replace(model, K0=np.asarray(model.K0) + offset)
        bias = np.asarray(sweep.sel(electrode=list(model.electrodes))["bias"].values[0])
        vector = split_vector_hz(at_end.M, at_end.stiffness(bias))
        then = np.array([(self.looked_at or {}).get(e, np.nan) for e in model.electrodes])
        change = np.inf
        if then.size and not np.isnan(then).any():
            change = float(np.hypot(*(vector - split_vector_hz(at_end.M, at_end.stiffness(then)))))
        self.looks = next_look(self.looks, change, found.sigma_hz)
        self.looked_at = dict(zip(model.electrodes, map(float, bias), strict=True))
        mean = float(np.hypot(*vector))
        return split_bound(mean, found.sigma_hz, self.looks), mean

    def floor(self, windows: int, every_s: float) -> float | None:
        """The best bound on the split that ``windows`` more windows could show (Hz).

        After :meth:`end_split` (None without its forecast, or when the latest window measured
        a split over ``near_hz``: its noise is not a degenerate window's): the point, at the
        level of the look the last of them would be (``looks.rayleigh_point``), of a zero split
        vector (every answer from now on perfect) with the variance the filter would hold after
        ``windows`` more windows like the latest, one every ``every_s`` s, at the end of the last
        (``splittrend.variance_after``); over the acceptance, the bench sets the floor.
        """
        if self.at_end is None or not self.windows or self.splits[-1] > self.near_hz:
            return None  # a window far from degenerate modes measures a split of its own size
        to_end = self._to_end_s()
        variance = variance_after(self.at_end, self.at_end.trend, windows, every_s, to_end)
        return rayleigh_point(max(self.looks, 1) + windows) * float(np.sqrt(variance))

    def windows_to(self, limit_hz: float, every_s: float, most: int = 10_000) -> int | None:
        """The fewest more windows whose :meth:`floor` is under ``limit_hz``, or None.

        None without a floor, or none up to ``most``. The bound falls with the windows, then may
        rise (the drift ages them, each look's level climbs): doubling, then bisection.
        """
        floor = self.floor(0, every_s)
        if floor is None or floor <= limit_hz:
            return None if floor is None else 0
        lo, hi = 0, 1  # floor(lo) > limit
        while (self.floor(hi, every_s) or 0.0) > limit_hz:
            if hi >= most:
                return None
            lo, hi = hi, min(2 * hi, most)
        while hi - lo > 1:
            mid = (lo + hi) // 2
            if (self.floor(mid, every_s) or 0.0) > limit_hz:
                lo = mid
            else:
                hi = mid
        return hi
