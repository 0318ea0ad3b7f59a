"""The gyro now from its latest verified windows (``[model] drift = "track"``).

Truth: the simulated cloverleaf on a bench whose B1 electrode charges (its effective bias drifts
linearly in time), so the split at a fixed bias moves steadily. A model fitted to design sweeps
an hour earlier misses the gyro now; anchored on later windows at one bias it must match the
gyro now, and its rate must carry it ahead to a time not yet measured.
"""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest
from sysid_cloverleaf import CloverleafGyro

from sysid_core import fit
from sysid_core.data import concat_experiments, experiment_from_measurement
from sysid_core.errors import DataError
from sysid_core.identification.anchor import anchor, split_offset
from sysid_core.identification.drift import offset_drift
from sysid_core.measure.sweeps import design_experiments

F = np.linspace(4385.0, 4445.0, 121)
BIAS = np.array([2.0, 4.4, 0.0])  # near the degenerate bias of seed 1 (2.04, 4.39 V)


def measured(gyro: CloverleafGyro, bias: np.ndarray, f: np.ndarray):
    sweep = gyro.measure(bias, f)
    return experiment_from_measurement(sweep, bias, gyro.electrodes, 15.58, "clover")


def window(gyro: CloverleafGyro) -> np.ndarray:
    f = gyro.true_modal_frequencies_hz(BIAS)
    return np.linspace(f.mean() - 1.0, f.mean() + 1.0, 41)


def split_now(gyro: CloverleafGyro) -> float:
    f = gyro.true_modal_frequencies_hz(BIAS)
    return float(f[1] - f[0])


@pytest.fixture(scope="module")
def charged():
    """A model of the design sweeps, three windows at BIAS 20 min apart an hour later."""
    gyro = CloverleafGyro(seed=1, bench={"clock": True, "charging_v_per_h": [0.05, 0.0, 0.0]})
    design = design_experiments(np.zeros(3), [0, 1], 1.0, (-10.0, 10.0), two_sided=True)
    ds = concat_experiments([measured(gyro, b, F) for b in design]).sel(electrode=["B1", "B2"])
    model = fit(ds)
    windows = []
    for _ in range(3):
        gyro.bench.now_s += 1200.0  # the bench goes on (other work, a fit)
        windows.append(measured(gyro, BIAS, window(gyro)))
    return gyro, model, windows


def test_anchored_model_is_the_gyro_now_and_its_rate_carries_it_ahead(charged) -> None:
    gyro, model, windows = charged
    bias = BIAS[:2]
    found = anchor(model, windows)
    assert found.sweeps == 3 and found.rate is not None
    assert found.t_ref == pytest.approx(gyro.time_s)
    now = found.model_at(model, gyro.time_s)
    truth = gyro.true_modal_frequencies_hz(BIAS)
    # the design's model (fitted around 0 V) misses the split by 0.7 Hz, the anchored one by 2 mHz
    missed = abs(model.split_hz(bias) - (truth[1] - truth[0]))
    assert missed > 0.02
    assert abs(now.split_hz(bias) - (truth[1] - truth[0])) < 0.05 * missed
    assert np.abs(now.modal_frequencies_hz(bias) - truth).max() < 0.05 * missed
    # half an hour ahead, not measured: the rate carries the split (its true move: 21 mHz)
    start = split_now(gyro)
    gyro.bench.now_s += 1800.0
    ahead = found.model_at(model, gyro.time_s)
    moved = split_now(gyro) - start
    assert abs(moved) > 0.01
    predicted = ahead.split_hz(bias) - now.split_hz(bias)
    assert predicted == pytest.approx(moved, rel=0.25)
    seen = offset_drift(ahead)
    assert seen is not None and seen.split_hz_per_h >= 0.75 * abs(moved) * 2  # per hour


def test_one_window_gives_an_offset_and_no_rate(charged) -> None:
    _, model, windows = charged
    found = anchor(model, windows[-1:])
    assert found.rate is None
    moved = found.model_at(model, found.t_ref + 3600.0)
    assert offset_drift(moved) is None  # no rate: the model does not move in time
    assert moved.split_hz(BIAS[:2]) == pytest.approx(
        found.model_at(model, found.t_ref).split_hz(BIAS[:2])
    )


def test_a_window_without_time_stamps_is_refused() -> None:
    gyro = CloverleafGyro(seed=1)
    ds = measured(gyro, BIAS, window(gyro))
    model = fit(
        concat_experiments(
            [
                measured(gyro, b, F)
                for b in design_experiments(np.zeros(3), [0, 1], 1.0, (-10.0, 10.0), True)
            ]
        ).sel(electrode=["B1", "B2"])
    )
    with pytest.raises(DataError, match="time stamp"):
        anchor(model, [ds])
    with pytest.raises(DataError, match="no sweep"):
        anchor(model, [])


def _split_rate(model, found) -> float:
    seen = offset_drift(found.model_at(model, found.t_ref))
    assert seen is not None
    return abs(seen.split_hz_per_h)


def test_windows_seconds_apart_on_a_still_gyro_give_no_split_rate() -> None:
    """Noise is not a drift: two windows 5 s apart at 60 dB on a gyro that does not drift tell
    no rate of the split (the Wald test keeps it out; a common rate stays); the same windows of
    a charging gyro 20 min apart do."""
    still = CloverleafGyro(seed=1, noise=1e-3, bench={"clock": True})
    design = design_experiments(np.zeros(3), [0, 1], 1.0, (-10.0, 10.0), two_sided=True)
    ds = concat_experiments([measured(still, b, F) for b in design]).sel(electrode=["B1", "B2"])
    model = fit(ds)
    close = [measured(still, BIAS, window(still)) for _ in range(2)]
    assert _split_rate(model, anchor(model, close)) < 1e-9
    charging = CloverleafGyro(
        seed=1, noise=1e-3, bench={"clock": True, "charging_v_per_h": [0.05, 0.0, 0.0]}
    )
    apart = []
    for _ in range(2):
        apart.append(measured(charging, BIAS, window(charging)))
        charging.bench.now_s += 1200.0
    assert _split_rate(model, anchor(model, apart)) > 0.01  # Hz/h; charging: about 0.04


def test_a_windows_own_split_moves_the_model_to_it(charged) -> None:
    """The design's model misses the split at BIAS by 0.7 Hz; offset by what the latest
    window's own fit measured there, it has the window's split, and its mean frequency."""
    _, model, windows = charged
    last = windows[-1]
    own = fit(last.sel(electrode=[]))
    moved = dataclasses.replace(model, K0=np.asarray(model.K0) + split_offset(model, last, own))
    bias = np.asarray(last.sel(electrode=["B1", "B2"])["bias"].values[0])  # as the DAC applied it
    assert abs(model.split_hz(bias) - own.split_hz([])) > 0.1
    assert moved.split_hz(bias) == pytest.approx(own.split_hz([]), abs=1e-6)
    before, after = model.modal_frequencies_hz(bias), moved.modal_frequencies_hz(bias)
    assert after.mean() == pytest.approx(before.mean(), abs=1e-3 * abs(np.ptp(before)))
