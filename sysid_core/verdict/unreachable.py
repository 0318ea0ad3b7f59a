"""When a model finds its goal unreachable: conclude, or continue from the best reachable bias.

:func:`best_effort` decides whether the verdict "the modes cannot meet the goal inside the
limits" ends the run or is the model's extrapolation, its noise, a drift it did not model, or a
pair's while other electrodes can be offered again; :func:`result_at` is the answer "go to
this bias" that the run applies instead.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

from sysid_core.data.schema import squared_potentials
from sysid_core.device.measuring import GuardedDevice, check_bias
from sysid_core.errors import UnreachableTuningError
from sysid_core.identification.drift import drift_modelled
from sysid_core.model.fitted import FittedModel
from sysid_core.tuning.criteria import BiasSpace, TuningResult, frequencies_from_w
from sysid_core.verdict.trust import unsure_unreachable

__all__ = ["REFUTES", "best_effort", "result_at"]

#: A verification that measured a split under this share of the best split a model can reach
#: refutes the model's verdict "cannot be made degenerate" (:func:`best_effort`).
REFUTES = 0.5


def best_effort(
    exc: UnreachableTuningError,
    criterion_name: str,
    model: FittedModel,
    space: BiasSpace,
    device: GuardedDevice,
    it: int,
    bias_step: float,
    last_iteration: bool,
    say: Callable[[str], None],
    least_measured: tuple[float, np.ndarray] | None = None,
    acceptance_hz: float | None = None,
    identified_here: bool = True,
    reoffer: bool = False,
) -> TuningResult:
    """Continue from the best reachable bias, or re-raise ``exc`` if that cannot help.

    A model identified around the current bias extrapolates to a far bias, so its verdict
    "unreachable" may be wrong there (measured: the cloverleaf's 4435 Hz target, B1 near
    9.2 V, 0.02-0.4 Hz "short" after the first iteration for some noise draws). If iterations
    remain and the best reachable bias lies more than ``bias_step`` from the current one, the
    run moves there (it is inside the limits) and identifies a model around it; the verdict of
    a model identified there, or of the last iteration, stands.

    On a bench with a clock, a drift during the measurements can look like a bias dependence
    that makes the goal unreachable: a model of time-stamped data that modelled no drift does
    not conclude either; the run continues from the best reachable bias, where the next fit
    sees more epochs; at the last iteration it stays at the current bias (verified once more)
    and ends unconverged instead of declaring the goal unreachable (measured: two gyros of an
    uncontrolled lab's population, which converge at a good lab's drift, ended with that
    error).

    A verification that measured a split under half the best one the model can reach
    (``least_measured``: the least split and its bias; degenerate modes only) refutes the
    verdict whatever the model: the run continues from that verification's bias, or at the
    last iteration stays where it is and ends unconverged (a local model fitted hours after a
    verification on a drifting bench can find 56.9 mHz the best reachable split where that
    verification measured 3.7 mHz).

    With ``acceptance_hz``, a verdict the model's own 95 % region does not hold
    (:func:`~.trust.unsure_unreachable`) is not concluded either: the run continues from there.

    Nor is that of a model not ``identified_here`` (a lean run's fit of every sweep: its law is
    the first design's, extrapolated to windows; its region states the noise, not that): the
    run moves to the best reachable bias and measures the local design there.

    Nor that of a model of a pair of the electrodes while others can be offered again
    (``reoffer``, :mod:`sysid_core.measure.pairing`): the run stays at its bias, where it offers
    every electrode again from the next iteration on.
    """
    refuted = (
        criterion_name == "degenerate"
        and least_measured is not None
        and exc.best_value is not None
        and least_measured[0] < REFUTES * float(exc.best_value)
    )
    if refuted:
        assert least_measured is not None
        measured, where = least_measured
        bias = check_bias(device.device, space.start_bias if last_iteration else where)
        then = (
            "the run stays at its bias and ends unconverged"
            if last_iteration
            else "continuing from that verification's bias"
        )
        say(
            f"iteration {it}: {exc} -- refuted by this run's data: a verification measured "
            f"{measured * 1e3:.3g} mHz at [{', '.join(f'{b:.4f}' for b in where)}] V; {then}"
        )
        return result_at(bias, space, model, criterion_name, exc)
    best = exc.best_bias
    span = model.facts.time_span_s
    unmodelled = span > 0 and not drift_modelled(model)
    far = (
        best is not None
        and float(np.max(np.abs(np.asarray(best, dtype=float) - space.start_bias))) > bias_step
    )
    unsure = None  # degenerate modes: the model's own region may not hold its verdict
    if criterion_name == "degenerate" and acceptance_hz and best is not None:
        if identified_here and not (far or unmodelled or last_iteration):
            there = result_at(np.asarray(best, dtype=float), space, model, criterion_name)
            unsure = unsure_unreachable(model, there, space, acceptance_hz)
    doubt = far or unmodelled or unsure is not None or not identified_here or reoffer
    if best is None or not doubt or (last_iteration and not unmodelled):
        raise exc
    # at the last iteration the run stays where it is: a far bias this model only extrapolates
    # to would end the run there (measured: 46 Hz off on a gyro the run had brought to 5 Hz);
    # so does one that offers every electrode again: a pair's best reachable bias may lie at a
    # limit, far from where all of them meet the goal and from the sweeps already measured
    bias = check_bias(device.device, space.start_bias if last_iteration or reoffer else best)
    if reoffer:
        why = "a model of a pair of the electrodes; the others are offered again"
    elif unmodelled:
        why = f"its data span {span / 60:.3g} min of a clock and no drift was modelled"
    elif unsure is not None:
        why = f"its own 95 % region there holds a split of {unsure * 1e3:.3g} mHz"
    elif not identified_here:
        why = "the model was not identified around this bias (a fit of every sweep so far)"
    else:
        why = f"the model was identified more than {bias_step} V away"
    then = (
        "not concluded: the run stays at its bias and ends unconverged (more iterations, or "
        "a [model] drift, decide)"
        if last_iteration
        else "staying at this bias to offer every electrode again"
        if reoffer
        else "continuing from that bias"
    )
    say(f"iteration {it}: {exc} -- {why}; {then}")
    return result_at(bias, space, model, criterion_name, exc)


def result_at(
    bias: np.ndarray,
    space: BiasSpace,
    model: FittedModel,
    criterion_name: str,
    exc: UnreachableTuningError | None = None,
) -> TuningResult:
    """The answer "go to ``bias``", with the model's modes there and the verdict it replaces.

    Without ``exc`` (no verdict replaced) the criterion's value is the model's split there.
    """
    w = squared_potentials(space.structure_potential, bias[space.index])
    f = frequencies_from_w(model, w)
    split = float(f[1] - f[0])
    if exc is None:
        value, info = split, {}
    else:
        value = float(exc.best_value) if exc.best_value is not None else float("nan")
        info = {"unreachable": str(exc)}
    return TuningResult(
        bias=bias,
        w=w,
        frequencies_hz=f,
        split_hz=split,
        criterion=criterion_name,
        value=value,
        info=info,
    )
