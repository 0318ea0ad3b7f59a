"""Everything a run has measured, kept for every later fit and for guessing where modes are.

A lean run (``[experiment] protocol = "lean"``) never throws a measurement away: the fit of an
iteration uses the union of every sweep of the run (identification sweeps, verification
windows, whole-band sweeps), which meets the rank condition (6) as soon as the biases of all
of them together do, or, once a verification has shown that the stiffness law holds only
locally, the sweeps near the bias (:meth:`Knowledge.near`). Each sweep also left its own
estimate of the modes at its bias (from the single-bias fit that judged its evidence);
:meth:`Knowledge.guess` turns these and a model of the union into a
:class:`~sysid_core.measure.lean.ModeGuess` for a bias not measured yet.
"""

from __future__ import annotations

import copy
import functools
from collections.abc import Callable, Sequence
from dataclasses import dataclass

import numpy as np
import xarray as xr

from sysid_core.data.schema import (
    concat_experiments,
    point_times,
    requested_bias,
    squared_potentials,
)
from sysid_core.data.validation import check_rank_condition, design_rank
from sysid_core.errors import SysidError
from sysid_core.measure.evidence import WindowAssessment
from sysid_core.measure.lean import ModeGuess
from sysid_core.measure.motion import predicted_uncertainty, recentred
from sysid_core.model.fitted import FittedModel
from sysid_core.model.structures import ModelStructure
from sysid_core.tuning.criteria import TuningResult

__all__ = ["LEVEL_SHARE", "Knowledge", "Measured", "levels"]

#: Biases closer than this (volts) count as the same (a DAC applies the requested bias only to
#: within its step).
SAME_V = 1e-3

#: Where the sweeps near a bias stand in for a local design (:meth:`Knowledge.meets_rank`), an
#: electrode's biases closer than this share of the design's step are one level of it. The
#: law's slope from two levels ``δ`` apart has ``(h/δ)²`` times the variance it has from the
#: design's step ``h``: windows at DAC codes a few LSBs apart meet the rank condition (6) in
#: exact arithmetic and tell the law's slope next to nothing. At half a step, at most four
#: times the design's variance (docs/studies/local-law.md measures both on runs).
LEVEL_SHARE = 0.5

#: Fits a data set with a given structure (the run's objective and solver).
FitWith = Callable[[xr.Dataset, ModelStructure], FittedModel]


@dataclass(frozen=True)
class Measured:
    """One sweep of the run: its data (one experiment) and the modes its evidence located."""

    data: xr.Dataset
    modes: ModeGuess | None

    @functools.cached_property
    def bias(self) -> np.ndarray:
        """The bias it was requested at (every electrode, volts).

        Where the run has been is told by what it asked for; the fits use the bias the device
        reports it applied (a DAC's, or a bias law of its own), which is in the data.
        """
        return requested_bias(self.data)


