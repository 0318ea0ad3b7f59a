"""Response files (``sysid_core.formats.sweepfiles``): each format read from files written by
independent writers (the ``csv`` module, scikit-rf's ``write_touchstone``, ``scipy.io.savemat``,
h5py as MATLAB writes v7.3, xarray), exact round trips through :func:`write_sweep`, and one-line
errors naming file and line/variable (MATLAB v7.3: ``test_mat73.py``).
"""

from __future__ import annotations

import csv
import re
from pathlib import Path

import numpy as np
import pytest
import skrf
import xarray as xr
from exports import write_mat73
from scipy.io import savemat
from sysid_cloverleaf import CloverleafGyro

from sysid_core.data.schema import experiment_from_measurement, save_dataset
from sysid_core.errors import (
    DimensionError,
    FileFormatError,
    FrequencyGridError,
    NonFiniteDataError,
)
from sysid_core.formats.sweepfiles import (
    CSV_HEADER,
    SWEEP_FORMATS,
    make_sweep,
    read_sweep,
    write_sweep,
)

FREQS = np.linspace(4385.0, 4445.0, 61)


@pytest.fixture(scope="module")
def sweep() -> xr.DataArray:
    """One measurement of the simulated cloverleaf at the paper's first bias (V/V)."""
    return CloverleafGyro(seed=11).measure([0.0, 0.0, 0.0], FREQS)


def assert_sweep(da: xr.DataArray, ref: xr.DataArray, units: str, source: Path) -> None:
    assert da.dims == ("frequency", "output", "input")
    assert da.shape == ref.shape
    assert da.dtype == np.complex128
    assert list(da["output"].values) == ["y1", "y2"]
    assert list(da["input"].values) == ["u1", "u2"]
    np.testing.assert_array_equal(da["frequency"].values, ref["frequency"].values)
    np.testing.assert_array_equal(da.values, ref.values)
    assert da.attrs == {"units": units, "source": str(source)}


# ------------------------------------------------------------------ independent writers
def write_csv(path: Path, f: np.ndarray, resp: np.ndarray, units: str | None = None) -> Path:
    """The contract's CSV through the csv module (its default "\\r\\n" line ends included)."""
    with open(path, "w", newline="") as fh:
        if units is not None:
            fh.write(f"# response_units: {units}\r\n# another comment\r\n")
        writer = csv.writer(fh)
        writer.writerow(CSV_HEADER.split(","))
        for k in range(f.size):
            row: list[float] = [float(f[k])]
            for o in range(2):
                for i in range(2):
                    row += [resp[k, o, i].real, resp[k, o, i].imag]
            writer.writerow(row)
    return path


def test_csv_from_the_csv_module(tmp_path: Path, sweep: xr.DataArray) -> None:
    path = write_csv(tmp_path / "a.csv", FREQS, sweep.values, units="V/V")
    assert_sweep(read_sweep(path), sweep, "V/V", path)
    bare = write_csv(tmp_path / "b.CSV", FREQS, sweep.values)  # no units; extension in any case
    assert_sweep(read_sweep(bare), sweep, "", bare)


def test_csv_row_major_over_outputs_then_inputs(tmp_path: Path) -> None:
    path = tmp_path / "order.csv"
    path.write_text(f"{CSV_HEADER}\n1000,1,2,3,4,5,6,7,8\n")
    da = read_sweep(path)
    assert da.sel(output="y1", input="u2").item() == 3 + 4j
    assert da.sel(output="y2", input="u1").item() == 5 + 6j


def test_s2p_from_scikit_rf(tmp_path: Path, sweep: xr.DataArray) -> None:
    net = skrf.Network(
        frequency=skrf.Frequency.from_f(FREQS, unit="Hz"),
        s=sweep.values,
        comments="response_units: V/V",
    )
    net.write_touchstone("ri", dir=tmp_path, form="ri")
    path = tmp_path / "ri.s2p"
    assert_sweep(read_sweep(path), sweep, "V/V", path)
    # Touchstone's convention: S21 is output 2 over input 1.
    assert read_sweep(path).sel(output="y2", input="u1").values[0] == net.s21.s[0, 0, 0]
    for form in ("ma", "db"):  # other forms and units are converted by scikit-rf
        net.frequency.unit = "kHz"
        net.write_touchstone(form, dir=tmp_path, form=form)
        da = read_sweep(tmp_path / f"{form}.s2p")
        np.testing.assert_allclose(da.values, sweep.values, rtol=1e-9)
        np.testing.assert_allclose(da["frequency"].values, FREQS, rtol=1e-12)


