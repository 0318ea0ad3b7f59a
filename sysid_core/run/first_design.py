"""The second steps of a lean run's first design: toward the answer of its first steps.

A two-sided first design (eq. (18)) steps each tuned electrode up and then down by
``[experiment] bias_step`` from the start, and the first answer is the law fitted on those
sweeps carried to wherever the answer lies, often several steps away, where a law chosen on a
volt's span may miss by hundreds of millihertz. The law is a function of ``w = (v - v_gyro)²``
(:mod:`sysid_core.model.structures`). A pair chosen among more electrodes
(:class:`~sysid_core.run.electrodes.Electrodes`) has measured the start and each electrode's
first step already, as its scouts: ``n + 1`` sweeps that meet the linear law's rank condition
(6) and place the answer. So its second steps go there: the run places the degenerate bias by
their linear law (:func:`~sysid_core.measure.pairing.pair_bias`) with its 95 % interval, and an
electrode whose whole interval lies beyond the design's span takes its second step at the answer
(:func:`~sysid_core.measure.sweeps.second_side`): the law fitted on the whole design then spans
the ``w`` the answer needs, with the same number of sweeps. Elsewhere the step down stays.

A run given two electrodes keeps eq. (18)'s order (each electrode up, then down): measuring
both first steps first parts an electrode's two steps in time, and on a bench written outside
the toolkit the four two-electrode runs whose only change was that order all took longer, by
13-29 dwells, the drift between the steps in the law (``docs/studies/first-design.md``).
"""

from __future__ import annotations

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
    ctx: RunContext, known: Knowledge, bias: np.ndarray, design: np.ndarray
) -> np.ndarray:
    """The first design with its second steps placed (see the module)."""
    sp = ctx.space
    two_sided = len(design) == 2 * len(sp.index) + 1
    if len(sp.index) != 2 or not two_sided or ctx.config.tuning.criterion != "degenerate":
        return design
    if not all(known.has(row) for row in design[1::2]):  # no scouts: eq. (18)'s order
        return design
    s, answer, region = ctx.fitter.structure, None, None
    try:
        model = ctx.fitter.fit(known.union(), type(s)(s.order, s.bias_terms, "linear"))[0]
        answer = pair_bias(model, bias[sp.index], sp.limits, sp.structure_potential)
        region = None if answer is None else _region(model, answer, bias, sp)
    except SysidError:  # no law of the first steps: the design as it was
        pass
    answer = None if region is None else answer  # no interval: not known to lie beyond
    placed = second_side(design, sp.index, answer, ctx.step(1), region)
    moved = [
        k
        for k in range(len(sp.index))
        if placed[2 * k + 2, sp.index[k]] != design[2 * k + 2, sp.index[k]]
    ]
    if moved and answer is not None:
        at = ", ".join(f"{sp.tuned[k]} at {answer[k]:.3f} V" for k in moved)
        ctx.say(
            f"iteration 1: second design step{'s' if len(moved) > 1 else ''} at the scouts' "
            f"answer ({at}): its 95 % interval lies beyond the {ctx.step(1):g} V step"
        )
    return placed


def _region(
    model: FittedModel, answer: np.ndarray, bias: np.ndarray, sp: BiasSpace
) -> np.ndarray | None:
    """The 95 % interval of each electrode of ``answer`` by ``model``'s covariance, or None.

    None where the fit states no covariance (a ``minimax`` fit): the second steps then stay.
    """
    pair = BiasSpace(
        list(sp.tuned), list(sp.tuned), bias[sp.index], sp.limits, sp.structure_potential
    )
    w = squared_potentials(sp.structure_potential, answer)
    result = TuningResult(answer, w, np.zeros(2), 0.0, "degenerate", 0.0)
    region = confidence_region(model, result, pair)
    return None if region is None else np.asarray(region.bias_ci, dtype=float)