class Knowledge:
    """The run's measurements, in order.

    Parameters
    ----------
    tuned : list of str
        The tuned electrodes (the model's electrodes).
    structure_potential : float
        ``v_gyro``, for the rank condition.
    """

    def __init__(self, tuned: Sequence[str], structure_potential: float) -> None:
        self.tuned = list(tuned)
        self.structure_potential = float(structure_potential)
        self.items: list[Measured] = []
        #: Every sweep of the run, also those :meth:`retune` set aside.
        self.every: list[Measured] = []
        #: Each sweep's applied bias on the tuned electrodes (what the rank condition reads).
        self.applied: list[np.ndarray] = []
        #: The epoch the sweeps added now belong to (the run's iteration): a fit with drift
        #: offsets gives each earlier epoch a stiffness offset of its own.
        self.epoch = 1

    def begin(self, epoch: int) -> None:
        """Sweeps added from now on belong to ``epoch`` (the run's iteration)."""
        self.epoch = epoch

    def add(self, sweep: xr.Dataset, evidence: WindowAssessment | None) -> None:
        """Keep ``sweep``, in the current :attr:`epoch`; its modes if ``evidence`` shows both."""
        modes = None
        if evidence is not None and evidence.ok:
            guess = ModeGuess.of(evidence.frequencies_hz, evidence.bandwidth_hz)
            modes = guess if guess.usable() else None
        epochs = np.full(sweep.sizes["experiment"], self.epoch, dtype=int)
        self.items.append(Measured(sweep.assign_coords(epoch=("experiment", epochs)), modes))
        self.every.append(self.items[-1])
        self.applied.append(np.asarray(sweep["bias"].sel(electrode=self.tuned).values, dtype=float))

    def retune(self, tuned: Sequence[str], bias: np.ndarray) -> None:
        """Tune ``tuned`` from now on, the other electrodes held at ``bias``.

        The sweeps that moved any other electrode away from ``bias`` are set aside: they stay
        on file, and no fit of the tuned electrodes can use them. Tuning every electrode again
        takes back every sweep, in the order measured.
        """
        names = [str(e) for e in self.every[0].data["electrode"].values] if self.every else []
        others = [k for k, e in enumerate(names) if e not in tuned]
        held = np.asarray(bias, dtype=float)[others]
        self.items = [
            m for m in self.every if self.same(np.asarray(m.bias, dtype=float)[others], held)
        ]
        self.tuned = list(tuned)
        self.applied = [
            np.asarray(m.data["bias"].sel(electrode=self.tuned).values, dtype=float)
            for m in self.items
        ]

    def unvaried(self) -> list[str]:
        """The tuned electrodes whose bias no kept sweep changed (none before two sweeps)."""
        if len(self.applied) < 2:
            return []
        spread = np.ptp(np.concatenate([np.atleast_2d(a) for a in self.applied]), axis=0)
        return [e for e, d in zip(self.tuned, spread, strict=True) if d <= SAME_V]

    def __len__(self) -> int:
        """The number of sweeps kept."""
        return len(self.items)

    def union(self) -> xr.Dataset:
        """Every sweep as one data set over the tuned electrodes."""
        return concat_experiments([m.data for m in self.items]).sel(electrode=self.tuned)

    @staticmethod
    def same(a: np.ndarray, b: np.ndarray) -> bool:
        """``a`` and ``b`` are one bias (within :data:`SAME_V`)."""
        return bool(np.allclose(a, b, rtol=0, atol=SAME_V))

    def has(self, bias: np.ndarray) -> bool:
        """Some sweep was measured at ``bias`` (within :data:`SAME_V`)."""
        return any(self.same(m.bias, bias) for m in self.items)

    def _near(self, bias: np.ndarray, radius: float) -> list[Measured]:
        return [m for m in self.items if self._within(m, bias, radius)]

    @staticmethod
    def _within(m: Measured, bias: np.ndarray, radius: float) -> bool:
        return float(np.max(np.abs(m.bias - bias))) <= radius + SAME_V

    def near(self, bias: np.ndarray, radius: float) -> xr.Dataset:
        """The sweeps within ``radius`` volts of ``bias`` (every electrode) as one data set.

        Every sweep if none is that near.
        """
        near = self._near(bias, radius) or self.items
        return concat_experiments([m.data for m in near]).sel(electrode=self.tuned)

    def meets_rank(self, bias: np.ndarray, radius: float, law: str, apart: float = SAME_V) -> bool:
        """The sweeps near ``bias`` meet the rank condition (6) for ``law``.

        ``"auto"`` asks for the quadratic law's rank (a two-sided design), so that the local
        fit can still choose. Each electrode's biases closer than ``apart`` volts count as one
        level (:func:`levels`; a local design passes :data:`LEVEL_SHARE` of its step).
        """
        near = [
            a
            for m, a in zip(self.items, self.applied, strict=True)
            if self._within(m, bias, radius)
        ]
        if not near:
            return False
        try:
            check_rank_condition(
                levels(np.concatenate(near), apart),
                self.structure_potential,
                self.tuned,
                quadratic=law != "linear",
            )
        except SysidError:
            return False
        return True

    def rank_reach(self, bias: np.ndarray, law: str, apart: float = SAME_V) -> float | None:
        """The smallest radius whose sweeps near ``bias`` meet (6) (:meth:`meets_rank`), or None.

        The radii tried are the sweeps' distances from ``bias`` (largest ``|Δv|``); more sweeps
        never lower the rank, so the first that meets it is found by bisection. None when every
        sweep together does not meet it.
        """
        radii = sorted({float(np.max(np.abs(m.bias - bias))) for m in self.items})
        if not radii or not self.meets_rank(bias, radii[-1], law, apart):
            return None
        lo, hi = -1, len(radii) - 1  # radii[hi] meets the rank; radii[lo] does not (-1: none)
        while hi - lo > 1:
            mid = (lo + hi) // 2
            if self.meets_rank(bias, radii[mid], law, apart):
                hi = mid
            else:
                lo = mid
        return radii[hi]

    def completing(
        self,
        bias: np.ndarray,
        radius: float,
        law: str,
        design: np.ndarray,
        index: Sequence[int],
        apart: float = SAME_V,
    ) -> list[int]:
        """The rows of ``design`` to measure so that the sweeps near ``bias`` meet (6).

        What :meth:`meets_rank` asks for, reached greedily with few new sweeps: the rows are taken
        in order, each only if it raises the rank of the sweeps near ``bias`` and the rows
        taken before it, until the rank is full. A sweep measured a few tenths of a volt away
        tells the local law what a new one at the design's bias would; only what the near
        sweeps lack is measured. ``index``: the tuned electrodes' columns of ``design`` (and of
        every sweep's requested bias); ``apart``: as in :meth:`meets_rank`.
        """
        vg, quadratic = self.structure_potential, law != "linear"
        # requested biases on both sides (a DAC's few LSBs would count as levels of their own),
        # each electrode's within ``apart`` of each other one level
        rows = [m.bias[list(index)][None, :] for m in self._near(bias, radius)]
        need = (2 if quadratic else 1) * len(self.tuned) + 1
        rank = design_rank(levels(np.concatenate(rows), apart), vg, quadratic) if rows else 0
        taken: list[int] = []
        for j, b in enumerate(design):
            if rank >= need:
                break
            if self.has(b):
                continue
            trial = np.concatenate([*rows, np.asarray(b, dtype=float)[list(index)][None, :]])
            if (r := design_rank(levels(trial, apart), vg, quadratic)) > rank:
                rows, rank = [trial], r
                taken.append(j)
        return taken

    def first_split(self) -> float | None:
        """The split of the run's first sweep that located the modes (Hz), or None."""
        return next((m.modes.split_hz for m in self.every if m.modes is not None), None)

    def latest(self) -> Measured | None:
        """The latest sweep with located modes, or None."""
        located = [m for m in self.items if m.modes is not None]
        return located[-1] if located else None

    def centre(
        self,
        bias: np.ndarray,
        index: Sequence[int] | np.ndarray,
        predicted: TuningResult,
        model: FittedModel,
        settle_s: float,
        ppm_per_h: float,
    ) -> tuple[float, float]:
        """Where to centre a window around ``predicted``'s modes, and their uncertainty (Hz).

        :func:`~sysid_core.measure.motion.recentred` from the :meth:`latest` located modes, moved
        by ``model`` from that sweep's bias to ``bias`` (``index``: the tuned electrodes'
        positions); aged from its first time stamp to the latest one of the run plus
        ``settle_s``, moving at ``ppm_per_h``. The answer's own without located modes.
        """
        ref = self.latest()
        if ref is None or ref.modes is None:
            return predicted.frequency_hz, predicted_uncertainty(predicted)
        try:
            there = model.modal(ref.bias[index]).frequencies_hz
            here = model.modal(bias[index]).frequencies_hz
        except SysidError:  # no modes where the latest sweep was: the answer alone
            return predicted.frequency_hz, predicted_uncertainty(predicted)
        ends = [t for m in self.items if (t := point_times(m.data, 0)) is not None and t.size]
        seen = point_times(ref.data, 0)
        age = 0.0
        if ends and seen is not None and seen.size:
            age = max(float(t.max()) for t in ends) - float(seen.min()) + settle_s
        moved = float(np.mean(here) - np.mean(there))
        latest = float(np.mean(ref.modes.frequencies_hz))
        return recentred(predicted, moved, latest, age, ppm_per_h)

    def nearest(self, bias: np.ndarray) -> Measured | None:
        """The sweep with located modes whose bias is closest to ``bias`` (largest |Δv|)."""
        located = [m for m in self.items if m.modes is not None]
        if not located:
            return None
        return min(located, key=lambda m: float(np.max(np.abs(m.bias - bias), initial=0.0)))

    def guess(
        self, bias: np.ndarray, structure: ModelStructure, fit_with: FitWith
    ) -> tuple[ModeGuess | None, bool]:
        """What is known of the modes at ``bias`` (every electrode): ``(guess, scout)``.

        * ``(None, False)``: nothing is known (no sweep located the modes);
        * ``(guess, True)``: ``bias`` steps an electrode that no sweep has varied, so the
          modes may have moved by an unknown amount: ``guess`` is the nearest sweep's modes;
        * ``(guess, False)``: a model of every sweep so far (the linear stiffness law over the
          electrodes they vary) predicts the modes, with
          :data:`~sysid_core.measure.motion.PREDICTION_ERROR` of the predicted move as uncertainty.
        """
        ref = self.nearest(bias)
        if ref is None or ref.modes is None:
            return None, False
        if self.same(ref.bias, bias):
            return ref.modes, False
        biases = np.array([m.bias for m in self.items])
        names = [str(e) for e in self.items[0].data["electrode"].values]
        varied = [
            names[p]
            for p in range(biases.shape[1])
            if np.ptp(biases[:, p]) > SAME_V and names[p] in self.tuned
        ]
        steps = [names[p] for p in range(biases.shape[1]) if abs(bias[p] - ref.bias[p]) > SAME_V]
        if not set(steps) <= set(varied):
            return self._scout(bias, ref), True
        data = concat_experiments([m.data for m in self.items]).sel(electrode=varied)
        try:
            check_rank_condition(np.asarray(data["bias"].values), self.structure_potential, varied)
            linear = copy.copy(structure)
            linear.stiffness = "linear"
            model = fit_with(data, linear)
            rep = model.modal([bias[names.index(e)] for e in varied])
        except SysidError:
            return self._scout(bias, ref), True
        predicted = ModeGuess.of(rep.frequencies_hz, rep.bandwidth_hz)
        if not predicted.usable():
            return self._scout(bias, ref), True
        return predicted.moved_from(ref.modes), False

    def _scout(self, bias: np.ndarray, ref: Measured) -> ModeGuess:
        """``ref``'s modes, uncertain by 3 × the largest move per volt² seen so far.

        The rate is the largest ``|Δf| / |Δw|`` between two sweeps with located modes that
        differ in one electrode; electrodes of one gyro are alike, so it bounds the move of an
        electrode not stepped yet. Without such a pair the uncertainty is 0 and
        :func:`~sysid_core.measure.lean.scout_grid` falls back to the modes' split.
        """
        assert ref.modes is not None
        vg = self.structure_potential
        located = [m for m in self.items if m.modes is not None]
        rate = 0.0
        for i, a in enumerate(located):
            for b in located[i + 1 :]:
                d = np.abs(a.bias - b.bias) > SAME_V
                if d.sum() != 1:
                    continue
                p = int(np.flatnonzero(d)[0])
                dw = abs(squared_potentials(vg, a.bias[p]) - squared_potentials(vg, b.bias[p]))
                assert a.modes is not None and b.modes is not None
                move = float(np.max(np.abs(a.modes.frequencies_hz - b.modes.frequencies_hz)))
                rate = max(rate, move / dw)
        dw_new = float(
            np.max(np.abs(squared_potentials(vg, bias) - squared_potentials(vg, ref.bias)))
        )
        return ModeGuess(
            ref.modes.frequencies_hz, ref.modes.bandwidth_hz, np.full(2, 3 * rate * dw_new)
        )


def levels(biases: np.ndarray, apart: float = SAME_V) -> np.ndarray:
    """``biases`` (one row a sweep) with each electrode's values gathered into levels.

    Column by column, in ascending order, a value within ``apart`` volts of the first of its
    level joins it and takes that level's mean; the rows come back in their order. Biases a
    DAC's few LSBs apart (``apart`` = :data:`SAME_V`), or a small share of a design's step,
    are then one level of the rank condition (6), which the column scaling of
    :func:`~sysid_core.data.validation.design_rank` would otherwise count as apart as any.
    """
    rows = np.array(biases, dtype=float, ndmin=2)
    out = rows.copy()
    for p in range(rows.shape[1]):
        order = np.argsort(rows[:, p], kind="stable")
        start = 0
        for k in range(1, order.size + 1):
            if k == order.size or rows[order[k], p] - rows[order[start], p] > apart:
                group = order[start:k]
                out[group, p] = rows[group, p].mean()
                start = k
    return out
