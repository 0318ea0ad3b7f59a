"""The data schema: construction, validation errors, netCDF round trip."""

from __future__ import annotations

import numpy as np
import pytest
import xarray as xr
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from hypothesis.extra.numpy import arrays
from truths import PAPER_BIASES, PAPER_FREQS, V_GYRO, simulate

from sysid_core import errors
from sysid_core.data.schema import (
    concat_experiments,
    load_dataset,
    make_dataset,
    save_dataset,
    to_frd,
)
from sysid_core.data.validation import check_rank_condition, validate


@pytest.fixture
def ds(in_class_truth):
    return simulate(in_class_truth, noise_rel=1e-3)


def test_schema(ds):
    assert ds["response"].dims == ("experiment", "frequency", "output", "input")
    assert ds["bias"].dims == ("experiment", "electrode")
    assert ds["frequency"].attrs["units"] == "Hz"
    assert ds.attrs["structure_potential"] == 15.58
    assert validate(ds) is ds


def test_nan_rejected_with_location(ds):
    bad = ds.copy(deep=True)
    bad["response"][1, 5, 0, 1] = np.nan
    with pytest.raises(errors.NonFiniteDataError, match=r"experiment 1 at 4387\.5 Hz"):
        validate(bad)


def test_inf_rejected(ds):
    bad = ds.copy(deep=True)
    bad["response"][0, 0, 1, 1] = np.inf
    with pytest.raises(errors.NonFiniteDataError):
        validate(bad)


def test_wrong_dims_rejected(ds):
    with pytest.raises(errors.DimensionError, match="dims"):
        validate(ds.transpose("frequency", "experiment", "output", "input", ...))


def test_real_response_rejected(ds):
    bad = ds.copy()
    bad["response"] = bad["response"].real
    with pytest.raises(errors.DimensionError, match="complex"):
        validate(bad)


def test_not_2x2_rejected(ds):
    with pytest.raises(errors.DimensionError, match="2x2"):
        validate(ds.isel(output=[0]))


def test_non_increasing_frequencies_rejected(ds):
    f = ds["frequency"].values.copy()
    f[10], f[11] = f[11], f[10]
    with pytest.raises(errors.FrequencyGridError, match="not increasing at index 11"):
        validate(ds.assign_coords(frequency=f))


def test_duplicate_frequencies_rejected(ds):
    f = ds["frequency"].values.copy()
    f[11] = f[10]
    with pytest.raises(errors.FrequencyGridError, match="duplicated"):
        validate(ds.assign_coords(frequency=f))


def test_missing_bias_rejected(ds):
    with pytest.raises(errors.MissingBiasError):
        validate(ds.drop_vars("bias"))
    bad = ds.copy(deep=True)
    bad["bias"].values[2, 1] = np.nan
    with pytest.raises(errors.MissingBiasError, match="experiment 2, electrode B2"):
        validate(bad)


def test_missing_structure_potential_rejected(ds):
    bad = ds.copy()
    del bad.attrs["structure_potential"]
    with pytest.raises(errors.MissingBiasError, match="structure_potential"):
        validate(bad)


def test_too_few_experiments_rejected(ds):
    with pytest.raises(errors.TooFewExperimentsError, match="at least 3"):
        validate(ds.isel(experiment=[0, 1]))


def test_rank_condition_names_dependent_experiments():
    with pytest.raises(
        errors.RankConditionError, match=r"experiment 2 is a combination of experiments \[0, 1\]"
    ):
        check_rank_condition([[0, 0], [1, 0], [2, 0]], V_GYRO, ["B1", "B2"])
    with pytest.raises(errors.RankConditionError, match="B2 never changes"):
        check_rank_condition([[0, 0], [1, 0], [2, 0]], V_GYRO, ["B1", "B2"])
    # A repeated experiment is allowed when the others already satisfy the condition.
    check_rank_condition([[0, 0], [1, 0], [0, 1], [0, 0]], V_GYRO)
    check_rank_condition(PAPER_BIASES, V_GYRO)  # the paper's design is fine


def test_rank_condition_sign_symmetry():
    # v = v_gyro - dv enters squared: dv = 0 and dv = 2 v_gyro give the same stiffness.
    with pytest.raises(errors.RankConditionError):
        check_rank_condition([[0, 0], [4, 0], [0, 4]], 2.0)


def test_dataset_with_bad_design_rejected(in_class_truth):
    ds = simulate(in_class_truth, biases=np.array([[0, 0], [1, 0], [2, 0.0]]))
    with pytest.raises(errors.RankConditionError):
        validate(ds)


def test_round_trip_exact(tmp_path, ds):
    path = save_dataset(ds, tmp_path / "data.nc")
    back = load_dataset(path)
    xr.testing.assert_identical(back, ds)
    assert np.array_equal(back["response"].values, ds["response"].values)


def test_round_trip_per_experiment_grids(tmp_path, in_class_truth):
    grids = [PAPER_FREQS, PAPER_FREQS[::3], PAPER_FREQS[1::2]]
    resp = [in_class_truth.response(b, g) for b, g in zip(PAPER_BIASES, grids, strict=True)]
    ds = make_dataset(resp, grids, PAPER_BIASES, ["B1", "B2"], V_GYRO)
    back = load_dataset(save_dataset(ds, tmp_path / "grids.nc"))
    xr.testing.assert_identical(back, ds)
    assert back["measured"].dtype == bool


@settings(
    max_examples=25, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture]
)
@given(
    values=arrays(
        np.complex128,
        (3, 4, 2, 2),
        elements=st.complex_numbers(allow_nan=False, allow_infinity=False, max_magnitude=1e300),
    ),
    bias=arrays(np.float64, (3, 2), elements=st.floats(-10, 10)),
)
def test_round_trip_any_complex_values(tmp_path_factory, values, bias):
    ds = make_dataset(list(values), np.array([1.0, 2.0, 3.5, 7.0]), bias, ["a", "b"], 15.0)
    path = tmp_path_factory.mktemp("rt") / "x.nc"
    back = load_dataset(save_dataset(ds, path))
    assert np.array_equal(back["response"].values, values)
    assert np.array_equal(back["bias"].values, bias)


def test_failed_save_keeps_earlier_file(tmp_path, ds, monkeypatch):
    path = save_dataset(ds, tmp_path / "d.nc")
    before = path.read_bytes()

    def boom(*args, **kwargs):
        raise OSError("disk full")

    monkeypatch.setattr(xr.Dataset, "to_netcdf", boom)
    with pytest.raises(OSError):
        save_dataset(ds.isel(frequency=slice(0, 10)), path)
    assert path.read_bytes() == before
    assert [p.name for p in tmp_path.iterdir()] == ["d.nc"]


def test_concat_and_frd(ds):
    joined = concat_experiments([ds.isel(experiment=[0]), ds.isel(experiment=[1, 2])])
    np.testing.assert_array_equal(joined["response"].values, ds["response"].values)
    frd = to_frd(ds, 1)
    assert frd.ninputs == 2 and frd.noutputs == 2
    np.testing.assert_allclose(frd.omega, 2 * np.pi * PAPER_FREQS)
    np.testing.assert_allclose(frd.frdata[:, :, 3], ds["response"].values[1, 3])


def test_load_missing_file(tmp_path):
    with pytest.raises(errors.DataError, match="no data file"):
        load_dataset(tmp_path / "nope.nc")
