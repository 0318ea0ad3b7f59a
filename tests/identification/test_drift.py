"""A common frequency drift estimated from time stamps: by a fit's drift terms
(``sysid_core.api.fit(drift=...)``), and by a run that tracks the gyro (``[model] drift``).

Truth: the simulated bench's temperature ramp moves every frequency by ``tempco · ΔT``, so the
rate is ``−30 ppm/K × ramp``; a fit that undoes it describes the gyro at the latest time stamp.
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
from sysid_cloverleaf import CloverleafGyro

from sysid_core import fit, tune
from sysid_core.data import concat_experiments, experiment_from_measurement
from sysid_core.errors import ConfigError, FitWarning
from sysid_core.measure.sweeps import design_experiments
from sysid_core.run.config import parse_config

RAMP_K_PER_H = 1.5
RATE_PER_H = -30e-6 * RAMP_K_PER_H  # the truth: −45 ppm/h
F = np.linspace(4385.0, 4445.0, 121)
MAIN_JOB = {
    "model": {"drift": "auto"},
    "tuning": {
        "criterion": "degenerate",
        "electrodes": ["B1", "B2"],
        "start_bias": [0.0] * 3,
        "acceptance_hz": 0.002,
        "max_iterations": 4,
    },
}


def sweeps(gyro: CloverleafGyro):
    design = design_experiments(np.zeros(3), [0, 1], 1.0, (-10.0, 10.0), two_sided=True)
    parts = [
        experiment_from_measurement(gyro.measure(b, F), b, gyro.electrodes, 15.58, "cloverleaf")
        for b in design
    ]
    return concat_experiments(parts).sel(electrode=["B1", "B2"])


def test_the_rate_of_a_temperature_ramp_is_estimated_and_undone() -> None:
    warm = CloverleafGyro(seed=2, bench={"clock": True, "temperature_ramp_k_per_h": RAMP_K_PER_H})
    ds = sweeps(warm)
    model = fit(ds, drift=True)
    assert model.meta["drift_rate_per_h"] == pytest.approx(RATE_PER_H, rel=0.2)
    assert model.meta["drift_reference_time_s"] == pytest.approx(warm.time_s)
    # the model is the gyro at the latest time stamp: its modes at the base bias are the truth now
    now = warm.true_modal_frequencies_hz([0.0, 0.0, 0.0])
    still = fit(ds)  # a time-invariant model averages over the sweeps
    err_drift = np.abs(model.modal([0.0, 0.0]).frequencies_hz - now).max()
    err_still = np.abs(still.modal([0.0, 0.0]).frequencies_hz - now).max()
    assert err_drift < 0.2 * err_still


def test_data_without_time_stamps_are_fitted_without_drift_and_say_so() -> None:
    ds = sweeps(CloverleafGyro(seed=2))
    with pytest.warns(FitWarning, match="drift is not modelled"):
        model = fit(ds, drift=True)
    assert "drift_rate_per_h" not in model.meta


def test_a_run_on_a_ramp_tracks_the_gyro_and_claims_no_drift_it_did_not_measure(
    tmp_path: Path,
) -> None:
    """The cloverleaf on a 1.5 K/h ramp converges at its second answer, each anchored on the one
    window before it: no two windows at one bias, no fit over an hour, so no common rate was
    measured and none is reported (a rate of 0 would claim a gyro that does not drift). The
    rates a run measures are checked against the truth in
    :func:`test_epoch_offsets_and_a_trend_see_a_temperature_ramp` and
    tests/drift/test_tracking.py."""
    device = CloverleafGyro(seed=1, bench={"clock": True, "temperature_ramp_k_per_h": RAMP_K_PER_H})
    lines: list[str] = []
    config = {"device": {"name": "cloverleaf", "seed": 1}, **MAIN_JOB}
    result = tune(config, tmp_path / "run", device=device, progress=lines.append, plots=False)
    truth = device.true_modal_frequencies_hz(result.bias)  # at the end of the run
    assert result.converged and truth[1] - truth[0] < 0.002
    assert any("the model anchored on 1 verified window(s)" in line for line in lines)
    assert not any("mHz/h common" in line for line in lines)
    assert result.drift_common_hz_per_h is None
    summary = json.loads((tmp_path / "run" / "summary.json").read_text())
    assert summary["drift_common_hz_per_h"] is None


def test_the_drift_key_is_checked() -> None:
    with pytest.raises(ConfigError, match="drift"):
        parse_config({"device": {"name": "cloverleaf"}, "model": {"drift": "sometimes"}})


@pytest.mark.parametrize("former", ["common", "offsets", "trend"])
def test_the_former_fit_terms_are_not_run_policies(former: str) -> None:
    """The fit's drift terms stay in ``fit``; a run configuration naming one is told where."""
    config = {"device": {"name": "cloverleaf"}, "model": {"drift": former}}
    with pytest.raises(ConfigError, match=rf'config: \[model\] drift = "{former}" is no longer'):
        parse_config(config)
    with pytest.raises(ConfigError, match=rf'fit\(data, drift="{former}"\)'):
        parse_config(config)


