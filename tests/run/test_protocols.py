"""What each protocol measures in an iteration and how it verifies, called directly.

The full protocol (the paper's) measures its whole design over the band; the lean one locates
the modes once and measures grids around them, far fewer points, for a data set that meets the
rank condition all the same. Both save every sweep before it is used, and both verify a split
at the bias the first model's answer gives, with the evidence that shows both modes. The truth
is the simulated cloverleaf, whose B1/B2 degenerate bias the device knows.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
import scipy.linalg
from truths import cloverleaf_config

from sysid_core.data.schema import measured_mask
from sysid_core.data.validation import check_rank_condition
from sysid_core.run.config import parse_config
from sysid_core.run.lean_protocol import LeanProtocol
from sysid_core.run.pipeline import TuningRun
from sysid_core.run.protocols import FullProtocol
from sysid_core.tuning.criteria import solve_criterion


def run_of(tmp_path: Path, protocol: str) -> TuningRun:
    config = parse_config(cloverleaf_config(0.01, 2, experiment={"protocol": protocol}))
    return TuningRun(config, tmp_path / "run", plots=False)


@pytest.mark.parametrize(("name", "kind"), [("full", FullProtocol), ("lean", LeanProtocol)])
def test_the_configuration_picks_the_protocol(tmp_path: Path, name: str, kind: type) -> None:
    assert type(run_of(tmp_path, name).protocol) is kind


def test_the_full_protocol_measures_its_design_over_the_band(tmp_path: Path) -> None:
    run = run_of(tmp_path, "full")
    folder = tmp_path / "iter01"
    folder.mkdir()
    data, prefit = run.protocol.data(1, run.space.start_bias, folder, None, 0.0)
    design = run.protocol.ctx.design(run.space.start_bias)
    # the biases the DAC applied: the design's, to the DAC's step
    step = run.bench.device.capabilities.bias_resolution or 0.0
    np.testing.assert_allclose(data["bias"].values, design[:, run.space.index], rtol=0, atol=step)
    band = run.protocol.ctx.plan.band()
    assert measured_mask(data).sum(axis=1).tolist() == [band.size] * len(design)
    assert sorted(p.name for p in folder.glob("exp*.nc")) == [
        f"exp{k}.nc" for k in range(len(design))
    ]  # every sweep saved
    assert prefit is None


def test_the_lean_protocol_measures_fewer_points_and_verifies_the_answer(tmp_path: Path) -> None:
    lean, full = run_of(tmp_path / "a", "lean"), run_of(tmp_path / "b", "full")
    got = {}
    for name, run in (("lean", lean), ("full", full)):
        folder = tmp_path / name
        folder.mkdir()
        got[name] = run.protocol.data(1, run.space.start_bias, folder, None, 0.0)[0]
    points = {k: int(measured_mask(d).sum()) for k, d in got.items()}
    assert points["lean"] < points["full"] / 3, points
    # fewer points, the same rank condition (6)
    check_rank_condition(got["lean"]["bias"].values, lean.space.structure_potential)

    run = lean
    model = run.fitter.model(got["lean"])
    result, _ = solve_criterion(run.criterion, model, run.space)
    folder = tmp_path / "verify"
    folder.mkdir()
    ver = run.protocol.verify(result.bias, result, model, folder)
    assert ver.verified, ver
    # the split measured is the truth's at the bias the DAC applied, to the noise's millihertz
    device = run.bench.device.device
    stiffness = device.truth.stiffness(device.applied_bias(result.bias))
    omega2 = scipy.linalg.eigvalsh(stiffness, device.truth.M)
    true_split = float(np.diff(np.sqrt(omega2))[0])
    assert ver.split_hz is not None
    assert abs(ver.split_hz - true_split / (2 * np.pi)) < 1e-3
