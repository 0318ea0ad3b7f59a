"""MATLAB v7.3 ``.mat`` files (``sysid_core.formats.mat73``): written with h5py the way MATLAB
writes them (``tests/exports.py``: MATLAB's 512-byte header, column-major datasets,
``MATLAB_class``, complex compound types, UTF-16 characters), read through :func:`read_sweep`
exactly as the same sweep from a v5 file, in a manifest too, with the same checks and the same
messages.
"""

from __future__ import annotations

from pathlib import Path

import h5py
import numpy as np
import pytest
import xarray as xr
from exports import MATLAB_HEADER, write_mat73
from scipy.io import loadmat
from sysid_cloverleaf import CloverleafGyro
from test_sweepfiles import FREQS, mat_error_cases, savemat_v5

from sysid_core.errors import FileFormatError
from sysid_core.formats.manifest import load_manifest
from sysid_core.formats.sweepfiles import read_sweep, write_sweep


@pytest.fixture(scope="module")
def sweep() -> xr.DataArray:
    """A measurement of the simulated cloverleaf with time stamps (V/V)."""
    da = CloverleafGyro(seed=12).measure([0.5, 0.0, 0.0], FREQS)
    return da.assign_coords(time_s=("frequency", 3.0 + 0.125 * np.arange(FREQS.size)))


def test_the_helper_writes_what_matlab_writes(tmp_path: Path, sweep: xr.DataArray) -> None:
    """The file's layout, byte by byte where MATLAB fixes it, so the reader's test means it."""
    path = write_mat73(
        tmp_path / "a.mat", frequency_hz=FREQS, response=sweep.values, response_units="V/V"
    )
    head = path.read_bytes()[:512]
    assert head.startswith(MATLAB_HEADER.encode()) and head[124:128] == b"\x00\x02IM"
    with pytest.raises(NotImplementedError, match=r"v7\.3"):  # scipy recognises a v7.3 file
        loadmat(path)
    with h5py.File(path, "r") as fh:
        assert fh.userblock_size == 512
        assert fh["frequency_hz"].shape == (1, 61)  # MATLAB's 61 x 1 column, reversed
        response = fh["response"]
        assert response.shape == (2, 2, 61)  # MATLAB's 61 x 2 x 2, reversed
        assert response.dtype.names == ("real", "imag")
        assert response.attrs["MATLAB_class"] == b"double"
        assert response[1, 0, 7]["real"] == sweep.values[7, 0, 1].real  # H(8, 1, 2) = y1/u2
        assert fh["response_units"].attrs["MATLAB_class"] == b"char"
        assert fh["response_units"][:, 0].tolist() == [ord(c) for c in "V/V"]


def test_v73_reads_as_the_same_sweep_in_v5(tmp_path: Path, sweep: xr.DataArray) -> None:
    variables = {
        "frequency_hz": FREQS,
        "response": sweep.values,
        "response_units": "V/V",
        "time_s": sweep["time_s"].values,
        "notes": {"operator": "M. Lab"},  # another variable, a struct: not read
    }
    v73 = read_sweep(write_mat73(tmp_path / "a.mat", **variables))
    v5 = read_sweep(write_sweep(tmp_path / "b.mat", sweep, "V/V"))
    xr.testing.assert_identical(v73.drop_attrs(), v5.drop_attrs())
    assert v73.attrs == {"units": "V/V", "source": str(tmp_path / "a.mat")}
    np.testing.assert_array_equal(v73.values, sweep.values)  # exact
    np.testing.assert_array_equal(v73["time_s"].values, sweep["time_s"].values)
    # single precision and a row vector of frequencies, as MATLAB may hold them
    small = read_sweep(
        write_mat73(
            tmp_path / "c.mat",
            frequency_hz=FREQS[None, :],
            response=sweep.values.astype(np.complex64),
        )
    )
    np.testing.assert_array_equal(small.values, sweep.values.astype(np.complex64))
    assert small.attrs["units"] == ""


def test_v73_in_a_manifest(tmp_path: Path, sweep: xr.DataArray) -> None:
    gyro = CloverleafGyro(seed=12)
    lines = ['structure_potential_v = 15.58\nelectrodes = ["B1", "B2"]']
    for k, bias in enumerate([[0.0, 0.0], [1.0, 0.0], [0.0, 1.0]]):
        h = gyro.measure([*bias, 0.0], FREQS).values
        write_mat73(tmp_path / f"e{k}.mat", frequency_hz=FREQS, response=h, response_units="V/V")
        lines.append(f'[[experiment]]\nbias_v = {bias}\nfile = "e{k}.mat"')
    (tmp_path / "m.toml").write_text("\n".join(lines) + "\n")
    ds = load_manifest(tmp_path / "m.toml")
    assert ds.sizes["experiment"] == 3 and ds.attrs["response_units"] == "V/V"
    np.testing.assert_array_equal(ds["response"].values[2], h)


def test_v73_errors_are_the_v5_errors(tmp_path: Path, sweep: xr.DataArray) -> None:
    """Each bad file gives, word for word, the message of the same variables in a v5 file."""
    for variables, _ in mat_error_cases(sweep.values):
        messages = []
        for name, writer in (("v5.mat", savemat_v5), ("v73.mat", write_mat73)):
            path = writer(tmp_path / name, **variables)
            with pytest.raises(FileFormatError) as info:
                read_sweep(path)
            messages.append(str(info.value).replace(str(path), "FILE"))
        assert messages[0] == messages[1]


def test_v73_only_errors(tmp_path: Path, sweep: xr.DataArray) -> None:
    path = write_mat73(tmp_path / "s.mat", frequency_hz=FREQS, response={"re": sweep.values.real})
    with pytest.raises(FileFormatError, match=r"s\.mat, variable 'response': a MATLAB struct"):
        read_sweep(path)
    whole = write_mat73(tmp_path / "t.mat", frequency_hz=FREQS, response=sweep.values)
    (tmp_path / "cut.mat").write_bytes(whole.read_bytes()[:600])  # the header, a piece of HDF5
    with pytest.raises(FileFormatError, match=r"cut\.mat: a MATLAB v7\.3 file that HDF5 cannot"):
        read_sweep(tmp_path / "cut.mat")
    (tmp_path / "head.mat").write_bytes(whole.read_bytes()[:512])  # the header alone
    with pytest.raises(FileFormatError, match=r"head\.mat: MATLAB's v7\.3 header but no HDF5"):
        read_sweep(tmp_path / "head.mat")
    with h5py.File(tmp_path / "h.mat", "w") as fh:  # HDF5 without MATLAB's header
        fh["frequency_hz"] = FREQS
    message = r"h\.mat: an HDF5 file without MATLAB's v7\.3 header: not a MATLAB \.mat file"
    with pytest.raises(FileFormatError, match=message):
        read_sweep(tmp_path / "h.mat")
