"""A whole-band sweep that does not locate narrow modes is followed by windows around them.

Truth: the simulated gyro's modal frequencies (``true_modal_frequencies_hz``), which the run
never sees.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np
from truths import degenerate_config

from sysid_core import tune
from sysid_core.measure.evidence import WindowAssessment
from sysid_core.measure.lean import MAX_FINE_HALF_POINTS
from sysid_core.measure.sweeps import SweepPlan
from sysid_core.measure.zoom import zoom_grid
from sysid_core.plugin.registry import get_registry

ACCEPTANCE = 0.002


def _gyro_112(
    tmp_path: Path, experiment: dict[str, Any], iterations: int = 4
) -> tuple[Path, Any, Any, list[str]]:
    """A run of random gyro 112 (frozen bench, 60 dB): folder, device, result, lines."""
    device = get_registry().device("random-gyro", seed=112, noise=1e-3)
    config = degenerate_config(
        device,
        {"seed": 112, "noise": 1e-3},
        iterations=iterations,
        model={"structure": device.structure},
        experiment=experiment,
    )
    out = tmp_path / "run"
    lines: list[str] = []
    result = tune(config, out, device=device, plots=False, progress=lines.append)
    return out, device, result, lines


def test_a_narrow_mode_gyro_is_located_by_windows_not_by_a_denser_band(tmp_path: Path) -> None:
    """Random gyro 112 (1.49 kHz, bandwidths 0.045 / 0.075 Hz, 60 dB SNR, frozen bench): its
    61-point locating sweep steps 1.66 Hz and its fit fails. Measured: windows around the
    modes it fitted show them (54 points), and the run converges at a true split of 0.01 mHz
    in 496 points; with the band swept four times as densely instead (200 points, which failed
    too) the run ended 715 mHz apart after 2406 points."""
    out, device, result, lines = _gyro_112(tmp_path, {})
    assert (out / "iter01" / "exp0-zoom.nc").exists()
    assert not list(out.glob("iter01/*locate4.nc"))
    f = device.true_modal_frequencies_hz(result.bias)
    assert f[1] - f[0] <= ACCEPTANCE
    assert result.points < 1000
    said = [line for line in lines if "exp0.nc: the sweep does not show both modes" in line]
    assert said and "; windows around 14" in said[0]


def test_a_probe_that_misses_narrow_modes_is_followed_by_windows_not_the_band(
    tmp_path: Path,
) -> None:
    """The same gyro with a probe first (``probe = true``): its 16 points step 6.6 Hz and its fit
    fails; windows around the modes it placed (cheaper than the 61-point locating band) show
    them. Measured: no locating band in the first design. Its scouts step 26 bandwidths (8
    points; 19 with 11 points) and the first answer's law is a guess: with 11-point scouts a
    true split of 0.95 mHz after 4 iterations (178 points), with 8 a window missed and a local
    design, 0.32 mHz after 5 (391 points; 514 since the probe takes 16 points, 6.6 Hz apart,
    and its windows 34); with the design's sweeps around predicted modes at the scouts' floor
    too, 0.17 mHz after 5 (226 points)."""
    out, device, result, lines = _gyro_112(tmp_path, {"probe": True}, iterations=5)
    assert (out / "iter01" / "exp0-zoom.nc").exists()
    assert not list(out.glob("iter01/*locate*.nc"))
    f = device.true_modal_frequencies_hz(result.bias)
    assert f[1] - f[0] <= ACCEPTANCE
    said = [line for line in lines if "exp0.nc: a probe of 16 points" in line]
    assert said and "; windows around 148" in said[0] and said[0].endswith("first")


def _plan() -> SweepPlan:
    return SweepPlan(
        band_hz=(1438.5, 1538.2),
        resolution_hz=0.01,
        refine_span_hz=6.0,
        refine_resolution_hz=0.01,
        verify_span_hz=0.1,
        verify_resolution_hz=0.001,
        max_points=4001,
    )


def _failed(modes: list[float], bw: list[float], step: float) -> WindowAssessment:
    return WindowAssessment(
        window_hz=(1438.5, 1538.2),
        step_hz=step,
        band=True,
        frequencies_hz=np.array(modes),
        bandwidth_hz=np.array(bw),
    )


def test_the_windows_put_points_within_a_bandwidth_of_modes_half_a_step_off() -> None:
    """Fitted modes half a step from the truth still get points within a bandwidth of it."""
    plan = _plan()
    swept = np.linspace(1438.5, 1538.2, 61)
    step = float(swept[1] - swept[0])
    truth = np.array([1485.99, 1490.74])
    fitted = truth + np.array([-0.5, 0.5]) * step * 0.99
    points = zoom_grid(swept, _failed(list(fitted), [0.045, 0.075], step), plan, limit=241)
    assert points is not None
    assert points.size < 241
    assert points.size <= 2 * (2 * MAX_FINE_HALF_POINTS + 1) + 6
    nearest = np.min(np.abs(points[:, None] - truth[None, :]), axis=0)
    assert np.all(nearest <= 0.075)


def test_no_windows_for_modes_outside_the_band_or_a_sweep_that_was_not_the_band() -> None:
    plan = _plan()
    swept = np.linspace(1438.5, 1538.2, 61)
    outside = _failed([1400.0, 1490.0], [0.05, 0.05], 1.66)
    assert zoom_grid(swept, outside, plan, limit=241) is None
    window = np.linspace(1480.0, 1495.0, 20)
    assert zoom_grid(window, _failed([1486.0, 1490.0], [0.05, 0.05], 0.8), plan, 241) is None
    assert zoom_grid(swept, _failed([1486.0, 1490.0], [0.05, 0.05], 1.66), plan, limit=10) is None
