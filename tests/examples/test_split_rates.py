"""examples/split_rates.py: the true split's rate behind the drift estimator's prior.

Truth: random gyros 273 (1.9 kHz) and 274 (27.7 kHz) on the simulated benches of
examples/drift_population.py. The good lab's ramp scales the whole stiffness and moves no
split; the uncontrolled lab's charging moves both, 0.4 and 6.5 mHz/min: a 15-fold range in
mHz/min that is about one rate in ppm of the frequency per hour (13 and 14).
"""

from __future__ import annotations

import sys
from pathlib import Path

import pytest

sys.path.insert(0, str(Path(__file__).resolve().parents[2] / "examples"))

from split_rates import main, split_rate


def test_a_good_labs_ramp_moves_no_split() -> None:
    assert split_rate(273, "good")["mhz_per_min"] < 1e-3


def test_the_labs_rates_are_one_rate_in_ppm_of_the_frequency() -> None:
    slow, fast = split_rate(273, "lab"), split_rate(274, "lab")
    assert fast["mhz_per_min"] > 10 * slow["mhz_per_min"]
    assert fast["ppm_per_h"] == pytest.approx(slow["ppm_per_h"], rel=0.3)
    for r in (slow, fast):  # the same rate in both units
        assert r["ppm_per_h"] == pytest.approx(
            r["mhz_per_min"] * 1e-3 / 60.0 * 3600.0 / r["frequency_hz"] * 1e6, rel=1e-12
        )


def test_the_command_prints_a_line_per_gyro(capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["--bench", "lab", "--seeds", "273-274"]) == 0
    out = capsys.readouterr().out.splitlines()
    assert out[0].startswith("gyro 273:") and out[1].startswith("gyro 274:")
    assert out[-1].startswith("ppm/h: median")
