"""Faults of evidence: no run claims a tuning its measurements do not show.

A goal out of reach, modes far from the prediction, a window without modes, a target frequency
missed: each run ends honestly (not converged, or with the modes located), never with a claim.
"""

from __future__ import annotations

import json
import warnings
from pathlib import Path

import numpy as np
import pytest
from faulting import (
    FAST,
    tables,
)

from sysid_core.api import fit
from sysid_core.errors import (
    FitWarning,
    UnreachableTuningError,
)
from sysid_core.plugin.interfaces import Goal
from sysid_core.plugin.registry import get_registry
from sysid_core.run.config import parse_config
from sysid_core.run.pipeline import TuningRun


def test_target_out_of_reach_is_not_claimed_and_the_modes_are_located(tmp_path: Path) -> None:
    """QA's case: target 4390 Hz claimed "converged", true modes 20.8 Hz apart."""
    cfg = parse_config(
        {
            "device": {"name": "cloverleaf", "seed": 1},
            "tuning": {
                "criterion": "target",
                "target_hz": 4390.0,
                "max_iterations": 2,
                "acceptance_hz": 0.05,
            },
            "experiment": FAST,
        }
    )
    run = TuningRun(cfg, tmp_path / "run", plots=False)
    with pytest.raises(UnreachableTuningError, match="4390"):
        run.run()
    summary = json.loads((tmp_path / "run" / "summary.json").read_text())
    assert summary["converged"] is False
    first = summary["history"][0]
    truth = run.device.device.true_modal_frequencies_hz(first["verified_bias"])
    assert np.ptp(truth) > 15  # far from a tuning
    assert first["verification"] == "located"  # only a whole-band sweep found the modes
    np.testing.assert_allclose(first["measured_frequencies_hz"], truth, atol=0.1)
    assert first["evidence"][-1]["band"] and first["evidence"][-1]["ok"]


@pytest.mark.parametrize("criterion", ["degenerate", "min-max-bias"])
def test_modes_far_from_the_prediction_are_never_a_false_success(
    tmp_path: Path, criterion: str
) -> None:
    """A bias law far from v**2: the first prediction misses; every claim is checked."""
    tuning = {"criterion": criterion, "max_iterations": 3, "acceptance_hz": 0.01}
    if criterion == "min-max-bias":
        tuning["electrodes"] = ["B1", "B2", "B3"]
    cfg = parse_config(tables(device={"warp": 0.06}, tuning=tuning))
    run = TuningRun(cfg, tmp_path / "run", plots=False)
    summary = run.run()
    gyro = run.device.device
    first = gyro.true_modal_frequencies_hz(summary.history[0].verified_bias)
    assert np.ptp(first) > 0.05  # the first iteration really missed (truth)
    for rec in summary.history:
        true = gyro.true_modal_frequencies_hz(rec.verified_bias)
        if rec.verification == "verified":
            np.testing.assert_allclose(rec.measured_frequencies_hz, true, atol=3e-3)
    if summary.converged:
        final = gyro.true_modal_frequencies_hz(summary.bias)
        assert np.ptp(final) <= 0.01 + 3e-3
    assert summary.converged == (
        summary.history[-1].verification == "verified"
        and summary.split_hz is not None
        and summary.split_hz <= 0.01
    )


def test_window_without_modes_is_not_evidence() -> None:
    """The single-bias fit of a window 10 Hz from both modes invents two modes inside it."""
    from sysid_cloverleaf import CloverleafGyro

    from sysid_core.data.schema import experiment_from_measurement
    from sysid_core.measure.evidence import assess_window

    gyro = CloverleafGyro(seed=1)

    def assess(bias: list[float], lo: float, hi: float, n: int, band: bool = False):
        f = np.linspace(lo, hi, n)
        v_gyro = gyro.structure_potential
        ds = experiment_from_measurement(gyro.measure(bias, f), bias, list(gyro.electrodes), v_gyro)
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", FitWarning)  # not the subject here
            model = fit(ds.isel(electrode=[]), "act", 1)
        return assess_window(ds, model, band=band)

    far = [-10.0, -10.0, -10.0]  # true modes 4392.6 / 4413.4 Hz
    assert not assess(far, 4403.4, 4404.4, 101).ok
    assert not assess(far, 4392.0, 4393.2, 121).ok  # one mode inside, the other 21 Hz away
    band = assess(far, 4385.0, 4445.0, 121, band=True)
    assert band.ok
    np.testing.assert_allclose(band.frequencies_hz, gyro.true_modal_frequencies_hz(far), atol=0.1)
    tuned = assess([2.0405, 4.3874, 0.0], 4429.5, 4430.5, 101)
    assert tuned.ok, tuned.failures()


def test_target_counts_only_with_its_frequency_error(tmp_path: Path) -> None:
    goals = _target_goals([4430.004, 4430.005], target=4430.0, tolerance=1e-3)
    assert [g.name for g in goals] == ["split", "frequency error"]
    assert goals[0].met and not goals[1].met
    cfg = parse_config(
        {
            "device": {"name": "cloverleaf", "seed": 1},
            "tuning": {
                "criterion": "target",
                "target_hz": 4430.0,
                "max_iterations": 1,
                "tolerance_hz": 1e-4,
                "acceptance_hz": 0.5,
            },
            "experiment": FAST,
        }
    )
    summary = TuningRun(cfg, tmp_path / "run", plots=False).run()
    assert summary.verified and summary.split_hz < 0.5
    assert not summary.converged
    assert "frequency error" in summary.status and "goals not met" in summary.status


def _target_goals(freqs: list[float], target: float, tolerance: float) -> list[Goal]:
    crit = get_registry().criterion(
        "target", target_hz=target, tolerance_hz=tolerance, solver=get_registry().solver("clarabel")
    )
    return crit.goals(np.array(freqs), acceptance_hz=0.01)
