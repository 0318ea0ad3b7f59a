"""A local fit that finds the goal unreachable: the fit of every sweep so far may reach it.

Truth: random gyro 119 (25.8 kHz, input dynamics, degenerate near B1 = 5.67 V, B2 = 4.13 V,
42.8 Hz apart at 0 V) at 60 dB SNR. Its first fit, from ±1 V around 0 V, puts the degenerate bias
outside the limits; the run moves to the best reachable bias (B2 = 10 V) and from then on fits
the sweeps near its bias, whose ±0.25 V designs cannot see the curvature that brings the modes
together 6 V away. Measured before the fallback: stuck at B2 = 10 V, 5.2 Hz at the end of 4
iterations; with it, the third iteration answers from the fit of every sweep, and the run
leaves the limit for the true bias: 48 mHz after the fourth iteration with grids of one shape,
99 mHz after the sixth with grids chosen by information per second (19 Hz after the fourth:
its verification windows take another path; 1.3 mHz after the seventh). The bench has no
clock: with one, the stiffness law's test leaves out the part that moves both modes together
(a drift's), the first fit keeps the linear law (9.3 against a threshold of 13.3), its answer
is inside the limits, and the run ends 0.84 Hz apart after 4 iterations by another path.
"""

from __future__ import annotations

from pathlib import Path

from truths import degenerate_config

from sysid_core import tune
from sysid_core.plugin.registry import get_registry


def test_a_run_stuck_at_a_limit_answers_from_every_sweep(tmp_path: Path) -> None:
    device = get_registry().device("random-gyro", seed=119, noise=1e-3)
    config = degenerate_config(device, {"seed": 119, "noise": 1e-3}, iterations=6)
    lines: list[str] = []
    result = tune(config, tmp_path, device=device, plots=False, progress=lines.append)
    assert any("the fit of every sweep so far reaches the goal" in line for line in lines)
    assert device.true_split_hz(result.bias) < 0.2  # 5.2 Hz without the fallback
    assert abs(result.bias[1] - 4.13) < 0.5  # away from the limit, near the true bias
