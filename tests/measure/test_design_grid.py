"""A design's sweep around modes a law predicts: the fewest points that show them, then more.

Truth: the simulated gyro's modal frequencies (``true_modal_frequencies_hz``), which the run
never sees.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import xarray as xr
from hypothesis import given, settings
from hypothesis import strategies as st

from sysid_core import tune
from sysid_core.measure.lean import (
    QUIET_SCOUT_POINTS,
    SCOUT_MIN_POINTS,
    ModeGuess,
    learning_grids,
    mode_grid,
    scout_grid,
)
from sysid_core.measure.sweeps import SweepPlan
from sysid_core.plugin.registry import get_registry

PLAN = SweepPlan((4385.0, 4445.0), 0.5, 6.0, 0.05, 1.0, 0.01, 20_000)
SCOUTS = SweepPlan((4385.0, 4445.0), 4.0, 6.0, 0.05, 1.0, 0.01, 20_000)


def test_predicted_modes_are_sampled_at_their_centres_and_core_edges() -> None:
    """Two modes 2 Hz apart, bandwidths 0.08 Hz, predicted to 0.01 Hz: three points on each
    (below, at, above its predicted frequency, within its core) and the far points, 8 in all
    on a noisy bench where the mode grid takes 11 or more; a scout of the same modes would
    spread its points over ten bandwidths a side at the scouts' step."""
    guess = ModeGuess.of([4410.0, 4412.0], [0.08, 0.08], [0.01, 0.01])
    cheap, full = learning_grids(guess, False, (PLAN, SCOUTS))
    assert full is not None and cheap.size == SCOUT_MIN_POINTS < full.size
    assert np.array_equal(full, mode_grid(guess, PLAN))
    for f, half in zip(guess.frequencies_hz, guess.core_half_widths(1.5), strict=True):
        near = cheap[np.abs(cheap - f) <= guess.core_half_widths().max() + 1e-9]
        assert np.min(np.abs(near - f)) < 0.01  # one at the predicted mode
        assert np.any(near < f - 0.5 * half) and np.any(near > f + 0.5 * half)  # and a side each
    quiet, _ = learning_grids(guess, False, (PLAN, SCOUTS), quiet=True)
    assert QUIET_SCOUT_POINTS <= quiet.size <= cheap.size


def test_modes_that_may_have_moved_by_an_unknown_amount_are_scouted() -> None:
    guess = ModeGuess.of([4410.0, 4412.0], [0.08, 0.08], [0.5, 0.5])
    cheap, full = learning_grids(guess, True, (PLAN, SCOUTS))
    assert full is None
    assert np.array_equal(cheap, scout_grid(guess, SCOUTS))


@settings(max_examples=60, deadline=None)
@given(
    centre=st.floats(4400.0, 4430.0),
    split=st.floats(0.0, 8.0),
    bandwidth=st.floats(0.005, 1.0),
    sigma=st.floats(0.0, 2.0),
    quiet=st.booleans(),
)
def test_the_cheap_grid_never_takes_more_than_the_mode_grid(
    centre: float, split: float, bandwidth: float, sigma: float, quiet: bool
) -> None:
    guess = ModeGuess.of([centre, centre + split], [bandwidth] * 2, [sigma] * 2)
    cheap, full = learning_grids(guess, False, (PLAN, SCOUTS), quiet)
    assert full is not None
    assert (QUIET_SCOUT_POINTS if quiet else SCOUT_MIN_POINTS) <= cheap.size <= full.size
    assert np.all(np.diff(cheap) > 0)


def test_a_noisy_bench_measures_the_second_steps_at_the_floor_and_tunes(tmp_path: Path) -> None:
    """Random gyro 931 (3 electrodes, B2 and B3 tuned, 60 dB, one tone, a good lab's clock,
    acceptance 2 mHz): its second steps, around modes the scouts' law predicts, took 16 and 13
    points as mode grids (91 points in all, first verified split 2.42 mHz). At the scouts'
    floor they take 8 each, show the modes, and the run converges as before: 78 points, first
    verified split 2.8 mHz, 0.46 mHz true at the end."""
    drift = {"temperature_ramp_k_per_h": 0.2, "temperature_walk_k_per_sqrt_h": 0.05}
    options = {"seed": 931, "noise": 1e-3}
    bench = {"clock": True, "seed": 931, "tones": 1, **drift}
    device = get_registry().device("random-gyro", **options, bench=bench)
    config = {
        "device": {"name": "random-gyro", **options},
        "model": {"drift": "auto", "structure": device.structure},
        "tuning": {
            "criterion": "degenerate",
            "electrodes": list(device.electrodes[:6]),
            "start_bias": [0.0] * len(device.electrodes),
            "acceptance_hz": 0.002,
        },
    }
    out = tmp_path / "run"
    lines: list[str] = []
    result = tune(config, out, device=device, plots=False, progress=lines.append)
    text = "\n".join(lines)
    steps = [out / "iter01" / "exp2.nc", out / "iter01" / "exp4.nc"]
    for path in steps:
        with xr.open_dataset(path) as ds:
            assert ds.sizes["frequency"] == SCOUT_MIN_POINTS, text
    assert not list(out.glob("iter01/exp[24]-*.nc")), text  # they showed the modes
    f = device.true_modal_frequencies_hz(result.bias)
    assert result.converged and f[1] - f[0] <= 0.002, text
