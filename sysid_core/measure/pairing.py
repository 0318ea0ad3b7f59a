"""Which two electrodes a degenerate tuning needs: the pair that reaches it with the least voltage.

Degenerate modes are two equations, the two components of the split vector (the traceless part
of ``M^{-1/2} K M^{-1/2}``), so two electrodes whose stiffness acts along different axes can
meet them. Every further electrode tuned costs its own experiments in every design (two per
electrode in a two-sided design, eq. (18)) and adds nothing the answer needs: on random gyros
of 2-6 electrodes the designs of a run tuning all of them took twice the bench time of one
tuning the first two, for the same result (docs/studies/dwells.md, "A pair of electrodes,
chosen by the run").

So a lean run given more than two electrodes for the degenerate criterion first steps them once
each, in turn (the linear law's rank condition, ``n + 1`` sweeps), fits that law, and asks each pair
``(a, b)`` for its exact degenerate bias with the other electrodes where they are
(:func:`~sysid_core.model.modal.degenerate_w`; of the two roots ``v_gyro ± √w`` of each
electrode, the one nearer its bias inside the limits). :func:`least_voltage_pair` returns the
pair whose bias lies inside the limits with the smallest largest step from the current bias: the
shortest extrapolation of the law it was fitted with. From the third electrode stepped (three
pairs: a choice of axes), the least-voltage pair of those stepped, if one lies inside the
limits, ends the stepping (:func:`choose_pair`, :func:`pair_of_stepped`): a further scout costs
a bias change and its acquisitions in every run, and the shorter step its pair might offer
saved fewer (on random gyros with one tone, the median run 114 → 98 dwells; stepping only two
offers one pair, whose axes may lie close, and lengthened 9 of 24 fresh runs:
docs/studies/dwells.md, "Scouts until three electrodes offer a pair"). The run then tunes that
pair; the other electrodes stay at their bias. No pair inside the limits: every electrode stays
tuned.

The first sweeps' law can be wrong about a pair far from where it was measured, and two
electrodes offer the DAC's codes on a coarser lattice than more do. So a pair whose answer is
beyond its reach (its model finds the goal out of reach inside the limits, or the DAC's best
code near the answer leaves more than the acceptance:
:func:`~sysid_core.verdict.dacfloor.beyond_reach`) gives way: the sweeps that stepped the
others count again, and those never stepped are stepped once where the run is. Out of reach,
the linear law of every sweep chooses again among the pairs that have not given way (``exclude``
of :func:`least_voltage_pair`); the DAC's codes, or no pair left, and every electrode is tuned
(:class:`~sysid_core.run.electrodes.Electrodes`).
"""

from __future__ import annotations

import dataclasses
import itertools
from collections.abc import Callable, Collection
from dataclasses import dataclass

import numpy as np

from sysid_core.data.schema import squared_potentials
from sysid_core.model.fitted import FittedModel
from sysid_core.model.modal import degenerate_w
from sysid_core.tuning.criteria import BiasSpace

__all__ = ["Pair", "choose_pair", "least_voltage_pair", "pair_bias", "pair_of_stepped"]


@dataclass(frozen=True)
class Pair:
    """The chosen pair: its electrodes, their degenerate bias by the law, and the step there.

    Attributes
    ----------
    electrodes : tuple of str
        The two electrodes, in the model's order.
    bias : ndarray
        Their bias (volts) that the fitted law makes degenerate.
    step_v : float
        The largest change of the two from their current bias (volts).
    unstepped : tuple of str
        The electrodes never stepped: the pair was chosen before them (:func:`pair_of_stepped`).
    """

    electrodes: tuple[str, str]
    bias: np.ndarray
    step_v: float
    unstepped: tuple[str, ...] = ()

    def describe(self, among: list[str], law: str = "the first sweeps'") -> str:
        """One line for the progress (``law``: whose law chose the pair)."""
        a, b = self.electrodes
        line = (
            f"tuning {a} and {b} of {', '.join(among)}: the pair whose degenerate bias by "
            f"{law} law ({self.bias[0]:.3f}, {self.bias[1]:.3f} V) lies the least "
            f"from the current bias ({self.step_v:.3g} V); the others stay where they are"
        )
        if self.unstepped:
            line += (
                f" ({', '.join(self.unstepped)} not stepped: this pair of the first three "
                "stepped reaches degenerate modes inside the limits)"
            )
        return line


