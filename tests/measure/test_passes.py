"""A verification window whose noise hides the split is measured again and averaged.

Truth: the simulated gyro's undamped modal frequencies at the window's bias (``true_modal_
frequencies_hz``), which neither the window's fit nor the run sees.
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
import xarray as xr
from hypothesis import given, settings
from hypothesis import strategies as st
from truths import degenerate_config

from sysid_core import fit, tune
from sysid_core.data.schema import experiment_from_measurement
from sysid_core.errors import DataError
from sysid_core.measure.passes import MAX_REPEAT_S, average_passes, passes_needed, target_reach_hz
from sysid_core.plugin.registry import get_registry
from sysid_core.tuning.confidence import split_interval

#: Random gyro 106 (28.3 kHz, input dynamics) near its degenerate bias: true split 2.0 mHz.
SEED = 106
BIAS = np.array([-4.8849, -5.0122, 0.0])
OFFSETS = np.array(
    [
        *(-50.07, -25.03, -10.01, -7.82, -6.67, -5.21, -3.33, -2.60, 0.02),
        *(2.63, 3.36, 5.25, 6.71, 7.86, 10.05, 25.06, 50.10),
    ]
)


def _window(device: object, freqs: np.ndarray) -> xr.Dataset:
    return experiment_from_measurement(
        device.measure(BIAS, freqs),  # type: ignore[attr-defined]
        BIAS,
        list(device.electrodes),  # type: ignore[attr-defined]
        device.structure_potential,  # type: ignore[attr-defined]
        "random-gyro",
    )


def test_averaged_passes_measure_the_split_the_noise_hid() -> None:
    """At 60 dB SNR one pass measures 6 mHz for a true 2 mHz (the split of noisy modes is
    biased up); eight passes averaged bring it to the truth within the noise they leave."""
    device = get_registry().device("random-gyro", seed=SEED, noise=1e-3)
    truth = device.true_modal_frequencies_hz(BIAS)
    true_split = float(truth[1] - truth[0])
    freqs = float(np.mean(truth)) + OFFSETS
    errors: dict[int, list[float]] = {1: [], 8: []}
    for _ in range(6):
        passes = [_window(device, freqs) for _ in range(8)]
        for n in errors:
            model = fit(average_passes(passes[:n]).isel(electrode=[]), structure=device.structure)
            f = model.modal([]).frequencies_hz
            errors[n].append(float(f[1] - f[0]) - true_split)
    rms = {n: float(np.sqrt(np.mean(np.square(e)))) for n, e in errors.items()}
    assert rms[8] < 0.5 * rms[1]  # √8 less noise: 0.35 of one pass's error, and its bias gone
    assert rms[8] < true_split


def test_averaging_keeps_the_sweep_and_divides_the_noise() -> None:
    device = get_registry().device("random-gyro", seed=SEED, noise=1e-3, bench={"clock": True})
    freqs = 28257.6 + OFFSETS
    passes = [_window(device, freqs) for _ in range(4)]
    mean = average_passes(passes)
    np.testing.assert_allclose(
        mean["response"].values, np.mean([p["response"].values for p in passes], axis=0)
    )
    np.testing.assert_allclose(
        mean["time_s"].values, np.mean([p["time_s"].values for p in passes], axis=0)
    )
    np.testing.assert_allclose(
        mean["noise_var"].values, np.mean([p["noise_var"].values for p in passes], axis=0) / 4
    )
    assert mean.attrs["passes"] == 4
    np.testing.assert_array_equal(mean["bias"].values, passes[0]["bias"].values)
    with pytest.raises(DataError, match="share their frequencies"):
        average_passes([passes[0], _window(device, freqs + 0.1)])


@settings(max_examples=25, deadline=None)
@given(n=st.integers(1, 6), scale=st.floats(1e-6, 1e3))
def test_averaging_copies_of_one_sweep_gives_the_sweep(n: int, scale: float) -> None:
    device = get_registry().device("random-gyro", seed=SEED, noise=1e-3)
    one = _window(device, 28257.6 + OFFSETS)
    one["response"] = one["response"] * scale
    mean = average_passes([one] * n)
    np.testing.assert_allclose(mean["response"].values, one["response"].values, rtol=1e-12)


def test_how_many_passes() -> None:
    device = get_registry().device("random-gyro", seed=SEED, noise=1e-3)
    truth = device.true_modal_frequencies_hz(BIAS)
    window = _window(device, float(np.mean(truth)) + OFFSETS)
    model = fit(window.isel(electrode=[]), structure=device.structure)
    f = model.modal([]).frequencies_hz
    split = float(f[1] - f[0])
    reach = split_interval(model)[1] - split
    assert reach > 0.002  # one pass at 60 dB does not resolve 2 mHz on this gyro
    expected = int(np.ceil((reach / target_reach_hz(split, 0.002)) ** 2))
    assert passes_needed(model, split, 0.002, 64) == min(expected, 64)
    assert passes_needed(model, split, 0.002, 1) == 1
    assert passes_needed(model, split, 0.002, 8) == min(expected, 8)
    # a pass of 100 s: the repeats stay within MAX_REPEAT_S
    assert passes_needed(model, split, 0.002, 64, pass_s=100.0) <= 1 + MAX_REPEAT_S / 100.0
    # far from a tuning only a quarter of the split is asked for
    assert target_reach_hz(0.1, 0.002) == pytest.approx(0.025)


def _run(tmp_path: Path, max_passes: int, resume: bool = False) -> tuple[Path, dict]:
    device = get_registry().device("random-gyro", seed=SEED, noise=1e-3)
    config = degenerate_config(
        device, {"seed": SEED, "noise": 1e-3}, iterations=3, experiment={"max_passes": max_passes}
    )
    out = tmp_path / f"run{max_passes}"
    tune(config, out, device=device, plots=False, resume=resume)
    return out, json.loads((out / "summary.json").read_text())


def test_a_run_saves_every_pass_and_counts_it(tmp_path: Path) -> None:
    out, summary = _run(tmp_path, 8)
    passes = sorted(out.glob("iter*/verify*-pass*.nc"))
    assert passes  # a noisy 28 kHz gyro's windows are averaged
    files = [p for p in out.glob("iter*/*.nc") if "model" not in p.name]
    assert summary["points"] == sum(xr.open_dataset(p).sizes["frequency"] for p in files)
    # --resume reads every pass back and ends where the run ended
    stamps = {p: p.stat().st_mtime_ns for p in passes}
    _, again = _run(tmp_path, 8, resume=True)
    assert (again["bias"], again["points"]) == (summary["bias"], summary["points"])
    assert {p: p.stat().st_mtime_ns for p in passes} == stamps  # nothing measured again
    plain, _ = _run(tmp_path, 1)
    assert not list(plain.glob("iter*/*-pass*.nc"))
