"""The output-error polish of examples/window_designs.py: a fit by the response, not a guess.

Truth: random gyro 205 (22 kHz) at 60 dB near its degenerate bias. The polish starts from the
run's window fit and may only lower the noise-weighted response error (a Levenberg-Marquardt
step from there); on a window without noise it keeps the split the exact fit found.
"""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np
import xarray as xr

from sysid_core.data.schema import experiment_from_measurement
from sysid_core.measure.fitter import Fitter
from sysid_core.model.fitted import FittedModel
from sysid_core.plugin.registry import get_registry

sys.path.insert(0, str(Path(__file__).resolve().parents[2] / "examples"))

from window_designs import polish

BIAS = [1.7242, 4.2841]


def _window(noise: float) -> tuple[xr.Dataset, FittedModel, float]:
    reg = get_registry()
    device = reg.device("random-gyro", seed=205, noise=noise, bench={"clock": True, "seed": 205})
    names = list(device.electrodes)
    bias = np.zeros(len(names))
    bias[:2] = BIAS
    fc = float(np.mean(device.true_modal_frequencies_hz(bias)))
    freqs = fc + np.r_[-22.0, -4.4, -2.9, -1.5, -0.75, -0.5, -0.25, 0.0]
    freqs = np.r_[freqs, fc + np.r_[0.25, 0.5, 0.75, 1.5, 2.9, 4.4, 22.0]]
    da = device.measure(bias, freqs)
    ds = experiment_from_measurement(da, bias, names, device.structure_potential, "random")
    fitter = Fitter(
        reg.structure(device.structure), reg.objective("least-squares"), reg.solver("clarabel")
    )
    model, _ = fitter.window(ds, band=False)
    return ds.isel(electrode=[]), model, float(device.true_split_hz(bias))


def _cost(model: FittedModel, ds: xr.Dataset) -> float:
    psi = ds["response"].values[0]
    r = (model.response(ds["frequency"].values, []) - psi) / np.sqrt(ds["noise_var"].values[0])
    return float(np.sum(np.abs(r) ** 2))


def test_the_polish_only_lowers_the_response_error() -> None:
    ds, model, _ = _window(1e-3)
    polished = polish(model, ds)
    assert _cost(polished, ds) <= _cost(model, ds) * (1 + 1e-9)


def test_without_noise_the_polish_keeps_the_split() -> None:
    ds, model, true_split = _window(1e-9)
    assert abs(model.split_hz([]) - true_split) < 1e-4
    assert abs(polish(model, ds).split_hz([]) - model.split_hz([])) < 1e-4
