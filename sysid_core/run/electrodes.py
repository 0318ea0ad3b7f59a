"""Which electrodes a lean run tunes: a pair chosen by the first steps, or every one.

For degenerate modes with more than two electrodes and ``[tuning] pair = true``, the first
iteration steps the electrodes in turn and tunes the pair that reaches degenerate modes with the
least voltage (:func:`sysid_core.measure.pairing.choose_pair`: stepping stops once three
electrodes stepped offer a pair that does so inside the limits). A pair whose answer is beyond
its reach gives way (:meth:`Electrodes.give_way`): the electrodes never stepped are then stepped
once where the run is (:meth:`Electrodes.complete`), as the first ones were. If its model found
the goal out of reach inside the limits, the linear law of every sweep then chooses again among
the pairs that have not given way (:meth:`Electrodes.rechoose`); a pair chosen before every
electrode was stepped saw three of them, by a law fitted on a volt. Where no pair remains, or
the pair gave way to the DAC's codes (a lattice that more electrodes make finer), every
electrode is tuned.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from pathlib import Path
from typing import Any

import numpy as np

from sysid_core.measure.knowledge import Knowledge
from sysid_core.measure.pairing import choose_pair, least_voltage_pair
from sysid_core.measure.sweeps import design_experiments
from sysid_core.model.fitted import FittedModel
from sysid_core.run.context import RunContext
from sysid_core.verdict.dacfloor import beyond_reach

__all__ = ["Electrodes"]

#: Measure one identification experiment at a bias, saved to a path.
Learn = Callable[[np.ndarray, Path], None]


class Electrodes:
    """The tuned electrodes of a lean run (see the module).

    Parameters
    ----------
    ctx : RunContext
        The run's shared parts (its bias space is retuned here).
    known : Knowledge
        The run's sweeps (retuned with it).
    learn : callable
        Measures an identification experiment: ``learn(bias, path)``.
    """

    def __init__(self, ctx: RunContext, known: Knowledge, learn: Learn) -> None:
        self.ctx, self.known, self.learn = ctx, known, learn
        #: Every configured electrode while the run tunes a pair of them (else None).
        self.offered: list[str] | None = None
        #: Where the pair was chosen, and where every electrode was offered again if that is
        #: where the run still is (its design is the first one's).
        self.paired_at: np.ndarray | None = None
        self.regrown_at: np.ndarray | None = None
        #: The pairs that gave way, and whether the next iteration chooses again among the rest.
        self.failed: set[frozenset[str]] = set()
        self.again = False

    def regrown(self, bias: np.ndarray) -> bool:
        """Every electrode was offered again at ``bias``, where the first design was."""
        return self.regrown_at is not None and self.known.same(bias, self.regrown_at)

    def choose(self, bias: np.ndarray, folder: Path) -> None:
        """Step the electrodes in turn and tune the pair chosen, if one (see the module)."""
        ctx = self.ctx
        tuned, tuning, sp = list(ctx.space.tuned), ctx.config.tuning, ctx.space
        if not (tuning.pair and tuning.criterion == "degenerate" and len(tuned) > 2):
            return
        rows = design_experiments(bias, sp.index, ctx.step(1), sp.limits)[1:]

        def fit(names: list[str]) -> FittedModel:
            return ctx.fitter.fit(self.known.union().sel(electrode=names))[0]

        pair = choose_pair(tuned, rows, self._step(folder), fit, bias[sp.index], sp)
        if pair is None:
            ctx.say(
                "iteration 1: by the first sweeps' law no pair of the electrodes reaches "
                "degenerate modes inside the limits; tuning all of them"
            )
            return
        ctx.say(f"iteration 1: {pair.describe(tuned)}")
        self.offered, self.paired_at = tuned, bias.copy()
        ctx.retune(list(pair.electrodes))
        self.known.retune(pair.electrodes, bias)

    def give_way(self, info: Mapping[str, Any] | None, bias: np.ndarray) -> None:
        """Offer every electrode again if the pair's answer (``info``) is beyond its reach.

        Out of reach inside the limits (the next iteration chooses again among the other
        pairs: :meth:`rechoose`), or the DAC's best code leaving more than the acceptance
        (every electrode is tuned from now on): :func:`~sysid_core.verdict.dacfloor.beyond_reach`.
        Every sweep set aside counts again.
        """
        if self.offered is None:
            return
        why = beyond_reach(info or {}, self.ctx.config.tuning.acceptance_hz)
        if why is None:
            return
        every, pair, self.offered = self.offered, self.ctx.space.tuned, None
        self.failed.add(frozenset(pair))
        self.again = "unreachable" in (info or {})
        then = (
            "choosing again among the other pairs by the law of every sweep"
            if self.again
            else f"tuning every electrode ({', '.join(every)}) from now on"
        )
        self.ctx.say(f"the pair {' and '.join(pair)} cannot meet the goal: {why}; {then}")
        self.ctx.retune(every)
        self.known.retune(every, bias)
        self.regrown_at = self.paired_at

    def complete(self, bias: np.ndarray, folder: Path, moved: bool = False) -> None:
        """Step once, from ``bias``, each tuned electrode no kept sweep varied.

        The electrodes a pair was chosen before, once it gave way: by the first design's step,
        as the first ones were, so that the fit of every sweep holds each electrode's law. Not
        where the run ``moved`` (its local design steps them all) unless it chooses again.
        """
        sp, lacking = self.ctx.space, [] if moved and not self.again else self.known.unvaried()
        if lacking:
            index = [sp.electrodes.index(e) for e in lacking]
            rows = design_experiments(bias, index, self.ctx.step(1), sp.limits)[1:]
            step = self._step(folder)
            for row, name in zip(rows, lacking, strict=True):
                step(row, name)
        if self.again:
            self.rechoose(bias)

    def rechoose(self, bias: np.ndarray) -> None:
        """Tune the pair that reaches degenerate modes with the least voltage by every sweep.

        The linear law of every sweep so far, of every electrode; the pairs that gave way are
        not chosen again. None left inside the limits: every electrode stays tuned.
        """
        self.again = False
        ctx, sp = self.ctx, self.ctx.space
        every, s = list(sp.tuned), ctx.fitter.structure
        linear = type(s)(s.order, s.bias_terms, "linear")
        model = ctx.fitter.fit(self.known.union(), linear)[0]
        pair = least_voltage_pair(
            model, bias[sp.index], sp.limits, sp.structure_potential, exclude=self.failed
        )
        if pair is None:
            ctx.say("no other pair reaches degenerate modes inside the limits; tuning every one")
            return
        ctx.say(pair.describe(every, "every sweep's"))
        self.offered, self.paired_at = every, bias.copy()
        ctx.retune(list(pair.electrodes))
        self.known.retune(pair.electrodes, bias)

    def _step(self, folder: Path) -> Callable[[np.ndarray, str], None]:
        """Measure ``row``, the step of electrode ``name``, unless a sweep there is kept."""

        def step(row: np.ndarray, name: str) -> None:
            if not self.known.has(row):
                self.learn(row, folder / f"exp-{name}.nc")

        return step
