"""The lean protocol (the default, ``[experiment] protocol = "lean"``): points where the modes are.

Every sweep is kept (:class:`~sysid_core.measure.knowledge.Knowledge`) and fitted again while the
verifications agree with the model of all of them, the sweeps near the bias once they do not
(:mod:`sysid_core.measure.lean`). Where those lack the rank condition it measures the local
design's experiments they lack (``Knowledge.completing``), unless the split falls so fast that
the answer of the nearest sweeps that meet it is the cheaper way (:meth:`LeanProtocol._reach`).
"""

from __future__ import annotations

from collections.abc import Callable, Mapping, Sequence
from pathlib import Path
from typing import Any

import numpy as np
import xarray as xr

from sysid_core.clock.benchtime import settle as settle_s
from sysid_core.data.schema import point_times
from sysid_core.errors import SysidError
from sysid_core.measure.contraction import Costs, design_or_not, too_slow
from sysid_core.measure.evidence import WindowAssessment
from sysid_core.measure.information import measuring_order
from sysid_core.measure.knowledge import LEVEL_SHARE, Knowledge
from sysid_core.measure.lean import (
    FINE_STEP,
    LOCAL_RADIUS,
    ModeGuess,
    denser_plan,
    explained_gap,
    following,
    learning_grids,
    locate_plan,
    mode_grid,
)
from sysid_core.measure.locating import locate as locate_modes
from sysid_core.measure.locating import probe_first, probe_points, verify_tries
from sysid_core.measure.motion import motion_allowance
from sysid_core.measure.previous import PreviousModel
from sysid_core.measure.sweeps import SweepPlan
from sysid_core.measure.verification import Band, Verification, modes_at
from sysid_core.model.fitted import FittedModel
from sysid_core.run.context import RunContext
from sysid_core.run.electrodes import Electrodes
from sysid_core.run.first_design import toward_answer
from sysid_core.run.protocol_base import Found, Prefit, Protocol
from sysid_core.tuning.confidence import split_interval
from sysid_core.tuning.criteria import TuningResult

__all__ = ["LeanProtocol"]

#: Why a run measures the local design where it is now.
MOVED = "the last answer moved the run (to the best reachable bias, or back to a measured one)"
REGROWN = "every electrode is tuned from now on, where the first design was"
REPAIRED = "another pair is tuned from now on, where the first design was"


