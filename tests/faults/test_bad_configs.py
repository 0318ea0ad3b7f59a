"""Faults of configuration: every bad setting is refused before the first measurement.

A bad value, a binary file given as the configuration, a wrong type through the Python API: one
line naming what is wrong, exit status 1, and nothing measured or written.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import pytest
from faulting import (
    EXAMPLE_DATA,
    one_error_line,
    sysid,
    tables,
)
from truths import write_toml

from sysid_core.api import fit
from sysid_core.data.schema import load_dataset


@pytest.mark.parametrize(
    ("change", "message"),
    [
        ({"experiment": {"band_hz": [4445.0, 4385.0]}}, "[experiment] band_hz"),
        ({"experiment": {"resolution_hz": 1e-6}}, "max_points"),
        ({"experiment": {"band_hz": [1.0, 2.0], "resolution_hz": 0.05}}, "does not overlap"),
        ({"experiment": {"band_hz": [4400.0, 4400.2], "resolution_hz": 0.5}}, "at least 11"),
        ({"solver": {"name": "clarabel", "max_iter": "x"}}, "option 'max_iter' of solver"),
        ({"solver": {"name": "scs", "max_iters": 2.5}}, "option 'max_iters' of solver 'scs'"),
        ({"objective": {"name": "minimax", "tie_tol": "x"}}, "option 'tie_tol' of objective"),
        ({"model": {"objective": "minimax"}}, "[model] objective has moved to [objective] name"),
        (
            {"tuning": {"options": {"bias_tol": -1.0}, "criterion": "min-max-bias"}},
            "option 'bias_tol' of tuning criterion 'min-max-bias' must be a finite number > 0",
        ),
        ({"device": {"structure_potential": "abc"}}, "'structure_potential'"),
        ({"device": {"broken": "electrodes"}}, "'electrodes' must be a non-empty"),
        ({"device": {"broken": "limits"}}, "'bias_limits' must be two finite numbers"),
        ({"tuning": {"start_bias": [0.0, 20.0, 0.0]}}, "outside the device's limits"),
        (
            {"tuning": {"target_hz": 4430.0, "criterion": "target", "tolerance_hz": -1}},
            "tolerance_hz",
        ),
    ],
)
def test_bad_settings_fail_before_measuring_and_leave_nothing(
    tmp_path: Path, change: dict[str, dict[str, Any]], message: str
) -> None:
    t = tables(device={"fault": "raise"})  # a measurement would fail differently
    for table, values in change.items():
        t[table] = {**t.get(table, {}), **values}
    cfg = write_toml(tmp_path / "c.toml", t)
    out = tmp_path / "run"
    done = sysid("tune", str(cfg), "--out", str(out), "--no-plots")
    assert done.returncode == 1
    line = one_error_line(done.stderr)
    assert message in line, line
    assert "lost the connection" not in line
    assert not out.exists()


def test_binary_config_is_named(tmp_path: Path) -> None:
    cfg = tmp_path / "c.toml"
    cfg.write_bytes(bytes(range(256)))
    done = sysid("tune", str(cfg))
    assert done.returncode == 1
    assert f"{cfg} is not a text file" in one_error_line(done.stderr)


def test_python_api_type_errors() -> None:
    ds = load_dataset(EXAMPLE_DATA)
    with pytest.raises(TypeError, match="structure must be a name"):
        fit(ds, 123)  # type: ignore[arg-type]
    with pytest.raises(TypeError, match=r"xarray\.Dataset"):
        fit("examples/cloverleaf-3exp.nc")  # type: ignore[arg-type]
