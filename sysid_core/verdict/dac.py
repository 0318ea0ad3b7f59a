"""Choosing the DAC code to apply: the neighbouring code the model predicts best.

A device whose bias source quantises (a DAC) applies the nearest code to the answer, and near
the answer the split changes by up to a few mHz per code (the split's slope scales with the
modal frequency: about 3 mHz per 0.3 mV step at 25 kHz). Plain rounding then leaves that much.
:func:`best_code` looks at the codes around the answer, one step up, none or one down on each
tuned electrode (``3**n`` candidates), and returns the one at which the model predicts the
smallest split (or, for a target frequency, the smallest frequency error). It needs the
device's optional ``bias_resolution`` (volts per code) and ``applied_bias(bias)``
(``docs/writing-a-device.md``); without them the answer is applied as it is.
"""

from __future__ import annotations

import itertools

import numpy as np

from sysid_core.data.schema import squared_potentials
from sysid_core.device.capabilities import read_capabilities
from sysid_core.device.measuring import GuardedDevice, applied_bias
from sysid_core.model.fitted import FittedModel
from sysid_core.model.modal import modal_frequencies_hz
from sysid_core.tuning.criteria import BiasSpace, TuningResult, frequencies_from_w

__all__ = [
    "MAX_ELECTRODES",
    "apply_best_code",
    "best_code",
    "bias_resolution",
    "predicted_modes_hz",
]

#: Above this many tuned electrodes (3**n candidates) the answer is applied as it is.
MAX_ELECTRODES = 8


def bias_resolution(device: object) -> float | None:
    """The device's DAC step in volts, if it states one (its checked capabilities)."""
    caps = device.capabilities if isinstance(device, GuardedDevice) else read_capabilities(device)
    return caps.bias_resolution


def predicted_modes_hz(model: FittedModel, w: np.ndarray) -> np.ndarray:
    """The model's two undamped modal frequencies (Hz) at each row of ``w``, ``(S, 2)``."""
    w = np.atleast_2d(np.asarray(w, dtype=float))
    return modal_frequencies_hz(model.stiffness_w(w), model.M)


def best_code(
    model: FittedModel, result: TuningResult, space: BiasSpace, device: object
) -> np.ndarray | None:
    """The DAC code around ``result.bias`` that the model predicts best, or ``None``.

    ``None`` when the device states no resolution or cannot say what it applies, or with more
    than :data:`MAX_ELECTRODES` tuned electrodes. Codes outside the device's limits are
    skipped (``applied_bias`` refuses them). The measure is the predicted split, or the largest
    frequency error for an answer with a ``target_hz``; ties go to the code nearest the answer.
    """
    step = bias_resolution(device)
    index = space.index
    if step is None or len(index) > MAX_ELECTRODES:
        return None
    bias = np.asarray(result.bias, dtype=float)
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
    target = result.info.get("target_hz")
    if target is not None:
        score = np.max(np.abs(f - float(target)), axis=1)
    else:
        score = f[:, 1] - f[:, 0]
    best = float(score.min())
    tied = np.flatnonzero(score <= best + 1e-9 * max(abs(best), 1e-12) + 1e-15)
    choice = tied[np.argmin(np.asarray(distance)[tied])]
    return applied_codes[choice]


def apply_best_code(
    model: FittedModel, result: TuningResult, space: BiasSpace, device: GuardedDevice
) -> None:
    """Move ``result`` to the DAC code the model predicts best (:mod:`sysid_core.verdict.dac`)."""
    code = best_code(model, result, space, device)
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
