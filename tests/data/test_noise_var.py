"""``noise_var``: a measurement's per-point noise variances, kept with the data."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
import xarray as xr
from sysid_cloverleaf import CloverleafGyro

from sysid_core import errors
from sysid_core.clock.runfolder import RunFolder
from sysid_core.data.schema import (
    RESPONSE_DIMS,
    concat_experiments,
    experiment_from_measurement,
    load_dataset,
    make_dataset,
    point_noise,
    save_dataset,
)
from sysid_core.data.validation import validate
from sysid_core.formats.export import export_dataset
from sysid_core.formats.manifest import load_manifest
from sysid_core.formats.sweepfiles import read_sweep, write_sweep

DEVICE = CloverleafGyro(seed=7)
TUNED = ["B1", "B2"]
BIASES = ([0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0])


def experiment(bias: list[float], f: np.ndarray, device: CloverleafGyro = DEVICE) -> xr.Dataset:
    return experiment_from_measurement(
        device.measure(bias, f), bias, device.electrodes, device.structure_potential, "cloverleaf"
    )


@pytest.fixture(scope="module")
def ds() -> xr.Dataset:
    f = np.linspace(4385.0, 4445.0, 31)
    return concat_experiments([experiment(b, f) for b in BIASES]).sel(electrode=TUNED)


def test_a_measurement_brings_its_variances(ds: xr.Dataset) -> None:
    assert ds["noise_var"].dims == RESPONSE_DIMS
    one = DEVICE.measure(BIASES[0], ds["frequency"].values)
    exp = experiment_from_measurement(one, BIASES[0], DEVICE.electrodes, 15.58)
    np.testing.assert_array_equal(exp["noise_var"].values[0], one["noise_var"].values)
    assert validate(ds) is ds


def test_joined_experiments_keep_them_nan_where_unknown() -> None:
    """Per-experiment grids and an experiment without variances (noise 0): NaN there."""
    quiet = CloverleafGyro(seed=7, noise=0.0)
    f1, f2 = np.linspace(4385.0, 4445.0, 13), np.linspace(4400.0, 4440.0, 9)
    parts = [experiment(BIASES[0], f1), experiment(BIASES[1], f2, quiet), experiment(BIASES[2], f2)]
    joined = concat_experiments(parts)
    assert "measured" in joined and joined["noise_var"].dims == RESPONSE_DIMS
    for k, part in enumerate(parts):
        got = point_noise(joined, k)
        if k == 1:
            assert got is None
            assert np.all(np.isnan(joined["noise_var"].values[1]))
        else:
            assert got is not None
            np.testing.assert_array_equal(got, part["noise_var"].values[0])
    unmeasured = ~joined["measured"].values
    assert np.all(np.isnan(joined["noise_var"].values[unmeasured]))
    validate(joined.sel(electrode=TUNED))
    # and none at all: no variable
    assert "noise_var" not in concat_experiments([parts[1], parts[1]])


def test_saved_and_read_back_exactly(tmp_path: Path, ds: xr.Dataset) -> None:
    back = load_dataset(save_dataset(ds, tmp_path / "exp0.nc"))
    xr.testing.assert_identical(back["noise_var"], ds["noise_var"])


def test_a_resumed_run_reads_them_back(tmp_path: Path) -> None:
    """What a run saves (exp*.nc, before it uses it) and what --resume reads are the same."""
    f = np.linspace(4420.0, 4440.0, 21)
    bias = np.array(BIASES[1])
    measured: list[xr.Dataset] = []

    def measure() -> xr.Dataset:
        measured.append(experiment(BIASES[1], f))
        return measured[-1]

    path = tmp_path / "run" / "iter01" / "exp1.nc"
    path.parent.mkdir(parents=True)
    folder = RunFolder(tmp_path / "run", "digest")
    first, was_read = folder.read_or_measure(path, bias, f, measure)
    assert not was_read and "noise_var" in first
    again, was_read = folder.read_or_measure(path, bias, f, measure)
    assert was_read and len(measured) == 1
    np.testing.assert_array_equal(again["noise_var"].values, measured[0]["noise_var"].values)
    assert again["noise_var"].dims == RESPONSE_DIMS


@pytest.mark.parametrize(
    ("value", "error", "message"),
    [
        (
            -1e-12,
            errors.DataError,
            r"noise_var of experiment 2 at 4405\.0 Hz \(output 1, input 0\) is -1e-12",
        ),
        (np.inf, errors.NonFiniteDataError, "must be finite and >= 0"),
    ],
)
def test_validation_refuses_impossible_variances(
    ds: xr.Dataset, value: float, error: type[Exception], message: str
) -> None:
    bad = ds.copy(deep=True)
    bad["noise_var"][2, 10, 1, 0] = value
    with pytest.raises(error, match=message) as info:
        validate(bad)
    assert info.type is error


def test_validation_accepts_unknown_and_refuses_wrong_shapes(ds: xr.Dataset) -> None:
    unknown = ds.copy(deep=True)
    unknown["noise_var"][0, 3] = np.nan
    validate(unknown)
    flat = ds.assign(noise_var=ds["noise_var"].mean(("output", "input")))
    with pytest.raises(errors.DimensionError, match="'noise_var' has dims"):
        validate(flat)
    complex_var = ds.assign(noise_var=ds["noise_var"] + 0j)
    with pytest.raises(errors.DimensionError, match="must be real"):
        validate(complex_var)


def test_make_dataset_checks_the_shapes() -> None:
    f = np.linspace(4420.0, 4440.0, 5)
    resp = [np.ones((5, 2, 2), complex)] * 3
    bias = np.array(BIASES)[:, :2]
    with pytest.raises(errors.DimensionError, match=r"experiment 1: noise_var has shape \(5,\)"):
        make_dataset(resp, f, bias, TUNED, 15.58, noise_var=[None, np.ones(5), None])
    ds = make_dataset(resp, f, bias, TUNED, 15.58, noise_var=[None, np.ones((5, 2, 2)), None])
    assert np.isnan(ds["noise_var"].values[[0, 2]]).all()
    assert (ds["noise_var"].values[1] == 1).all()


@pytest.mark.parametrize("fmt", ["csv", "nc", "mat", "s2p"])
def test_export_and_import_are_not_disturbed(tmp_path: Path, ds: xr.Dataset, fmt: str) -> None:
    """``sysid export``/``import`` do not carry the variances, and do not mind them."""
    back = load_manifest(export_dataset(ds, tmp_path / fmt, fmt))
    np.testing.assert_allclose(back["response"].values, ds["response"].values, rtol=1e-12)


def test_sweep_files_of_a_measurement_with_variances(tmp_path: Path, ds: xr.Dataset) -> None:
    f = ds["frequency"].values
    answer = DEVICE.measure(BIASES[0], f)
    for name in ("sweep.csv", "sweep.nc"):
        path = write_sweep(tmp_path / name, answer)
        np.testing.assert_allclose(read_sweep(path).values, answer.values, rtol=1e-12)
    # a run's own experiment file is a sweep file too
    path = save_dataset(experiment(BIASES[0], f), tmp_path / "exp0.nc")
    assert read_sweep(path).shape == (f.size, 2, 2)
