"""The study: local and dask executors agree, results persist, failures are reported."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from sysid_core import errors
from sysid_core.study import load_study_config, run_study

SMALL = """
[device]
name = "cloverleaf"
[model]
order = 1
objective = "least-squares"
[tuning]
electrodes = ["B1", "B2"]
start_bias = [0.0, 0.0, 0.0]
[experiment]
resolution_hz = 1.0
verify_resolution_hz = 0.02
refine_resolution_hz = 0.2
[study]
grid = [-3, 3]
structures = ["act"]
iterations = 2
"""


def _assert_close(a, b):
    if isinstance(a, dict):
        assert a.keys() == b.keys()
        for k in a:
            _assert_close(a[k], b[k])
    elif isinstance(a, list):
        assert len(a) == len(b)
        for x, y in zip(a, b, strict=True):
            _assert_close(x, y)
    elif isinstance(a, float):
        assert a == pytest.approx(b, rel=1e-9, abs=1e-12)
    else:
        assert a == b


def _cfg(tmp_path: Path, text: str = SMALL):
    path = tmp_path / "study.toml"
    path.write_text(text)
    return load_study_config(path)


def test_dask_and_local_executors_agree(tmp_path):
    cfg = _cfg(tmp_path)
    local = run_study(cfg, tmp_path / "local", executor="local", plots=False)
    dask = run_study(cfg, tmp_path / "dask", executor="dask", workers=2, plots=False)
    assert local["runs"] == dask["runs"] == 4
    # Identical up to floating-point summation order (BLAS threads differ between processes).
    _assert_close(local["summary"], dask["summary"])
    for key in ("least-squares-act-000", "least-squares-act-003"):
        a = json.loads((tmp_path / "local" / "results" / f"{key}.json").read_text())
        b = json.loads((tmp_path / "dask" / "results" / f"{key}.json").read_text())
        for ra, rb in zip(a["iterations"], b["iterations"], strict=True):
            ra.pop("fit_time_s"), rb.pop("fit_time_s")
            _assert_close(ra, rb)
    s = local["summary"]["least-squares"]["act"]["2"]
    assert s["runs"] == 4 and s["failed"] == 0
    # Two iterations from +-3 V tune the simulated cloverleaf to well under 300 mHz (true split).
    assert s["under_300mHz"] == 4
    assert np.allclose(s["mean_bias"], [2.04, 4.39], atol=0.2)


def test_rerun_skips_done_runs_and_writes_outputs(tmp_path, monkeypatch):
    cfg = _cfg(tmp_path)
    out = tmp_path / "s"
    first = run_study(cfg, out, executor="local", plots=True)
    assert (out / "results.nc").exists() and (out / "summary.json").exists()
    assert (out / "fig-least-squares-act-iter2.png").exists()
    import sysid_core.study as study

    def boom(spec):
        raise AssertionError(f"run {spec.key} should not run again")

    monkeypatch.setattr(study, "run_one", boom)
    again = run_study(cfg, out, executor="local", plots=False)
    assert again["summary"] == first["summary"]
    import xarray as xr

    ds = xr.open_dataset(out / "results.nc", engine="h5netcdf")
    assert ds["true_split_hz"].dims == ("objective", "model", "start", "iteration")
    assert ds.sizes["start"] == 4
    ds.close()


def test_failed_run_is_reported_and_others_finish(tmp_path):
    # Start points outside the device's limits fail (the bias is refused before measuring).
    text = SMALL.replace("grid = [-3, 3]", "starts = [[0.0, 0.0], [12.0, 0.0]]")
    res = run_study(_cfg(tmp_path, text), tmp_path / "f", executor="local", plots=False)
    assert len(res["failures"]) == 1
    assert res["failures"][0]["start"][:2] == [12.0, 0.0]
    assert "BiasLimitError" in res["failures"][0]["error"]
    assert res["summary"]["least-squares"]["act"]["2"]["runs"] == 1


def test_unknown_study_key_is_named(tmp_path):
    with pytest.raises(errors.ConfigError, match="unknown key 'gird' in \\[study\\]"):
        _cfg(tmp_path, SMALL.replace("grid =", "gird ="))
