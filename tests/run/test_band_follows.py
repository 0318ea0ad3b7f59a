"""The band is where to look for modes nobody has located: modes a model predicts, or a sweep
located, outside it are measured where they are.

A lab declares the band around the modes it sees at its start bias; a tuning moves them: to a
target frequency, or to where the electrodes' softening puts the degenerate modes. The
simulated cloverleaf's modes at 0 V are at 4424.0 and 4429.0 Hz; its degenerate modes (B1, B2)
at 4430.04 Hz and its modes tuned to 4435 Hz (B1-B3) both lie outside a band that holds the
modes at 0 V with a margin below them. Every window clipped to such a band missed them.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st
from truths import cloverleaf_config

from sysid_core.data.schema import load_dataset, measured_mask
from sysid_core.run.config import parse_config
from sysid_core.run.pipeline import TuningRun

PLAN = parse_config({"device": {"name": "cloverleaf"}}).experiment.sweep_plan((4385.0, 4445.0))


@given(
    f=st.lists(st.floats(4000.0, 5000.0), min_size=1, max_size=3),
    margin=st.floats(0.0, 50.0),
)
def test_the_band_grows_to_hold_the_modes_and_never_shrinks(f: list[float], margin: float) -> None:
    lo, hi = PLAN.following(f, margin).band_hz
    assert lo <= min(PLAN.band_hz[0], min(f) - margin) + 1e-9
    assert hi >= max(PLAN.band_hz[1], max(f) + margin) - 1e-9
    assert lo > 0
    # the band sweep keeps its number of points, however far the modes are
    assert PLAN.following(f, margin).band().size <= PLAN.band().size + 1


def test_modes_inside_the_band_leave_the_plan_as_it_is() -> None:
    assert PLAN.following([4420.0, 4430.0], 3.0) is PLAN
    assert PLAN.following([np.nan], 3.0) is PLAN


@pytest.mark.parametrize(
    ("criterion", "band", "tuning"),
    [
        ("degenerate", [4412.0, 4429.7], {}),
        (
            "target",
            [4410.0, 4433.0],
            {"target_hz": 4435.0, "electrodes": ["B1", "B2", "B3"]},
        ),
    ],
)
def test_a_run_measures_the_tuned_modes_outside_the_declared_band(
    tmp_path: Path, criterion: str, band: list[float], tuning: dict[str, object]
) -> None:
    cfg = cloverleaf_config(0.01, 4, experiment={"band_hz": band})
    cfg["tuning"] = {**cfg["tuning"], "criterion": criterion, **tuning}
    summary = TuningRun(parse_config(cfg), tmp_path / "run", plots=False).run()
    assert summary.converged, summary.status
    verify = load_dataset(tmp_path / "run" / f"iter{summary.iterations:02d}" / "verify.nc")
    measured = verify["frequency"].values[measured_mask(verify)[0]]
    assert measured.max() > band[1]  # the window around the tuned modes left the band