def least_voltage_pair(
    model: FittedModel,
    bias: np.ndarray,
    limits: tuple[float, float],
    structure_potential: float,
    exclude: Collection[frozenset[str]] = (),
) -> Pair | None:
    """The pair of ``model``'s electrodes that reaches degenerate modes with the smallest step.

    Parameters
    ----------
    model : FittedModel
        A model of the linear law over every candidate electrode (``model.Kp``, one per
        electrode in ``model.electrodes``).
    bias : ndarray
        The candidates' current bias (volts), in the model's order.
    limits : tuple of float
        The device's bias limits (volts).
    structure_potential : float
        ``v_gyro`` (volts).
    exclude : collection of frozenset of str
        Pairs not to choose (pairs that gave way).

    Returns
    -------
    Pair or None
        None when no pair has a degenerate bias inside the limits (or the model has two
        electrodes or fewer).
    """
    names = [str(e) for e in model.electrodes]
    kp = [np.asarray(k, dtype=float) for k in model.Kp]
    if len(names) <= 2 or len(kp) != len(names):
        return None
    bias = np.asarray(bias, dtype=float)
    w = squared_potentials(structure_potential, bias)
    best: Pair | None = None
    for a, b in itertools.combinations(range(len(names)), 2):
        if frozenset((names[a], names[b])) in exclude:
            continue
        pair = _pair(model, (a, b), bias, w, structure_potential, limits)
        if pair is not None and (best is None or pair.step_v < best.step_v):
            best = pair
    return best


def pair_bias(
    model: FittedModel, bias: np.ndarray, limits: tuple[float, float], structure_potential: float
) -> np.ndarray | None:
    """The bias of a two-electrode ``model`` that its law makes degenerate, or None.

    Of each electrode's two roots, the one nearer ``bias`` inside ``limits`` (as a pair's).
    None when the model does not have two electrodes or no such bias lies inside the limits.
    """
    if len(model.electrodes) != 2 or len(model.Kp) != 2:
        return None
    w = squared_potentials(structure_potential, np.asarray(bias, dtype=float))
    pair = _pair(model, (0, 1), np.asarray(bias, dtype=float), w, structure_potential, limits)
    return None if pair is None else pair.bias


def _pair(
    model: FittedModel,
    ab: tuple[int, int],
    bias: np.ndarray,
    w: np.ndarray,
    structure_potential: float,
    limits: tuple[float, float],
) -> Pair | None:
    """Electrodes ``ab`` of ``model`` with their degenerate bias inside ``limits``, or None."""
    names, kp = [str(e) for e in model.electrodes], [np.asarray(k, float) for k in model.Kp]
    (a, b), (low, high) = ab, limits
    base = np.asarray(model.K0, dtype=float) + sum(
        w[p] * kp[p] for p in range(len(names)) if p not in ab
    )
    try:
        wa, wb, _ = degenerate_w(base, kp[a], kp[b], np.asarray(model.M, dtype=float))
    except np.linalg.LinAlgError:
        return None  # the pair's stiffnesses and the mass are linearly dependent
    v = [_root(wp, bias[p], structure_potential, low, high) for wp, p in ((wa, a), (wb, b))]
    if v[0] is None or v[1] is None:
        return None
    step = float(max(abs(v[0] - bias[a]), abs(v[1] - bias[b])))
    return Pair((names[a], names[b]), np.array(v, dtype=float), step)


def pair_of_stepped(
    model: FittedModel, bias: np.ndarray, space: BiasSpace, unstepped: list[str]
) -> Pair | None:
    """The least-voltage pair of the electrodes stepped so far, or None.

    ``model``: the linear law of those electrodes (three or more), stepped from ``bias``
    (theirs, in the model's order); ``unstepped``: the others, which the pair leaves unstepped.
    None when no pair of them reaches degenerate modes inside the limits (stepping goes on).
    """
    pair = least_voltage_pair(model, bias, space.limits, space.structure_potential)
    return None if pair is None else dataclasses.replace(pair, unstepped=tuple(unstepped))


def choose_pair(
    tuned: list[str],
    rows: np.ndarray,
    learn: Callable[[np.ndarray, str], None],
    fit: Callable[[list[str]], FittedModel],
    bias: np.ndarray,
    space: BiasSpace,
) -> Pair | None:
    """Step the electrodes in turn and choose the pair to tune (see the module).

    ``rows``: the bias that steps each of ``tuned`` from ``bias`` (theirs), which
    ``learn(row, name)`` measures; ``fit(names)``: the linear law of ``names`` from every sweep
    so far. From the third electrode stepped (three pairs to choose from), a pair of those
    inside the limits (:func:`pair_of_stepped`) ends the stepping; else, once all are stepped,
    the pair of least voltage, or None.
    """
    for k, (row, name) in enumerate(zip(rows, tuned, strict=True), start=1):
        learn(row, name)
        if 3 <= k < len(tuned) and (
            pair := pair_of_stepped(fit(tuned[:k]), bias[:k], space, tuned[k:])
        ):
            return pair
    return least_voltage_pair(fit(tuned), bias, space.limits, space.structure_potential)


def _root(
    w: float, now: float, structure_potential: float, low: float, high: float
) -> float | None:
    """The bias ``v_gyro ± √w`` nearest ``now`` inside ``[low, high]``, or None."""
    if not np.isfinite(w) or w < 0.0:
        return None
    roots = [structure_potential + s * float(np.sqrt(w)) for s in (-1.0, 1.0)]
    inside = [r for r in roots if low <= r <= high]
    return min(inside, key=lambda r: abs(r - now)) if inside else None