def test_s2p_units_comment_anywhere(tmp_path: Path) -> None:
    path = tmp_path / "late.s2p"
    path.write_text(f"# Hz S RI R 50\n! response_units: V/V\n4385 {S2P_ROW}\n4386 {S2P_ROW}\n")
    da = read_sweep(path)
    assert da.attrs["units"] == "V/V"
    assert da.sel(output="y2", input="u1").values.tolist() == [3 + 4j] * 2  # S21: 3rd, 4th


def test_mat_from_savemat(tmp_path: Path, sweep: xr.DataArray) -> None:
    path = tmp_path / "a.mat"
    savemat(path, {"frequency_hz": FREQS, "response": sweep.values, "response_units": "V/V"})
    assert_sweep(read_sweep(path), sweep, "V/V", path)
    column = tmp_path / "b.mat"
    savemat(column, {"frequency_hz": FREQS, "response": sweep.values}, oned_as="column")
    assert_sweep(read_sweep(column), sweep, "", column)


def test_nc_data_set_and_bare_dataarray(tmp_path: Path, sweep: xr.DataArray) -> None:
    one = experiment_from_measurement(sweep, [0.0, 0.0, 0.0], ["B1", "B2", "B3"], 15.58)
    path = save_dataset(one, tmp_path / "one.nc")
    assert_sweep(read_sweep(path), sweep, "V/V", path)
    bare = tmp_path / "bare.nc"
    sweep.drop_attrs().assign_attrs(units="V/V").to_netcdf(bare, engine="h5netcdf")
    assert_sweep(read_sweep(bare), sweep, "V/V", bare)
    swapped = tmp_path / "swapped.nc"  # channels by label, whatever their order in the file
    sweep.isel(output=[1, 0]).drop_attrs().to_netcdf(swapped, engine="h5netcdf")
    assert_sweep(read_sweep(swapped), sweep, "", swapped)


@pytest.mark.parametrize("ext", SWEEP_FORMATS)
def test_write_read_round_trip_is_exact(tmp_path: Path, sweep: xr.DataArray, ext: str) -> None:
    path = write_sweep(tmp_path / f"x{ext}", sweep, "V/V")
    assert path == tmp_path / f"x{ext}"
    assert sorted(p.name for p in tmp_path.iterdir()) == [f"x{ext}"]  # no temporary left over
    assert_sweep(read_sweep(path), sweep, "V/V", path)
    write_sweep(path, sweep.drop_attrs())  # replaces; no units given, none in the attributes
    assert read_sweep(path).attrs["units"] == ""


def test_csv_writer_layout(tmp_path: Path, sweep: xr.DataArray) -> None:
    lines = write_sweep(tmp_path / "x.csv", sweep).read_text().splitlines()
    assert lines[0] == "# response_units: V/V"  # from the DataArray's units attribute
    assert lines[1] == CSV_HEADER
    assert len(lines) == 2 + FREQS.size


def test_make_sweep() -> None:
    da = make_sweep([1.0, 2.0], np.ones((2, 2, 2)), "V/V", "here")
    assert da.dtype == np.complex128 and da["frequency"].attrs["units"] == "Hz"
    assert da.attrs == {"units": "V/V", "source": "here"}


def test_write_refuses_what_it_could_not_read(tmp_path: Path, sweep: xr.DataArray) -> None:
    with pytest.raises(DimensionError, match="dims"):
        write_sweep(tmp_path / "x.csv", sweep.isel(frequency=0))
    with pytest.raises(FrequencyGridError, match=r"frequency\[1\]"):
        write_sweep(tmp_path / "x.csv", sweep.isel(frequency=[0, 0]))
    bad = sweep.copy()
    bad.values[3, 1, 0] = np.nan
    with pytest.raises(NonFiniteDataError, match=r"response\[3, 1, 0\]"):
        write_sweep(tmp_path / "x.csv", bad)
    with pytest.raises(FileFormatError, match=r"unknown .* '\.txt'; supported: \.csv, \.s2p"):
        write_sweep(tmp_path / "x.txt", sweep)
    assert not list(tmp_path.iterdir())


# --------------------------------------------------------------------------- errors: CSV
ROW = "4385.0,1,2,3,4,5,6,7,8"
REAL_HEADER = "frequency_hz,y1_u1_re,y1_u2_re,y2_u1_re,y2_u2_re"