# --------------------------------------------------------------------------- offsets and trend
def epochs_of(ds, epochs):
    return ds.assign_coords(epoch=("experiment", np.asarray(epochs, dtype=int)))


def two_epochs(gyro: CloverleafGyro):
    """The design (epoch 1), then the base and one step again (epoch 2), measured in turn."""
    first = sweeps(gyro)
    again = [np.zeros(3), np.array([1.0, 0.0, 0.0])]
    parts = [
        experiment_from_measurement(gyro.measure(b, F), b, gyro.electrodes, 15.58, "cloverleaf")
        for b in again
    ]
    second = concat_experiments(parts).sel(electrode=["B1", "B2"])
    ds = concat_experiments(
        [epochs_of(first, [1] * first.sizes["experiment"]), epochs_of(second, [2, 2])]
    )
    return ds


def test_epoch_offsets_and_a_trend_see_a_temperature_ramp() -> None:
    """The common rate by the trend: the ramp's, within 20 %; by the offsets' slope, 50 %.

    The offsets are constant per epoch while the ramp goes on during the design's five sweeps
    (an hour): the time-invariant bias terms of the first epoch take part of it (measured: −0.275
    against −0.199 Hz/h); the trend follows every point's time stamp (−0.194).
    """
    from sysid_core.identification.drift import offset_drift

    warm = CloverleafGyro(seed=2, bench={"clock": True, "temperature_ramp_k_per_h": RAMP_K_PER_H})
    ds = two_epochs(warm)
    assert list(np.unique(ds["epoch"].values)) == [1, 2]  # the epoch survives the join
    now = warm.true_modal_frequencies_hz([0.0, 0.0, 0.0])
    expected = RATE_PER_H * now.mean()  # Hz per hour
    still = fit(ds)
    # the offsets' model is the latest epoch's average gyro (two sweeps, 20 minutes), the
    # trend's the gyro at the last time stamp: 0.098 and 0.012 Hz off, 0.286 without either
    for drift, rel, better in (("offsets", 0.5, 0.5), ("trend", 0.2, 0.1)):
        model = fit(ds, drift=drift)
        seen = offset_drift(model)
        assert seen is not None
        assert seen.common_hz_per_h == pytest.approx(expected, rel=rel), drift
        # the model is the gyro of the latest epoch (offsets) or time stamp (trend)
        err = np.abs(model.modal([0.0, 0.0]).frequencies_hz - now).max()
        err_still = np.abs(still.modal([0.0, 0.0]).frequencies_hz - now).max()
        assert err < better * err_still, drift
    assert len(fit(ds, drift="offsets").meta["drift_offsets"]) == 1


def test_a_frozen_gyro_shows_no_drift_and_the_same_model() -> None:
    """Without drift, offsets and trend are ~0 and the model is the time-invariant one."""
    from sysid_core.identification.drift import offset_drift

    clock = CloverleafGyro(seed=2, bench={"clock": True})
    ds = two_epochs(clock)
    still = fit(ds)
    f_still = still.modal([0.0, 0.0]).frequencies_hz
    for drift in ("offsets", "trend"):
        model = fit(ds, drift=drift)
        seen = offset_drift(model)
        assert seen is not None
        # the noise's doing only: under 2 % of the ramp's rate of the other tests
        assert abs(seen.common_hz_per_h) < 0.02 * abs(RATE_PER_H * 4430.0), drift
        assert np.abs(model.modal([0.0, 0.0]).frequencies_hz - f_still).max() < 2e-3, drift


def test_a_bad_drift_option_is_refused() -> None:
    ds = sweeps(CloverleafGyro(seed=2, bench={"clock": True}))
    with pytest.raises(ConfigError, match="drift 'offset'"):
        fit(ds, drift="offset")
    with pytest.raises(ConfigError, match="not identified"):
        fit(ds, drift="offsets+trend")
