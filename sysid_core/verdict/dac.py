"""Choosing the DAC code to apply: the code near the answer the model expects best.

A device whose bias source quantises (a DAC) applies the nearest code to the answer, and near
the answer the split changes by up to a few mHz per code (the split's slope scales with the
modal frequency: about 3 mHz per 0.3 mV step at 25 kHz). Plain rounding then leaves that much.
:func:`best_code` searches the codes around the answer and returns the one at which the model
expects the smallest split (or, for a target frequency, the smallest frequency error). It needs
the device's optional ``bias_resolution`` (volts per code) and ``applied_bias(bias)``
(``docs/writing-a-device.md``); without them the answer is applied as it is.

With more tuned electrodes than the two goals need, the degenerate biases form a set through
the answer, and the DAC's lattice passes closer to it somewhere along it than at the answer: a
22 kHz gyro with four electrodes, whose codes one step around the answer leave 1.09 mHz at best
(true), has codes 4 steps away at 0.27 mHz and 15 away at 0.20 (true; the model predicts 1.13,
0.26 and 0.16). So where the codes one step around an answer at degenerate modes leave half
the acceptance or more (where the run says the DAC limits the answer), the search
(:func:`split_code`) scores every code of a box of
:data:`SEARCHED_CODES` around the answer's nearest code by the split the model expects there:
the square of its prediction plus the variance the fit's covariance gives the change of the
split from the answer to that code (the law's slopes are known only so well, and their error
grows with the distance). On that gyro the change 15 codes away is known to ±0.008 mHz, so the
box, not the covariance, bounds the search; a model without a covariance (``minimax``) is scored
by its prediction alone. A target frequency keeps the codes one step around the answer.
"""

from __future__ import annotations

import itertools

import numpy as np

from sysid_core.data.schema import squared_potentials
from sysid_core.device.capabilities import read_capabilities
from sysid_core.device.measuring import GuardedDevice, applied_bias
from sysid_core.model.fitted import FittedModel
from sysid_core.model.modal import modal_frequencies_hz, normalised_stiffness, trace_deviation
from sysid_core.tuning.confidence import stiffness_draws
from sysid_core.tuning.criteria import BiasSpace, TuningResult, frequencies_from_w

__all__ = [
    "CODE_DRAWS",
    "EXACT_CODES",
    "MAX_ELECTRODES",
    "SEARCHED_CODES",
    "apply_best_code",
    "best_code",
    "bias_resolution",
    "predicted_modes_hz",
    "search_reach",
    "split_code",
]

#: Above this many tuned electrodes (3**n candidates) the answer is applied as it is.
MAX_ELECTRODES = 8
#: The most codes :func:`split_code` scores: a box of ``(2 K + 1)**n`` codes, ``K`` as large as
#: this allows (:func:`search_reach`: 364 codes each way with two tuned electrodes, 13 with
#: four, 4 with six, 2 with eight). A bound on the work (0.3-0.4 s per answer here), not
#: on the model: the covariance, not the box, would stop a model whose law is uncertain.
SEARCHED_CODES = 9**6
#: The codes of the box scored by the model's own law, the best by its tangent at the answer.
EXACT_CODES = 64
#: Models drawn from the fit's covariance to score the change of the split from the answer to
#: a code (its variance to about ±7 %).
CODE_DRAWS = 400


def bias_resolution(device: object) -> float | None:
    """The device's DAC step in volts, if it states one (its checked capabilities)."""
    caps = device.capabilities if isinstance(device, GuardedDevice) else read_capabilities(device)
    return caps.bias_resolution


def predicted_modes_hz(model: FittedModel, w: np.ndarray) -> np.ndarray:
    """The model's two undamped modal frequencies (Hz) at each row of ``w``, ``(S, 2)``."""
    w = np.atleast_2d(np.asarray(w, dtype=float))
    return modal_frequencies_hz(model.stiffness_w(w), model.M)


