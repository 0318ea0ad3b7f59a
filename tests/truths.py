"""Synthetic truths for the tests (in the model class and out of it), and data sets from them.

Every calibration figure is read from the cloverleaf's parameter set
(:class:`sysid_cloverleaf.CloverleafParameters`), never copied here: a change of the calibration
reaches the tests, and the tests' known figures (published biases, frequencies) check it.
"""

from __future__ import annotations

import json
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np
from sysid_cloverleaf import CloverleafParameters

from sysid_core.data.schema import make_dataset
from sysid_core.device.simulation import GyroTruth, LowPass
from sysid_core.model.fitted import FittedModel

__all__ = [
    "CLOVERLEAF",
    "OUTPUT_LOWPASS",
    "PAPER_BIASES",
    "PAPER_FREQS",
    "PICKOFF",
    "TWO_PI",
    "V_GYRO",
    "cloverleaf_truth",
    "degenerate_config",
    "random_gyro_sweep",
    "simulate",
]

#: The cloverleaf's calibration (``docs/cloverleaf.md``).
CLOVERLEAF = CloverleafParameters()
TWO_PI = 2 * np.pi
V_GYRO = CLOVERLEAF.structure_potential
#: The paper's three experiments (B1, B2) and its measurement band, 121 points.
PAPER_BIASES = np.array([[0.0, 0.0], [1.0, 0.0], [0.0, 1.0]])
PAPER_FREQS = np.linspace(*CLOVERLEAF.band_hz, 121)
#: The cloverleaf's pick-off signal conditioning: channel 2 lags by 1 degree at 4430 Hz.
OUTPUT_LOWPASS = CLOVERLEAF.output_lowpass()
#: The cloverleaf's pick-off matrix ``R`` (non-collocation).
PICKOFF = np.asarray(CLOVERLEAF.pickoff, dtype=float)


def cloverleaf_truth(
    h_out: LowPass | None = None,
    h_in: LowPass | None = None,
    R: np.ndarray | None = None,
    B: np.ndarray | None = None,
) -> GyroTruth:
    """A two-electrode gyro like the paper's: B1 and B2, B3 held at 0 V and folded into K0."""
    kp = CLOVERLEAF.electrode_stiffness()
    held = CLOVERLEAF.electrodes.index("B3")
    tuned = [p for p in range(len(CLOVERLEAF.electrodes)) if p != held]
    return GyroTruth(
        M=np.eye(2),
        C=CLOVERLEAF.damping(),
        K0=CLOVERLEAF.stiffness() + kp[held] * V_GYRO**2,  # (v_gyro - 0 V)**2
        Kp=kp[tuned],
        structure_potential=V_GYRO,
        electrodes=tuple(CLOVERLEAF.electrodes[p] for p in tuned),
        R=PICKOFF if R is None else R,
        B=np.eye(2) if B is None else B,
        velocity_pickoff=CLOVERLEAF.velocity_pickoff,
        h_out=h_out,
        h_in=h_in,
    )


class ModelTruth:
    """A fitted model as ``simulate``'s truth: its response at each bias."""

    def __init__(self, model: FittedModel) -> None:
        self.model = model
        self.electrodes = model.electrodes
        self.structure_potential = model.structure_potential

    def response(self, bias: np.ndarray, freqs: np.ndarray) -> np.ndarray:
        return self.model.response(freqs, bias)


def simulate(
    truth: GyroTruth | ModelTruth,
    biases: np.ndarray = PAPER_BIASES,
    freqs: np.ndarray = PAPER_FREQS,
    noise_rel: float = 0.0,
    noise_peak: float = 0.0,
    seed: int = 0,
):
    """Data set from ``truth`` with complex noise relative to each point and to the peak."""
    rng = np.random.default_rng(seed)
    responses = []
    for b in biases:
        r = truth.response(b, freqs)
        scale = noise_rel * np.abs(r) + noise_peak * np.abs(r).max()
        z = (rng.standard_normal(r.shape) + 1j * rng.standard_normal(r.shape)) / np.sqrt(2)
        responses.append(r + scale * z)
    return make_dataset(
        responses, freqs, biases, list(truth.electrodes), truth.structure_potential, device="truth"
    )


