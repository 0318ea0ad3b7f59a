"""Population studies (``[study] gyros``): one random gyro per run, its own structure, the true
splits per iteration against the generator's exact answer; bad settings refused before any run.
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
import xarray as xr
from sysid_random_gyro import RandomGyro

from sysid_core import errors
from sysid_core.batch.study.runner import load_study_config, run_study

POPULATION = """
[device]
name = "random-gyro"
[tuning]
criterion = "degenerate"
electrodes = ["B1", "B2"]
[experiment]
resolution_hz = 1.0
verify_resolution_hz = 0.02
[study]
gyros = 3
structures = ["auto"]
iterations = 2
"""


def _cfg(tmp_path: Path, text: str = POPULATION):
    path = tmp_path / "study.toml"
    path.write_text(text)
    return load_study_config(path)


def test_population_study_tunes_each_gyro_with_its_own_structure(tmp_path: Path) -> None:
    out = tmp_path / "out"
    full = run_study(_cfg(tmp_path), out, executor="local", plots=True)
    assert full["failed"] == 0 and full["population"] is True
    assert full["median_points"] > 0 and full["median_bench_time_s"] > 0
    ds = xr.open_dataset(out / "results.nc", engine="h5netcdf")
    assert list(ds["model"].values) == ["auto"]
    for k in range(3):
        gyro = RandomGyro(seed=k)  # device seeds 0, 1, 2
        result = json.loads((out / "results" / f"least-squares-auto-{k:03d}.json").read_text())
        used = json.loads((out / "runs" / result["key"] / "config.json").read_text())
        assert used["config"]["model"]["structure"] == gyro.structure
        assert result["start"] == [0.0] * len(gyro.electrodes)
        assert result["points"] > 0 and result["bench_time_s"] > 0  # sysid_core.clock.benchtime
        for it in result["iterations"]:
            # the study's true split is the generator's truth at the applied bias
            assert it["true_split_hz"] == pytest.approx(gyro.true_split_hz(it["bias"]), abs=1e-12)
            np.testing.assert_allclose(
                it["true_degenerate_bias"], gyro.true_degenerate_bias(), atol=1e-9
            )
    per_it = full["summary"]["least-squares"]["auto"]
    assert per_it["1"]["mean_bias"] is None  # biases of different gyros are not averaged
    assert per_it["2"]["under_2mHz"] <= per_it["2"]["under_10mHz"] <= 3
    splits = ds["true_split_hz"].sel(objective="least-squares", model="auto").values
    assert np.all(splits[:, 1] < splits[:, 0])  # the second iteration improved every gyro
    measured = ds["measured_split_hz"].sel(objective="least-squares", model="auto").values
    assert per_it["2"]["worst_step_ratio"] == pytest.approx(np.max(splits[:, 1] / measured[:, 0]))
    report = (out / "report.md").read_text()
    assert "| least-squares | auto | 2 | 3 |" in report
    assert (out / "fig-least-squares-auto-population.png").stat().st_size > 10_000


@pytest.mark.parametrize(
    ("old", "new", "says"),
    [
        ("gyros = 3", "gyros = 3\ngrid = [0, 1]", "[study] gyros runs every gyro from its native"),
        ("gyros = 3\n", "", "'auto' is for population studies"),
        ('electrodes = ["B1", "B2"]', 'electrodes = ["B1", "B7"]', "['B7'] not on 'random-gyro'"),
        ("gyros = 3", "gyros = 0", "[study] gyros"),
    ],
)
def test_bad_population_settings_are_refused_before_any_run(
    tmp_path: Path, old: str, new: str, says: str
) -> None:
    out = tmp_path / "out"
    with pytest.raises(errors.ConfigError) as info:
        run_study(_cfg(tmp_path, POPULATION.replace(old, new)), out, executor="local")
    assert says in str(info.value)
    assert not out.exists()


def test_auto_needs_a_device_that_names_its_structure(tmp_path: Path) -> None:
    text = POPULATION.replace('name = "random-gyro"', 'name = "cloverleaf"').replace(
        "[tuning]", "[tuning]\nstart_bias = [0.0, 0.0, 0.0]"
    )
    with pytest.raises(errors.ConfigError, match="needs a device that names its model"):
        run_study(_cfg(tmp_path, text), tmp_path / "out", executor="local")