@pytest.mark.parametrize(
    ("text", "message"),
    [
        (f"{REAL_HEADER}\n4385,1,2,3,4\n", r"line 1: no imaginary-part columns .* complex"),
        ("# c\nfrequency_hz,y1_u1,y1_u2,y2_u1,y2_u2\n4385,1,2,3,4\n", r"line 2: no imaginary"),
        (CSV_HEADER.replace("y2_u2_im", "y2_u2_imag") + f"\n{ROW}\n", r"unknown column 'y2_u2_im"),
        (CSV_HEADER.replace(",y2_u2_im", "") + "\n4385,1,2,3,4,5,6,7\n", r"missing column"),
        (CSV_HEADER.replace(",", ";") + "\n", r"line 1: .*commas, not semicolons"),
        (f"{ROW}\n", r"line 1: no header line"),
        (f"{CSV_HEADER}\n{ROW}\n4386,1,2,3\n", r"line 3: 4 field\(s\); expected 9"),
        (f"{CSV_HEADER}\n# c\n4385,1,2,abc,4,5,6,7,8\n", r"line 3: y1_u2_re is 'abc', not a num"),
        (f"{CSV_HEADER}\n{ROW}\n4386,1,2,3,4,5,nan,7,8\n", r"line 3: y2_u1_im: .*must be finite"),
        (f"{CSV_HEADER}\n{ROW}\n4386,1,2,3,4,inf,6,7,8\n", r"line 3: y2_u1_re: .*must be finite"),
        (f"{CSV_HEADER}\n{ROW}\n\n{ROW}\n", r"line 4: frequency 4385\.0 Hz after 4385\.0 Hz"),
        (f"{CSV_HEADER}\n{ROW}\n4000,1,2,3,4,5,6,7,8\n", r"line 3: .*strictly increasing"),
        (f"{CSV_HEADER}\n-1,1,2,3,4,5,6,7,8\n", r"line 2: frequency -1\.0 Hz; .*positive"),
        (f"{CSV_HEADER}\nnan,1,2,3,4,5,6,7,8\n", r"line 2: frequency nan Hz"),
        (f"# only a comment\n{CSV_HEADER}\n", r"no data rows after the header \(line 2\)"),
        ("", r"no header line"),
        (f"# response_units: V/V\n{CSV_HEADER}\n# response_units: V\n{ROW}\n", r"line 3: .*units"),
    ],
    ids=[
        "real-only",
        "real-no-suffix",
        "unknown-column",
        "missing-column",
        "semicolons",
        "no-header",
        "field-count",
        "not-a-number",
        "nan",
        "inf",
        "duplicate",
        "decreasing",
        "negative",
        "nan-frequency",
        "no-rows",
        "empty",
        "two-units",
    ],
)
def test_csv_errors_name_file_and_line(tmp_path: Path, text: str, message: str) -> None:
    path = tmp_path / "bad.csv"
    path.write_text(text)
    with pytest.raises(FileFormatError, match=rf"^{re.escape(str(path))}[:,] .*{message}") as info:
        read_sweep(path)
    assert "\n" not in str(info.value)


# -------------------------------------------------------------------- errors: Touchstone
S2P_ROW = "1 2 3 4 5 6 7 8"


@pytest.mark.parametrize(
    ("body", "message"),
    [
        ("# Hz Z RI R 50\n4385 {r}\n4386 {r}\n", r"line 1: .*'# Hz Z RI R 50'.* S parameters"),
        ("# Hz S RI R 50\n4385 {r}\n4386 1 nan 3 4 5 6 7 8\n", r"line 3: S11: .*finite"),
        ("# Hz S RI R 50\n! c\n4385 {r}\n4386 1 2 3 4 inf 6 7 8\n", r"line 4: S12: "),
        ("# Hz S RI R 50\n4385 {r}\n4400 {r}\n4390 {r}\n", r"line 4: the frequency decreases"),
        ("# Hz S RI R 50\n4385 {r}\n4385 {r}\n", r"line 3: frequency 4385\.0 Hz after"),
        ("# Hz S RI R 50\n4385 {r}\n4386 1 2 3\n", r"not a two-port Touchstone file"),
        ("# Hz S RI R 50\n4385 1 2\n4386 1 2\n", r"not a two-port Touchstone file"),
        ("hello\n", r"no option line"),
        ("# Hz S RI R 50\n", r"no frequency points"),
    ],
    ids=["Z", "nan", "inf", "decreasing", "duplicate", "short", "one-port", "garbage", "empty"],
)
def test_s2p_errors_name_file_and_line(tmp_path: Path, body: str, message: str) -> None:
    path = tmp_path / "bad.s2p"
    path.write_text(body.replace("{r}", S2P_ROW))
    with pytest.raises(FileFormatError, match=rf"^{re.escape(str(path))}[:,] .*{message}") as info:
        read_sweep(path)
    assert "\n" not in str(info.value)


class _OpensAFile:
    """Unpickling this creates ``marker``: proof that a file was unpickled."""

    def __init__(self, marker: Path) -> None:
        self.marker = marker

    def __reduce__(self) -> tuple[object, tuple[str, str]]:
        return (open, (str(self.marker), "w"))


