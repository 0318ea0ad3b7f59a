"""Step 3 of a run: from a fitted model to the bias applied next, in one place.

:func:`answer` solves the criterion (a quadratic law by repeated linearization), continues from
the best reachable bias when the model's "unreachable" may be its extrapolation or its noise
(:func:`~sysid_core.verdict.unreachable.best_effort`), moves the
answer to the DAC code the model predicts best, does not apply an answer the run's measurements
do not support (:mod:`sysid_core.verdict.trust`), checks the bias against the device's limits and
attaches the answer's confidence region.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from sysid_core.device.measuring import GuardedDevice, applied_bias, check_bias
from sysid_core.drift.tracker import NEAR_ACCEPTANCES
from sysid_core.errors import UnreachableTuningError
from sysid_core.model.fitted import FittedModel
from sysid_core.tuning.confidence import confidence_region
from sysid_core.tuning.criteria import (
    BiasSpace,
    TuningCriterion,
    TuningResult,
    solve_criterion,
)
from sysid_core.verdict.dac import apply_best_code
from sysid_core.verdict.dacfloor import DAC_FLOOR_SHARE, dac_floor
from sysid_core.verdict.trust import (
    beyond_tuning,
    trust_radius,
    untrusted_step,
    worse_than_measured,
)
from sysid_core.verdict.unreachable import best_effort, result_at

__all__ = ["Answer", "answer", "reach_with"]


@dataclass(frozen=True)
class Answer:
    """An iteration's answer: what is applied and what it came from.

    Attributes
    ----------
    result : TuningResult
        The criterion's answer at the bias that will be applied (the DAC code the model
        predicts best), with its confidence region.
    bias : ndarray
        Every electrode's bias to apply next, checked against the device's limits.
    moved : bool
        The answer is a move to the best reachable bias (the model found its goal
        unreachable; a model identified there decides).
    model : FittedModel or None
        The model it was solved from.
    """

    result: TuningResult
    bias: np.ndarray
    moved: bool
    model: FittedModel | None = None


def answer(
    criterion: TuningCriterion,
    model: FittedModel,
    space: BiasSpace,
    device: GuardedDevice,
    it: int,
    *,
    bias_step: float,
    last_iteration: bool,
    say: Callable[[str], None],
    every_sweep: Callable[[], FittedModel | None] | None = None,
    acceptance_hz: float | None = None,
    least_measured: tuple[float, np.ndarray] | None = None,
    latest_measured: tuple[float, np.ndarray] | None = None,
    near_acceptances: float = NEAR_ACCEPTANCES,
    local_step: float | None = None,
    local_fit: bool = False,
    reoffer: bool = False,
    linearised: tuple[dict[str, float] | None, float | None] = (None, None),
) -> Answer:
    """The answer of iteration ``it`` (see the module).

    If ``model`` finds the goal unreachable and ``every_sweep()`` gives a model of every sweep
    of the run (None when ``model`` already is one), that model answers if it reaches the goal
    (:func:`reach_with`); otherwise :func:`best_effort` decides, told the least split a
    verification of the run measured and its bias (``least_measured``). With
    ``acceptance_hz``, an answer whose DAC code leaves a sizeable share of it is said
    (:func:`~sysid_core.verdict.dacfloor.dac_floor`). An answer the run's measurements do not
    support is not applied (:mod:`sysid_core.verdict.trust`): the run goes back to the least
    measured split's bias, or takes the linearised step from the latest verified bias
    (``latest_measured``), no longer than the local design's step (``local_step``, else
    ``bias_step``) at first, then as far as the trust region reaches
    (:func:`~sysid_core.verdict.trust.trust_radius` of the last such step and the split verified
    after it, ``linearised``); from a model of the sweeps near the bias only (``local_fit``), at
    any split.
    A run that tunes a pair of its electrodes and can offer the others again (``reoffer``)
    concludes no "unreachable" (:func:`best_effort`).
    """
    try:
        result, local = solve_criterion(criterion, model, space)
    except UnreachableTuningError as exc:
        other = None if every_sweep is None else every_sweep()
        found = None if other is None else reach_with(criterion, other, space)
        if other is not None and found is not None:
            say(
                f"iteration {it}: the fit of every sweep so far reaches the goal inside the "
                "limits; answering from it"
            )
            result, local, space = found
            model = other
        else:
            result = best_effort(
                exc,
                criterion.name,
                model,
                space,
                device,
                it,
                bias_step,
                last_iteration,
                say,
                least_measured,
                acceptance_hz,
                local_fit or it == 1,
                reoffer,
            )
            local = model
    step = _applied(result, local, model, space, device, acceptance_hz)
    limit = bias_step if local_step is None else local_step
    band = device.device.band_hz
    stray = beyond_tuning(
        model, step.result.frequencies_hz, space.start_bias, space.index, band, limit
    )
    if stray is not None:
        bias = check_bias(device.device, stray)
        say(
            f"iteration {it}: the answer [{', '.join(f'{b:.4f}' for b in step.bias)}] V puts the "
            f"modes at {' / '.join(f'{f:.6g}' for f in step.result.frequencies_hz)} Hz, beyond "
            f"what any bias does to modes at {band[0]:.6g}-{band[1]:.6g} Hz (the device's "
            "band): its law is carried where no sweep measured it; taking the step the law "
            "asks at this bias and measuring there"
        )
        result, bias = _stepped(bias, space, model, criterion.name, device)
        result.info["beyond_tuning_answer"] = [float(b) for b in step.bias]
        return Answer(result, bias, True, model)
    back = worse_than_measured(step.result, criterion.name, least_measured, acceptance_hz)
    if back is not None:
        measured, where = back
        bias = check_bias(device.device, where)
        say(
            f"iteration {it}: the answer's own model predicts {step.result.split_hz * 1e3:.3g} "
            f"mHz at its bias, where a verification of this run measured "
            f"{measured * 1e3:.3g} mHz at [{', '.join(f'{b:.4f}' for b in where)}] V; going "
            "back there and measuring the local design"
        )
        result = result_at(bias, space, model, criterion.name)
        result.info["worse_than_measured"] = {
            "answer": [float(b) for b in step.bias],
            "predicted_split_hz": float(step.result.split_hz),
            "measured_split_hz": float(measured),
        }
        return Answer(result, bias, True, model)
    radius = trust_radius(*linearised, limit)
    untrusted = (
        None
        if criterion.name != "degenerate" or acceptance_hz is None
        else untrusted_step(
            model,
            step.bias,
            latest_measured,
            space.index,
            acceptance_hz,
            radius,
            near_acceptances,
            None if step.result.confidence is None else step.result.confidence.split_ci_hz[1],
            local_fit,
        )
    )
    if untrusted is not None:
        bias = check_bias(device.device, untrusted)
        b0 = np.asarray(latest_measured[1], dtype=float)[space.index]  # type: ignore[index]
        say(
            f"iteration {it}: the answer [{', '.join(f'{b:.4f}' for b in step.bias)}] V lies "
            f"{np.max(np.abs(step.bias[space.index] - b0)):.3g} V from the bias verified at "
            f"{latest_measured[0] * 1e3:.3g} mHz, beyond the step its model's law asks there; "  # type: ignore[index]
            "taking that step and measuring the local design"
        )
        result, bias = _stepped(bias, space, model, criterion.name, device)
        result.info["untrusted_answer"] = [float(b) for b in step.bias]
        result.info["trust_region"] = {
            "radius_v": float(radius),
            "length_v": float(np.max(np.abs(bias[space.index] - b0))),
            "from_split_hz": float(latest_measured[0]),  # type: ignore[index]
            "predicted_split_hz": float(result.split_hz),
        }
        step = Answer(result, bias, True, model)
    floor = dac_floor(step.result.info, acceptance_hz)
    if floor is not None and acceptance_hz is not None:
        say(
            f"iteration {it}: the DAC limits this answer: its best code nearby is predicted to "
            f"leave {floor * 1e3:.3g} mHz (acceptance {acceptance_hz * 1e3:.3g} mHz); a finer "
            "DAC, another electrode or a wider acceptance would help"
        )
    return step


def reach_with(
    criterion: TuningCriterion, model: FittedModel, space: BiasSpace
) -> tuple[TuningResult, FittedModel, BiasSpace] | None:
    """``model``'s solution of ``criterion`` if it reaches the goal, else None.

    Solved from ``space``'s bias and from the middle of the limits: from a bias at a limit,
    the repeated linearization of a quadratic law may stay at that limit.
    """
    middle = np.array(space.start_bias, dtype=float)
    middle[space.index] = 0.5 * (space.limits[0] + space.limits[1])
    for start in (space, dataclasses.replace(space, start_bias=middle)):
        try:
            result, local = solve_criterion(criterion, model, start)
        except UnreachableTuningError:
            continue
        return result, local, start
    return None


def _applied(
    result: TuningResult,
    local: FittedModel,
    model: FittedModel,
    space: BiasSpace,
    device: GuardedDevice,
    acceptance_hz: float | None = None,
) -> Answer:
    """``result`` at the DAC code ``model`` predicts best, checked, with its region.

    The codes along the degenerate set are searched (:func:`~sysid_core.verdict.dac.best_code`)
    for an answer of the criterion that was not moved into reach, where the best code one step
    around it leaves :data:`~sysid_core.verdict.dacfloor.DAC_FLOOR_SHARE` of ``acceptance_hz``
    or more: where the DAC limits the answer.
    """
    moved = "unreachable" in result.info
    chosen = dataclasses.replace(result)  # the criterion's, before the DAC code
    over = None if moved or acceptance_hz is None else DAC_FLOOR_SHARE * acceptance_hz
    apply_best_code(model, result, space, device, search_over=over)
    bias = check_bias(device.device, result.bias)
    # the region is about the answer (where the truth is); its split range is at the voltages
    # that will really be applied
    result.confidence = confidence_region(
        local.linearized(chosen.w),
        chosen,
        space,
        applied_bias=applied_bias(device.device, bias),
    )
    return Answer(result, bias, moved, model)


def _stepped(
    bias: np.ndarray, space: BiasSpace, model: FittedModel, name: str, device: GuardedDevice
) -> tuple[TuningResult, np.ndarray]:
    """The answer "step to ``bias``" at the DAC code the model predicts best, and that code.

    A step smaller than a code would otherwise apply the code verified before, unsaid.
    """
    result = result_at(bias, space, model, name)
    apply_best_code(model, result, space, device)
    return result, check_bias(device.device, result.bias)
