"""examples/window_replay.py against the truth of a bench that does not drift.

Truth: random gyro 117 (19.6 kHz) on a bench with a clock and no drift, at 80 dB. Its windows
measure the split to about 0.1 mHz there and nothing moves between them, so every way of
combining them must predict the next window's split vector to under a millihertz, but the
filter: its rate prior (1.8 mHz/min) lets two windows' noise read as a rate, and after the
minutes of a local design it may miss by more (1.1 mHz, seen); it must miss by no more than its
own forecast allows, the 99 % point of its disc (3.03 of its standard deviations); a replay that
put the truth at the wrong bias or time, or compared vectors in different frames, would miss by
the split's change between windows (tens of mHz). The run's acceptance, 1 µHz, is far under what
its windows can show, and its DAC is exact (no DAC floor stops it): the run never converges and
verifies all its iterations; the replay reads the windows within ten times 0.5 mHz.
"""

from __future__ import annotations

import json
import sys
from pathlib import Path

import numpy as np
from truths import degenerate_config

from sysid_core import tune
from sysid_core.plugin.registry import get_registry

sys.path.insert(0, str(Path(__file__).resolve().parents[2] / "examples"))

from window_replay import WAYS, replay, table

SEED, NOISE = 117, 1e-4


def device() -> object:
    bench = {"clock": True, "seed": SEED}
    return get_registry().device("random-gyro", seed=SEED, noise=NOISE, dac_bits=0, bench=bench)


def test_every_way_predicts_the_next_split_of_a_gyro_that_does_not_drift(tmp_path: Path) -> None:
    run = device()
    model = {"drift": "track", "structure": run.structure}
    options = {"seed": SEED, "noise": NOISE, "dac_bits": 0}
    config = degenerate_config(run, options, iterations=6, acceptance_hz=1e-6, model=model)
    tune(config, tmp_path, device=run, plots=False)
    rows = replay(tmp_path, device(), acceptance_hz=0.0005)
    assert len(rows) >= 2
    for row in rows:
        for way in WAYS:
            if way != "filter":
                assert row[way] < 1.0, (way, row)
        assert row["filter"] < max(1.0, 3.03 * row["filter_sigma"]), row
        # nothing drifts: the truth's split vector does not move in a minute
        assert row["rate_true"] < 1e-9, row
    # the replay's truth is the device's: the length of the split vector is the true split at
    # the bias of the next verification
    history = json.loads((tmp_path / "summary.json").read_text())["history"]
    bias = {h["iteration"]: h["verified_bias"] for h in history}
    truth = device()
    for row in rows:
        true = 1e3 * truth.true_split_hz(bias[int(row["iteration"]) + 1])
        assert abs(row["true"] - true) < 1e-3 * true + 1e-6
    text = table({str(SEED): rows}, {str(SEED): 19.6e3})
    assert "| `tracker` | 8 kHz or more |" in text
    assert np.isfinite([row["tracker"] for row in rows]).all()