def search_reach(electrodes: int) -> int:
    """How many codes each way :func:`split_code` searches with ``electrodes`` tuned ones."""
    reach = int((SEARCHED_CODES ** (1.0 / electrodes) - 1.0) / 2.0)
    while (2 * (reach + 1) + 1) ** electrodes <= SEARCHED_CODES:  # the root's rounding
        reach += 1
    return max(reach, 1)


def _slopes(model: FittedModel, w_answer: np.ndarray) -> tuple[np.ndarray, np.ndarray | None]:
    """How ``d`` changes with ``w`` at the answer, and how well the fit knows it.

    ``d`` is the deviatoric part of ``M^{-1/2} K(w) M^{-1/2}`` (:mod:`sysid_core.model.modal`):
    from the answer to a code it changes by ``D δw``, ``D`` (``(n, 2)``, returned first) the
    deviatoric parts of the normalised ``K_p`` of the model linearized at the answer. Over
    :data:`CODE_DRAWS` models drawn from the fit's covariance, the mean of ``|(D_s - D) δw|²``
    is ``δwᵀ C δw``; ``C`` (``(n, n)``) is returned second, None without a covariance.
    """
    tangent = model.linearized(w_answer)
    _, slope = trace_deviation(normalised_stiffness(tangent.M[None], np.asarray(tangent.Kp)[None]))
    if tangent.stiffness_factor is None:
        return slope[0], None
    m, _, kp = stiffness_draws(tangent, CODE_DRAWS)
    _, slopes = trace_deviation(normalised_stiffness(m, kp))  # (draws, n, 2)
    spread = np.cov(slopes[:, :, 0], rowvar=False) + np.cov(slopes[:, :, 1], rowvar=False)
    return slope[0], np.atleast_2d(spread)


def split_code(
    model: FittedModel, bias: np.ndarray, space: BiasSpace, device: object, step: float
) -> np.ndarray | None:
    """The code around ``bias`` (an answer) where the model expects the least split, or None.

    The box of :func:`search_reach` codes each way around the code the device applies for
    ``bias``, within the space's limits and on the answer's side of the structure's potential on
    every electrode (a bias mirrored through it gives the same squared potential: the same split
    volts away), scored by the expected square of the split: the
    model's prediction squared plus the variance of its change from the answer
    (:func:`_slopes`), both mapped to Hz by ``1 / (2π √t)``, ``t`` the mean of the two squared
    modal frequencies at the answer. The box is scored to first order in the change of the
    squared potentials, its best :data:`EXACT_CODES` by the model's own law; ties go to the code
    nearest the answer. None when the device does not say what it applies for ``bias``, or does
    not apply the code the search prefers as it is.
    """
    index = space.index
    centre = applied_bias(device, bias)
    if centre is None:
        return None
    n, reach = len(index), search_reach(len(index))
    axis = np.arange(-reach, reach + 1, dtype=float)
    tuned = centre[index] + step * np.stack(np.meshgrid(*([axis] * n), indexing="ij"), -1).reshape(
        -1, n
    )
    low, high = space.limits
    side = (space.structure_potential - tuned) * (space.structure_potential - bias[index]) >= 0
    tuned = tuned[np.all((tuned >= low) & (tuned <= high) & side, axis=1)]
    if not len(tuned):
        return None
    w_answer = squared_potentials(space.structure_potential, bias[index])
    t, d = trace_deviation(normalised_stiffness(model.M[None], model.stiffness_w(w_answer)[None]))
    to_hz = 1.0 / (4.0 * np.pi**2 * t[0])  # |d|² to the split's square (Hz²)
    slope, spread = _slopes(model, w_answer)
    change = squared_potentials(space.structure_potential, tuned) - w_answer
    uncertain = (
        np.zeros(len(tuned)) if spread is None else np.einsum("ij,jk,ik->i", change, spread, change)
    )
    first = np.sum((d[0] + change @ slope) ** 2, axis=1) + uncertain
    near = np.argsort(first, kind="stable")[:EXACT_CODES]
    f = predicted_modes_hz(model, change[near] + w_answer)
    score = (f[:, 1] - f[:, 0]) ** 2 + uncertain[near] * to_hz
    distance = np.max(np.abs(tuned[near] - bias[index]), axis=1)
    candidate = bias.copy()
    candidate[index] = tuned[near[np.lexsort((distance, score))[0]]]
    applied = applied_bias(device, candidate)
    if applied is None or not np.allclose(applied, candidate, rtol=0, atol=step / 2):
        return None  # not a code of this device: the answer is applied as it is
    return applied