def write_toml(path: Path, tables: dict[str, dict[str, Any]]) -> Path:
    """Write configuration ``tables`` (dicts of keys) as a TOML file at ``path``; return it."""

    def value(v: Any) -> str:
        if isinstance(v, bool):
            return "true" if v else "false"
        if isinstance(v, str):
            return json.dumps(v)
        if isinstance(v, (list, tuple)):
            return "[" + ", ".join(value(x) for x in v) + "]"
        if isinstance(v, dict):
            return "{" + ", ".join(f"{k} = {value(x)}" for k, x in v.items()) + "}"
        return repr(v)

    lines = []
    for table, values in tables.items():
        lines.append(f"[{table}]")
        lines += [f"{k} = {value(v)}" for k, v in values.items()]
    path.write_text("\n".join(lines) + "\n")
    return path


def cloverleaf_config(
    acceptance_hz: float, iterations: int, **sections: dict[str, Any]
) -> dict[str, Any]:
    """A run of the cloverleaf (seed 1) to degenerate modes with B1 and B2 from 0 V; more
    tables (``experiment``, ``model``...) from ``sections``."""
    return {
        "device": {"name": "cloverleaf", "seed": 1},
        "tuning": {
            "criterion": "degenerate",
            "electrodes": ["B1", "B2"],
            "start_bias": [0.0, 0.0, 0.0],
            "acceptance_hz": acceptance_hz,
            "max_iterations": iterations,
        },
        **sections,
    }


def degenerate_config(
    device: Any,
    options: dict[str, Any],
    iterations: int,
    acceptance_hz: float = 0.002,
    **sections: dict[str, Any],
) -> dict[str, Any]:
    """A run of ``random-gyro`` ``device`` (built with ``options``) to degenerate modes with B1
    and B2 from 0 V; the model structure that matches its dynamics, unless ``sections`` give a
    ``model`` table; more tables (``experiment``...) from ``sections``."""
    return {
        "device": {"name": "random-gyro", **options},
        "model": {"structure": device.structure},
        "tuning": {
            "criterion": "degenerate",
            "electrodes": ["B1", "B2"],
            "start_bias": [0.0] * len(device.electrodes),
            "acceptance_hz": acceptance_hz,
            "max_iterations": iterations,
        },
        **sections,
    }


def random_gyro_sweep(
    seed: int,
    noise: float,
    noise_seed: int,
    frequencies: Callable[[Any, np.ndarray], np.ndarray],
    b1: float = 0.0,
) -> tuple[Any, np.ndarray, Any, Any]:
    """One sweep of random gyro ``seed`` and the fitter of its structure.

    The bias is ``b1`` on the first electrode and zero on the others; ``frequencies(device,
    bias)`` gives the sweep's points. ``noise``: the device's, relative to its peak.
    Returns the device, the bias, the one-experiment data set and a least-squares fitter
    (:class:`~sysid_core.measure.fitter.Fitter`, Clarabel).
    """
    from sysid_core.data.schema import experiment_from_measurement
    from sysid_core.measure.fitter import Fitter
    from sysid_core.plugin.registry import get_registry

    registry = get_registry()
    device = registry.device("random-gyro", seed=seed, noise=noise, noise_seed=noise_seed)
    bias = np.zeros(len(device.electrodes))
    bias[0] = b1
    freqs = frequencies(device, bias)
    sweep = experiment_from_measurement(
        device.measure(bias, freqs), bias, list(device.electrodes), device.structure_potential, "r"
    )
    fitter = Fitter(
        registry.structure(device.structure),
        registry.objective("least-squares"),
        registry.solver("clarabel"),
    )
    return device, bias, sweep, fitter
