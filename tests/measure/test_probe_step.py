"""A sweep that misses the modes after a probe that showed them falls back to the probe's step.

Truth: the simulated gyro's modal frequencies (``true_modal_frequencies_hz``), which the run
never sees. Random gyro 404 (2.80 kHz, one tone per acquisition, a good lab's clock): its
16-point probe at 0 V shows both modes; stepping B1 by 3 V moves one mode out of the scout's
window. Before, the run then swept the band at 61 points (61 acquisitions); the 16 points of
the probe's step show the modes there as they did at 0 V. A verification whose window misses
the modes falls back the same way (random gyro 396).
"""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import numpy as np

from sysid_core import load_model, tune
from sysid_core.measure.modegrid import SHAPES
from sysid_core.plugin.registry import get_registry

GOOD_LAB = {"temperature_ramp_k_per_h": 0.2, "temperature_walk_k_per_sqrt_h": 0.05}


def one_iteration(seed: int, experiment: dict | None = None) -> tuple[Any, dict]:
    """Random gyro ``seed`` with one tone on a good lab's clock, and a one-iteration run of it."""
    bench = {"clock": True, "seed": seed, "tones": 1, **GOOD_LAB}
    device = get_registry().device("random-gyro", seed=seed, bench=bench)
    config = {
        "device": {"name": "random-gyro", "seed": seed},
        "model": {"structure": device.structure},
        "tuning": {
            "criterion": "degenerate",
            "electrodes": list(device.electrodes[:2]),
            "start_bias": [0.0] * len(device.electrodes),
            "acceptance_hz": 0.001,
            "max_iterations": 1,
        },
        "experiment": experiment or {},
    }
    return device, config


def test_a_missed_scout_is_followed_by_a_band_at_the_probes_step(tmp_path: Path) -> None:
    device, config = one_iteration(404, {"bias_step": 3.0})
    lines: list[str] = []
    out = tmp_path / "run"
    tune(config, out, device=device, plots=False, progress=lines.append)

    folder = out / "iter01"
    missed = [ln for ln in lines if "exp1.nc: the sweep does not show both modes" in ln]
    assert missed, "\n".join(lines)  # the case: the scout of B1 misses a mode
    assert (folder / "exp1-probe.nc").exists()
    assert not (folder / "exp1-locate.nc").exists()  # no 61-point band
    assert not any("61 points" in ln for ln in lines)
    # the band at the probe's step located the modes where they are: the first model, fitted
    # to it with the design, puts them within a bandwidth (0.111 / 0.197 Hz) of the truth at
    # the scout's bias
    model = load_model(folder / "model.nc")
    at = np.array([3.0, 0.0])
    fitted = np.sort(model.modal(at).frequencies_hz)
    truth = np.sort(
        device.true_modal_frequencies_hz(np.r_[at, np.zeros(len(device.electrodes) - 2)])
    )
    np.testing.assert_allclose(fitted, truth, atol=0.1)


def test_a_missed_verification_window_is_followed_by_a_band_at_the_probes_step(
    tmp_path: Path,
) -> None:
    """Random gyro 396 (3.67 kHz, one tone, a good lab's clock): the first answer's window
    misses a mode; before, the band at 61 points followed (61 acquisitions); the points of the
    probe's step locate both modes (with a probe of 21 points, the whole run went from 275 to
    214 dwells, 261 to 201 points). Located, not measured: each mode is within the narrowest
    core of the mode grid that the next window puts around it, 1.5 bandwidths (0.099 / 0.35 Hz;
    with the 21-point probe each was within one bandwidth)."""
    device, config = one_iteration(396)
    lines: list[str] = []
    out = tmp_path / "run"
    result = tune(config, out, device=device, plots=False, progress=lines.append)

    folder = out / "iter01"
    assert any("window around the predicted modes does not show both" in ln for ln in lines)
    assert (folder / "verify-band-probe.nc").exists(), "\n".join(lines)
    assert not (folder / "verify-band.nc").exists()  # no 61-point band
    # it located both modes where they are: each within the next window's core of the truth
    last = json.loads((out / "summary.json").read_text())["history"][-1]
    assert last["verification"] == "located"
    truth = np.sort(device.true_modal_frequencies_hz(result.bias))
    _, damped, q = device.true_modal_analysis(result.bias)  # ascending, as the truth's
    miss = np.abs(np.sort(last["measured_frequencies_hz"]) - truth)
    core = min(shape.core for shape in SHAPES)
    assert np.all(miss <= core * damped / q), (miss, damped / q)
