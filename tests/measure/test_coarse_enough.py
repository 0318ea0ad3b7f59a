"""A verification window too coarse to resolve the modes stands when its split is far over.

With one tone every point of a verification costs a dwell (10 s on the cloverleaf). A first
answer lands 2-170 mHz from degenerate, and its window, widened by the answer's uncertainty,
steps 0.15 Hz against bandwidths of 0.08 Hz: only ``resolved`` fails, and the fine window that
followed (22 points, 3.7 minutes) changed the split by at most 2 % in 155 clock runs, never the
verdict. Truth: the simulated cloverleaf's modes at the window's bias.
"""

from __future__ import annotations

import numpy as np
import pytest
from sysid_cloverleaf import CloverleafGyro

from sysid_core import fit
from sysid_core.data.schema import experiment_from_measurement
from sysid_core.measure.evidence import Check, WindowAssessment, assess_window
from sysid_core.measure.verification import COARSE_ENOUGH

BIAS = np.array([2.0407, 4.3882, 0.0])  # degenerate modes near 4430 Hz


def _window(dv: float, step: float, seed: int) -> tuple[WindowAssessment, float]:
    """A lean verification grid at ``BIAS + dv`` on B1: ``step`` near the modes, 4 anchors."""
    device = CloverleafGyro(seed=seed)
    bias = BIAS + np.array([dv, 0.0, 0.0])
    true = device.true_modal_frequencies_hz(bias)
    c = float(np.mean(true))
    core = c + np.arange(-0.45, 0.45 + 1e-9, step)
    freqs = np.sort(np.r_[core, c + np.array([-3.0, -1.5, 1.5, 3.0])])
    sweep = experiment_from_measurement(
        device.measure(bias, freqs), bias, list(device.electrodes), device.structure_potential, "c"
    )
    model = fit(sweep.isel(electrode=[]), structure="act")
    return assess_window(sweep, model), float(true[1] - true[0])


@pytest.mark.parametrize(("dv", "seed"), [(0.05, 3), (0.1, 4), (0.2, 5)])
def test_a_coarse_window_measures_a_far_split_and_stands(dv: float, seed: int) -> None:
    coarse, true = _window(dv, 0.15, seed)
    assert [c.name for c in coarse.checks if not c.passed] == ["resolved"]
    # the coarse fit's split is the true one within a few percent (noise 1e-3, bandwidth 0.08)
    assert coarse.split_hz == pytest.approx(true, rel=0.03)
    acceptance = true / (2 * COARSE_ENOUGH)  # the split is 20 acceptances: the window stands
    stands = coarse.enough(COARSE_ENOUGH * acceptance)
    assert stands.ok
    assert "it stands" in next(c.detail for c in stands.checks if c.name == "resolved")
    assert stands.coarse and not coarse.coarse
    assert not coarse.ok  # the original is not changed
    # a split under the limit does not stand: the run measures its fine window, as before
    assert not coarse.enough(2 * true).ok
    fine, _ = _window(dv, 0.05, seed)
    assert fine.ok
    assert coarse.split_hz == pytest.approx(fine.split_hz, rel=0.03)


def test_only_a_window_that_fails_nothing_but_resolution_stands() -> None:
    checks = [
        Check("fit", True, ""),
        Check("resolved", False, "step 0.15 Hz"),
        Check("observed", False, "the model peaks at 5 times the data's peak"),
    ]
    modes = np.array([4430.0, 4430.1])
    w = WindowAssessment((4427.0, 4433.0), 1.5, False, modes, np.array([0.08, 0.08]), checks)
    assert not w.enough(1e-3).ok  # an invented peak between the points: the fine window decides
    assert w.enough(1e-3) is w