def test_s2p_is_never_unpickled(tmp_path: Path) -> None:
    """``skrf.Network(path)`` tries pickle first (running code from the file); the reader gives
    scikit-rf the text instead, so a pickle is only a malformed Touchstone file."""
    import pickle

    marker = tmp_path / "unpickled"
    path = tmp_path / "evil.s2p"
    path.write_bytes(pickle.dumps(_OpensAFile(marker), protocol=0) + b"\n# Hz S RI R 50\n")
    with pytest.raises(FileFormatError, match="not a two-port Touchstone file"):
        read_sweep(path)
    assert not marker.exists()


# --------------------------------------------------------------------------- errors: .mat
def savemat_v5(path: Path, **variables: object) -> Path:
    savemat(path, variables, oned_as="column")
    return path


#: The writers of .mat files: scipy (MATLAB v5) and h5py as MATLAB writes v7.3 (tests/exports.py).
MAT_WRITERS = {"v5": savemat_v5, "v7.3": write_mat73}


def mat_error_cases(r: np.ndarray) -> list[tuple[dict[str, object], str]]:
    """Bad .mat files' variables and the error each must give (after the file's name)."""
    bad = r.copy()
    bad[7, 1, 1] = np.inf
    return [
        ({"response": r}, r"no variable 'frequency_hz' \(found: response\)"),
        ({"frequency_hz": FREQS}, r"no variable 'response'"),
        ({"frequency_hz": FREQS, "response": r.real}, r"variable 'response': real values"),
        (
            {"frequency_hz": FREQS, "response": np.transpose(r, (1, 2, 0))},
            r"variable 'response': shape \(2, 2, 61\); .*permute\(H, \[3 1 2\]\)",
        ),
        ({"frequency_hz": FREQS, "response": r[:, 0]}, r"variable 'response': shape \(61, 2\)"),
        ({"frequency_hz": FREQS[::-1], "response": r}, r"variable 'frequency_hz'\[1\]: .*after"),
        ({"frequency_hz": FREQS + 1j, "response": r}, r"variable 'frequency_hz': complex"),
        ({"frequency_hz": FREQS, "response": r, "response_units": 3.0}, r"'response_units'"),
        ({"frequency_hz": "abc", "response": r}, r"variable 'frequency_hz'"),
        ({"frequency_hz": FREQS, "response": bad}, r"variable 'response'\[7, 1, 1\]: .*finite"),
    ]


@pytest.mark.parametrize("version", sorted(MAT_WRITERS))
def test_mat_errors_name_file_and_variable(
    tmp_path: Path, sweep: xr.DataArray, version: str
) -> None:
    for variables, message in mat_error_cases(sweep.values):
        path = MAT_WRITERS[version](tmp_path / "bad.mat", **variables)
        with pytest.raises(FileFormatError, match=rf"^{re.escape(str(path))}[:,] .*{message}"):
            read_sweep(path)
    path.write_text("not a mat file at all")
    with pytest.raises(FileFormatError, match=r"not a MATLAB \.mat file"):
        read_sweep(path)


# ---------------------------------------------------------------------------- errors: .nc
def test_nc_errors_name_file_and_variable(tmp_path: Path, sweep: xr.DataArray) -> None:
    two = xr.concat([sweep, sweep], dim="experiment").rename("response").drop_attrs()
    two.to_netcdf(tmp_path / "two.nc", engine="h5netcdf")
    with pytest.raises(FileFormatError, match=r"two\.nc, variable 'response': 2 experiments"):
        read_sweep(tmp_path / "two.nc")
    sweep.real.drop_attrs().to_netcdf(tmp_path / "real.nc", engine="h5netcdf")
    with pytest.raises(FileFormatError, match=r"real\.nc, variable 'response': real values"):
        read_sweep(tmp_path / "real.nc")
    sweep.rename(output="out").drop_attrs().to_netcdf(tmp_path / "dims.nc", engine="h5netcdf")
    with pytest.raises(FileFormatError, match=r"dims\.nc, variable 'response': dims"):
        read_sweep(tmp_path / "dims.nc")
    (tmp_path / "text.nc").write_text("no netCDF")
    with pytest.raises(FileFormatError, match=r"text\.nc"):
        read_sweep(tmp_path / "text.nc")


def test_unknown_extension_and_missing_file(tmp_path: Path) -> None:
    with pytest.raises(FileFormatError, match=r"'\.s1p'; supported: \.csv, \.s2p, \.mat, \.nc"):
        read_sweep(tmp_path / "x.s1p")
    with pytest.raises(FileFormatError, match=r"x\.csv: no such file"):
        read_sweep(tmp_path / "x.csv")
