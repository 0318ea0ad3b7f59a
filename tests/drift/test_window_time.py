"""When a verification window measured the split: the time its own fit reads it at.

Truth: the simulated gyro's true split at the end of the run (the run never sees it). Random
gyro 787 of ``examples/clock_population.py`` (one tone, a good lab: 0.2 K/h ramp, 0.05 K/√h
walk, acceptance 1 mHz, its structure, first design ±1 V). A window is measured least
informative point first (:func:`sysid_core.measure.information.measuring_order`), so its fit
gives the split of its last points: the drift a run that stops there still carries is counted
from that time, not from the window's middle. Its second window measured 0.37 mHz; counted
from the middle, the rate the lab's prior allows (1.8 mHz/min) over half the window kept the
bound over the acceptance and the run measured a third window; it now stops at the second,
under the acceptance by the truth too.
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np

from sysid_core import tune
from sysid_core.api import load_model
from sysid_core.data.schema import load_dataset, point_times
from sysid_core.drift.windows import to_end_s, window_time
from sysid_core.plugin.registry import get_registry

SEED = 787
GOOD_LAB = {"temperature_ramp_k_per_h": 0.2, "temperature_walk_k_per_sqrt_h": 0.05}
ACCEPTANCE = 1e-3


def test_a_window_under_the_acceptance_ends_the_run_measured_at_its_end(tmp_path: Path) -> None:
    bench = {"clock": True, "seed": SEED, "tones": 1, **GOOD_LAB}
    device = get_registry().device("random-gyro", seed=SEED, bench=bench)
    config = {
        "device": {"name": "random-gyro", "seed": SEED},
        "model": {"structure": device.structure},
        "experiment": {"bias_step": 1.0},
        "tuning": {
            "criterion": "degenerate",
            "electrodes": list(device.electrodes[:6]),
            "start_bias": [0.0] * len(device.electrodes),
            "acceptance_hz": ACCEPTANCE,
            "max_iterations": 300,
        },
    }
    out = tmp_path / "run"
    result = tune(config, out, device=device, plots=False)
    assert result.converged
    assert device.true_split_hz(result.bias) <= ACCEPTANCE
    assert result.iterations == 2
    last = out / f"iter{result.iterations:02d}"
    sweep = load_dataset(last / "verify.nc")
    own = load_model(last / "verify-model.nc")
    t = point_times(sweep, 0)
    assert t is not None
    when = window_time(sweep, own)
    assert when is not None
    # the split of its last points: within the last tenth of the window
    assert when > t.max() - 0.1 * np.ptp(t)
    assert to_end_s(sweep, own) < 0.1 * np.ptp(t)
    # without the window's own fit, its middle
    assert window_time(sweep, None) == float(t.mean())
    summary = json.loads((out / "summary.json").read_text())
    assert summary["history"][-1]["measured_split_hz"] <= ACCEPTANCE