class LeanProtocol(Protocol):
    """Points where the modes are, every sweep kept (see the module).

    Later iterations fit every sweep while the last verification agrees with the model
    (:meth:`_design_now`); after that, or a later move to the best reachable bias, the sweeps near
    the bias, measuring what they lack of the local design to meet (6) where it pays.
    """

    def __init__(self, ctx: RunContext, prior: FittedModel | None = None) -> None:
        super().__init__(ctx)
        #: A previous model of the gyro (``--from-model``): while its answers contract the
        #: split, it is anchored on the latest sweeps instead of measuring designs.
        self.previous = PreviousModel.given(prior, ctx.config.tuning.acceptance_hz)
        self.known = Knowledge(ctx.space.tuned, ctx.space.structure_potential)
        self.locate_plan = locate_plan(ctx.plan, ctx.config.experiment.locate_points)
        self.local, self.moved = False, False
        self.last_verified: tuple[np.ndarray, np.ndarray] | None = None
        self.splits: list[float] = []  # every verified split, in order
        self.low: float | None = None  # the latest one's 95 % lower end (contraction.too_slow)
        self.verify_points: list[int] = []  # each sweep's points in the latest verification
        #: With ``probe``, the run's first look at the band is a probe (``measure.locating``);
        #: whether it found the bench quiet decides the first design and the scouts' floor.
        self.quiet, self.scout_plan = False, self.locate_plan
        #: The probe showed both modes: scouts step as it did; one missing them tries its band.
        self.probe_stood = False
        #: Which electrodes are tuned: a pair, or every one (:mod:`sysid_core.run.electrodes`).
        self.electrodes = Electrodes(ctx, self.known, self._learn)
        self.far_first = False  # a first answer out of reach moved the run: fit every sweep

    @property
    def offered(self) -> list[str] | None:  # type: ignore[override]
        """Every configured electrode while the run tunes a pair of them (else None)."""
        return self.electrodes.offered

    def data(
        self, it: int, bias: np.ndarray, folder: Path, center_hz: float | None, split_hz: float
    ) -> tuple[xr.Dataset, Prefit | None]:
        """Every sweep so far, or the sweeps near ``bias`` (see :class:`LeanProtocol`).

        The local design is measured where the sweeps near ``bias`` do not meet the rank
        condition; iteration 1 measures the design where the modes should be.
        """
        ctx = self.ctx
        self.known.begin(it)
        if self.previous is not None:
            return self._from_previous(it, bias, folder)
        # every electrode offered again where the first design was: that design, over the tuned
        again = self.electrodes.regrown(bias)
        chord = self.local and not (self.moved or again)  # local before, where it is: _reach
        # the electrodes a pair was chosen before, once it gave way, and maybe another pair
        self.electrodes.complete(bias, folder, self.moved)
        far, self.far_first = self.far_first, False  # every sweep spans that step: fit them
        if it > 1 and self.moved and not far:
            self.local = True
            where = (REPAIRED if self.offered else REGROWN) if again else MOVED
            ctx.say(f"iteration {it}: {where}; measuring the local design there")
        elif it > 1 and not self.local:
            why, prefit = self._design_now(it)
            if why is None:
                ctx.say(f"iteration {it}: fitting all {len(self.known)} sweeps so far")
                return (prefit[0], prefit) if prefit is not None else (self.known.union(), None)
            self.local = True
            ctx.say(f"iteration {it}: {why}; fitting the sweeps near the bias from now on")
        scale = 1 if again else it
        if it == 1 and not self.known.has(bias):  # the centre first (is the bench quiet?)
            self._learn(bias, folder / "exp0.nc")
        if it == 1:  # then the electrodes to tune (:class:`Electrodes`)
            self.electrodes.choose(bias, folder)
        radius = self._design(it, bias, folder, scale, chord)
        if it == 1:
            ctx.say(
                f"iteration {it}: fitting {ctx.fitter.structure.name} model to "
                f"{len(self.known)} sweeps"
            )
            return self.known.union(), None
        return self.known.near(bias, radius), None

    def _design(self, it: int, bias: np.ndarray, folder: Path, scale: int, chord: bool) -> float:
        """Measure the design of iteration ``it`` (later: what the sweeps near ``bias`` lack).

        Returns the radius of the sweeps to fit: :data:`LOCAL_RADIUS` steps, or with ``chord`` (a
        local run that did not move) :meth:`_reach`'s where that is the cheaper way (no sweep).
        """
        ctx, law = self.ctx, self.ctx.config.model.stiffness
        radius, apart = LOCAL_RADIUS * ctx.step(scale), LEVEL_SHARE * ctx.step(scale)
        if it > 1 and self.known.meets_rank(bias, radius, law, apart):
            return radius
        design = ctx.design(bias, scale, quiet=self.quiet and scale == 1)
        todo: Sequence[int] = range(len(design))  # the first design whole; later, what lacks
        if it == 1:  # its second steps toward the answer of the first ones
            design = toward_answer(ctx, self.known, bias, design)
        else:
            todo = self.known.completing(bias, radius, law, design, ctx.space.index, apart)
        todo = [j for j in todo if not self.known.has(design[j])]
        if it > 1 and chord and (wide := self._reach(it, bias, apart, todo)):
            return wide
        for j in todo:
            self._learn(design[j], folder / f"exp{j}.nc")
        return radius

    def every_sweep(self, it: int, bias: np.ndarray) -> xr.Dataset | None:
        """Every sweep so far, if the run fits only the sweeps near ``bias`` (and there are more).

        A local fit that finds the goal unreachable extrapolates from a few tenths of a volt;
        the sweeps of the whole run may span the answer.
        """
        if not self.local or self.previous is not None:
            return None
        near = self.known.near(bias, LOCAL_RADIUS * self.ctx.step(it))
        every = self.known.union()
        return every if every.sizes["experiment"] > near.sizes["experiment"] else None

    def verify(
        self, bias: np.ndarray, predicted: TuningResult, model: FittedModel, folder: Path
    ) -> Verification:
        """Step 4 at ``bias``, locating the modes with grids around the predicted ones."""
        modes = modes_at(model, bias[self.ctx.space.index])
        if modes is None:  # no oscillating modes at the answer: the band locates them
            return self._verify_with(bias, predicted, model, folder, self.locate_plan)
        bw = modes.bandwidth_hz
        if not np.all(np.isfinite(bw) & (bw > 0)):
            bw = np.full(2, self.ctx.plan.verify_resolution_hz)
        exp, ppm = self.ctx.config.experiment, self.ctx.plan.motion_ppm_per_h
        settle = settle_s(self.ctx.bench.device.capabilities, exp.settle_s, model)[0] or 0.0
        centre, sigma = self.known.centre(bias, self.ctx.space.index, predicted, model, settle, ppm)

        def window(
            center: float, split: float, around_prediction: bool, seen: np.ndarray | None
        ) -> np.ndarray:
            if around_prediction:
                center, uncertainty = centre, sigma
            else:  # modes the last sweep found: they may have moved since (a clock's drift)
                last = self.known.items[-1].data
                uncertainty = motion_allowance(center, point_times(last, 0), settle, ppm)
            guess = ModeGuess.of([center - split / 2, center + split / 2], bw, uncertainty)
            finest = None  # a second fine window resolves what the first one's fit measured
            if seen is not None and np.all(np.isfinite(seen)):
                narrowest = float(np.min(bw))
                finest = FINE_STEP * max(min(narrowest, float(np.min(seen))), narrowest / 4)
            plan, cost = self.ctx.plan, self._cost(around_prediction)
            fine = not around_prediction  # not after the bias change to the answer
            grid = mode_grid(guess, plan, resolve=True, fine=fine, finest_hz=finest, cost_s=cost)
            return measuring_order(grid, guess.frequencies_hz, bw)  # the split's best points last

        before = len(self.known)
        band = self._band(bias, folder)
        ver = self._verify_with(bias, predicted, model, folder, self.locate_plan, window, band)
        self.verify_points = [int(m.data.sizes["frequency"]) for m in self.known.items[before:]]
        return ver

    def _band(self, bias: np.ndarray, folder: Path) -> Band:
        """Locating at ``bias``: :func:`~sysid_core.measure.locating.verify_tries`."""

        def band(plan: SweepPlan, windows: list[WindowAssessment]) -> Found:
            found: list[Found] = []

            def sweep(freqs: np.ndarray, at: Path, whole: bool) -> Found:
                found.append(self.sweep(bias, freqs, at, whole))
                windows.append(found[-1][2])
                return found[-1]

            points = self.ctx.config.experiment.locate_points
            tries, dense = verify_tries(plan, self.ctx.plan.resolution_hz, self.probe_stood, points)
            locate_modes(sweep, self.ctx.say, folder / "verify-band.nc", tries, plan, dense)
            return found[-1]

        return band

    def learned(
        self,
        moved: bool,
        bias: np.ndarray,
        ver: Verification,
        info: Mapping[str, Any] | None = None,
    ) -> None:
        """Keep whether the run moved, and the verified bias and modes if verified.

        A pair whose answer (``info``) is beyond its reach gives way (``Electrodes.give_way``);
        a first answer out of reach that moved the run is followed by the fit of every sweep.
        """
        self.moved = moved
        first = self.known.epoch == 1 and not (self.local or self.splits or self.electrodes.offered)
        self.far_first = moved and first and "unreachable" in (info or {})
        self.electrodes.give_way(info, bias)
        if ver.verified and ver.frequencies_hz is not None:
            self.last_verified = (bias.copy(), np.asarray(ver.frequencies_hz, dtype=float))
            self.splits.append(float(ver.split_hz or 0.0))
            self.low = None if (ci := split_interval(ver.model)) is None else float(ci[0])
        if self.previous is not None:  # its next answer, or the local design there
            costs = self._costs(self.known.epoch + 1, bias) if ver.verified else None
            why, note = self.previous.judge(ver, self.ctx.left(), costs, self.low)
            if why:
                self.ctx.say(f"{why}; measuring the local design from now on")
                self.previous, self.local = None, True
            elif note:
                self.ctx.say(f"iteration {self.known.epoch}: {note}")

    def _from_previous(
        self, it: int, bias: np.ndarray, folder: Path
    ) -> tuple[xr.Dataset, Prefit | None]:
        """The previous model anchored on the latest sweeps (:mod:`sysid_core.measure.previous`).

        Iteration 1 measures one mode grid at ``bias`` around the modes the model predicts
        there (no locating sweep, no design); later ones anchor on the verification windows.
        """
        assert self.previous is not None
        ctx = self.ctx
        if it == 1:
            first = self.previous.first_grid(bias[ctx.space.index], ctx.plan)
            self._learn(bias, folder / "exp0.nc", first=first)
            self.previous.windows.append(self.known.items[-1].data)
        caps, exp = ctx.bench.device.capabilities, ctx.config.experiment
        ds, model, sweeps = self.previous.anchored(settle_s(caps, exp.settle_s)[0] or 0.0)
        ctx.say(f"iteration {it}: the model given anchored on {sweeps} sweep(s), no design")
        return ds, (ds, model, [])

    def sweep(
        self, bias: np.ndarray, freqs: np.ndarray, path: Path, band: bool, enough: float = np.inf
    ) -> tuple[xr.Dataset, FittedModel, WindowAssessment]:
        """One sweep at ``bias`` as :meth:`Protocol.sweep`, kept with the modes it shows."""
        found = super().sweep(bias, freqs, path, band, enough)
        self.known.add(found[0], found[2])
        return found

    def _design_now(self, it: int) -> tuple[str | None, Prefit | None]:
        """Why the run measures the local design now, or None (it verifies the next answer).

        Verifying alone must be the quicker way to the acceptance at the rate the split fell,
        priced on the bench clock (:func:`~sysid_core.measure.contraction.too_slow`); on a run
        that does not track the drift, the model of all sweeps must also reproduce the verified
        modes (:func:`~sysid_core.measure.lean.explained_gap`); with None, the fit of all sweeps.
        """
        if self.last_verified is None:
            return None, None
        (vb, vf), ctx = self.last_verified, self.ctx
        # the rate of two answers of models anchored on a window, not the first answer's: that
        # one carried the first design's law over the whole first step (contraction module)
        last, costs = self.splits[-2] if len(self.splits) > 1 else None, self._costs(it, vb)
        split, acceptance = float(vf[1] - vf[0]), ctx.config.tuning.acceptance_hz
        why, note = design_or_not(last, split, ctx.left(), acceptance, costs, self.low)
        if why:
            return why, None
        model, notes = ctx.fitter.fit(union := self.known.union())
        f = model.modal(vb[ctx.space.index]).frequencies_hz
        if ctx.tracking or (gap := explained_gap(f, vf)) is None:
            if note:  # a design the rate would have asked for, declined: say why
                ctx.say(f"iteration {it}: {note}")
            return None, (union, model, notes)
        n = len(self.known)
        return f"a model of all {n} sweeps misses the verified modes by {gap * 1e3:.3g} mHz", None

    def _costs(self, it: int, bias: np.ndarray) -> Costs | None:
        """A verification's and the local design's costs at ``bias`` (``contraction.Costs``).

        None where nothing prices them or there is no local design: the rate alone decides.
        """
        ctx, step = self.ctx, self.ctx.step(it)
        try:
            design, law = ctx.design(bias, it), ctx.config.model.stiffness
            todo = self.known.completing(
                bias, LOCAL_RADIUS * step, law, design, ctx.space.index, LEVEL_SHARE * step
            )
        except SysidError:
            return None
        return Costs.of(ctx.cost_s, self.verify_points, len(todo))

    def _reach(self, it: int, bias: np.ndarray, apart: float, todo: Sequence[int]) -> float:
        """The radius of the nearest sweeps that meet (6), if their fit is the cheaper way (or 0).

        The rate of the last two verified splits, priced against the ``todo`` sweeps of the local
        design, decides as in :meth:`_design_now`: while verifying is the quicker way, the answer
        of the sweeps that gave the last one (a design a few tenths of a volt away, the windows
        since) is verified next. Before a second verified split, the split located where the run
        started stands for the last. Only on a run that tracks the drift: its answers are
        anchored on the latest windows (``lean.explained_gap``).
        """
        first = self.known.first_split()
        splits = self.splits if len(self.splits) > 1 or first is None else [first, *self.splits]
        costs = Costs.of(self.ctx.cost_s, self.verify_points, len(todo))
        if len(splits) < 2 or not todo or costs is None or not self.ctx.tracking:
            return 0.0
        ctx, (last, split) = self.ctx, splits[-2:]
        if too_slow(last, split, ctx.left(), ctx.config.tuning.acceptance_hz, costs, self.low):
            return 0.0
        if reach := self.known.rank_reach(bias, ctx.config.model.stiffness, apart) or 0.0:
            ctx.say(
                f"iteration {it}: the split {'fell' if split < last else 'went'} from "
                f"{last * 1e3:.3g} to {split * 1e3:.3g} mHz; fitting the sweeps within "
                f"{reach:.3g} V of the bias, not the {len(todo)} of the local design they lack"
            )
        return reach

    def _cost(self, bias_change: bool) -> Callable[[int], float] | None:
        """What a sweep of so many points costs on the bench clock (None: nothing says)."""
        cost_s = self.ctx.cost_s
        return None if cost_s is None else (lambda n: cost_s(n, bias_change))

    def _learn(self, bias: np.ndarray, path: Path, first: np.ndarray | None = None) -> None:
        """Measure one identification experiment where its modes should be (``first``: here).

        The band, a scout, or around modes a law predicts the fewest points that show them, then
        a mode grid (:func:`~sysid_core.measure.lean.learning_grids`). One without both modes
        is followed by the locating bands (:mod:`sysid_core.measure.locating`), the first look
        at the band by a probe of a quarter of its points (``[experiment] probe``).
        """
        ctx, points = self.ctx, self.ctx.config.experiment.locate_points
        guess, scout = self.known.guess(bias, ctx.fitter.structure, ctx.fitter.model)
        plan = ctx.plan if guess is None else following(ctx.plan, guess)  # bands follow modes
        locating = self.locate_plan if plan is ctx.plan else locate_plan(plan, points)
        locate, grid = locating.band(), None
        if first is None and guess is None:
            first = locate
        elif first is None:
            assert guess is not None
            plans, cost = (ctx.plan, self.scout_plan), self._cost(True)
            cheap, grid = learning_grids(guess, scout, plans, self.quiet, cost)
            first = locate if cheap.size >= locate.size else cheap
        denser = denser_plan(locating, plan.resolution_hz).band()
        probe, probing = None, locate_plan(plan, probe_points(points))
        # the run's first look at the band, on a bench that may be quiet
        setting, caps = ctx.config.experiment.probe, ctx.bench.device.capabilities
        looked = first is locate and not len(self.known) and probe_first(setting, caps)
        if looked:
            probe = probing.band()
            probe = probe if probe.size < locate.size else None
        tries = [("-locate", locate), ("-locate4", denser), ("-band", plan.band())]
        if probe is None and self.probe_stood and first is not locate:
            tries.insert(0, ("-probe", probing.band()))  # the step that showed them: first
        if grid is not None and grid.size < locate.size:
            tries.insert(0, ("-grid", grid))  # the modes the law predicts, resolved
        if probe is None:
            tries.insert(0, ("", first))

        def sweep(freqs: np.ndarray, at: Path, band: bool) -> Found:
            return self.sweep(bias, freqs, at, band)

        before = len(self.known)
        quiet = locate_modes(sweep, ctx.say, path, tries, plan, denser.size, probe, looked)
        if looked:  # it decides the first design, the scouts' floor and their step
            self.quiet = quiet
            self.probe_stood = probe is not None and len(self.known) == before + 1
            self.scout_plan = probing if self.probe_stood else self.scout_plan  # its step
