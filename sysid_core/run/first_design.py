"""The second steps of a lean run's first design: toward the answer of its first steps.

A two-sided first design (eq. (18)) steps each tuned electrode up and then down by
``[experiment] bias_step`` from the start, and the first answer is the law fitted on those
sweeps carried to wherever the answer lies, often several steps away, where a law chosen on a
volt's span may miss by hundreds of millihertz. The law is a function of ``w = (v - v_gyro)²``
(:mod:`sysid_core.model.structures`); the start and the first steps (``n + 1`` sweeps) already
meet the linear law's rank condition (6) and place the answer. So for a degenerate pair the run
measures the first steps first, places the degenerate bias by their linear law
(:func:`~sysid_core.measure.pairing.pair_bias`), and takes each electrode's second step there
where it lies beyond the design's span (:func:`~sysid_core.measure.sweeps.second_side`): the
law fitted on the whole design then spans the ``w`` the answer needs, with the same number of
sweeps. Where the answer lies inside the span, or no answer is found, the step down stays.

The first steps are measured first, before any second one. A pair chosen among more electrodes
has measured them already, as its scouts; a run given two electrodes would measure them in
another order than eq. (18)'s, and on a bench with a clock (time stamps: a gyro that drifts
while it is measured) it does not: each electrode's two steps stay back to back, the drift
between them small. On four two-electrode gyros of a bench written outside the toolkit, where
only the order changed, the runs took 13-29 dwells longer (``docs/studies/first-design.md``).
"""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path

import numpy as np

from sysid_core.data.schema import squared_potentials
from sysid_core.errors import SysidError
from sysid_core.measure.knowledge import Knowledge
from sysid_core.measure.pairing import pair_bias
from sysid_core.measure.sweeps import second_side
from sysid_core.model.fitted import FittedModel
from sysid_core.run.context import RunContext
from sysid_core.tuning.confidence import confidence_region
from sysid_core.tuning.criteria import BiasSpace, TuningResult

__all__ = ["toward_answer"]


def toward_answer(
    ctx: RunContext,
    known: Knowledge,
    learn: Callable[[np.ndarray, Path], None],
    bias: np.ndarray,
    design: np.ndarray,
    folder: Path,
) -> tuple[np.ndarray, list[int]]:
    """Measure the first steps of ``design``, then place its second ones (see the module).

    Parameters
    ----------
    ctx : RunContext
        The run (its tuned electrodes, limits, criterion, fitter and step).
    known : Knowledge
        The run's sweeps; the start's is among them.
    learn : callable
        Measures an identification experiment: ``learn(bias, path)``.
    bias : ndarray
        The start (every electrode).
    design : ndarray
        The first design's rows (:meth:`RunContext.design`).
    folder : Path
        Where the sweeps go (``exp<row>.nc``).

    Returns
    -------
    tuple
        The design, its second steps placed where they go, and its rows not measured yet.
    """
    sp, todo = ctx.space, [j for j in range(len(design)) if not known.has(design[j])]
    two_sided = len(design) == 2 * len(sp.index) + 1
    if len(sp.index) != 2 or not two_sided or ctx.config.tuning.criterion != "degenerate":
        return design, todo
    first = [j for j in todo if j % 2]  # the first steps (rows 1 and 3) not measured as scouts
    if first and ctx.bench.clock_span_s is not None:  # time passes: its steps back to back
        return design, todo
    for j in first:
        learn(design[j], folder / f"exp{j}.nc")
    s, answer, region = ctx.fitter.structure, None, None
    try:
        model = ctx.fitter.fit(known.union(), type(s)(s.order, s.bias_terms, "linear"))[0]
        answer = pair_bias(model, bias[sp.index], sp.limits, sp.structure_potential)
        region = None if answer is None else _region(model, answer, bias, sp)
    except SysidError:  # no law of the first steps: the design as it was
        pass
    design = second_side(design, sp.index, answer, ctx.step(1), region)
    return design, [j for j in todo if not known.has(design[j])]


def _region(
    model: FittedModel, answer: np.ndarray, bias: np.ndarray, sp: BiasSpace
) -> np.ndarray | None:
    """The 95 % interval of each electrode of ``answer`` by ``model``'s covariance, or None.

    None where the fit states no covariance: then the answer alone decides.
    """
    pair = BiasSpace(
        list(sp.tuned), list(sp.tuned), bias[sp.index], sp.limits, sp.structure_potential
    )
    w = squared_potentials(sp.structure_potential, answer)
    result = TuningResult(answer, w, np.zeros(2), 0.0, "degenerate", 0.0)
    region = confidence_region(model, result, pair)
    return None if region is None else np.asarray(region.bias_ci, dtype=float)