def best_code(
    model: FittedModel,
    result: TuningResult,
    space: BiasSpace,
    device: object,
    search_over: float | None = None,
) -> np.ndarray | None:
    """The DAC code around ``result.bias`` that the model expects best, or ``None``.

    ``None`` when the device states no resolution or cannot say what it applies, or with more
    than :data:`MAX_ELECTRODES` tuned electrodes. The codes one step up, none or one down on
    each tuned electrode (codes outside the device's limits are skipped: ``applied_bias``
    refuses them), by the predicted split or, for a ``target_hz``, the largest frequency error;
    ties go to the code nearest the answer. Where the best of them is predicted to leave
    ``search_over`` (Hz) or more, and the answer has no ``target_hz``, :func:`split_code`
    searches further (``search_over`` is given for an answer at degenerate modes, the
    criterion's own: a step or a stay is not one, and a search would move it to one).
    """
    step = bias_resolution(device)
    index = space.index
    if step is None or len(index) > MAX_ELECTRODES:
        return None
    bias = np.asarray(result.bias, dtype=float)
    target = result.info.get("target_hz")
    codes, distance = [], []
    for offsets in itertools.product((-1.0, 0.0, 1.0), repeat=len(index)):
        candidate = bias.copy()
        candidate[index] += step * np.asarray(offsets)
        applied = applied_bias(device, candidate)
        if applied is not None:
            codes.append(applied)
            distance.append(float(np.max(np.abs(applied[index] - bias[index]))))
    if not codes:
        return None
    applied_codes = np.array(codes)
    w = squared_potentials(space.structure_potential, applied_codes[:, index])
    f = predicted_modes_hz(model, w)
    if target is not None:
        score = np.max(np.abs(f - float(target)), axis=1)
    else:
        score = f[:, 1] - f[:, 0]
    best = float(score.min())
    if target is None and search_over is not None and best >= search_over:
        found = split_code(model, bias, space, device, step)
        if found is not None:
            return found
    tied = np.flatnonzero(score <= best + 1e-9 * max(abs(best), 1e-12) + 1e-15)
    choice = tied[np.argmin(np.asarray(distance)[tied])]
    return applied_codes[choice]


def apply_best_code(
    model: FittedModel,
    result: TuningResult,
    space: BiasSpace,
    device: GuardedDevice,
    search_over: float | None = None,
) -> None:
    """Move ``result`` to the DAC code the model expects best (:func:`best_code`)."""
    code = best_code(model, result, space, device, search_over)
    if code is None or np.array_equal(code, result.bias):
        return
    rounded = applied_bias(device.device, np.asarray(result.bias, dtype=float))
    w = squared_potentials(space.structure_potential, code[space.index])
    f = frequencies_from_w(model, w)
    before = (
        None
        if rounded is None
        else frequencies_from_w(
            model, squared_potentials(space.structure_potential, rounded[space.index])
        )
    )
    result.info["dac_code"] = {
        "answer": [float(b) for b in result.bias],
        "predicted_split_hz_rounded": None if before is None else float(before[1] - before[0]),
        "predicted_split_hz_chosen": float(f[1] - f[0]),
    }
    result.bias, result.w = code, w
    result.frequencies_hz, result.split_hz = f, float(f[1] - f[0])
