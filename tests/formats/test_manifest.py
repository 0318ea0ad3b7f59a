"""Manifests of measured experiments (``sysid_core.formats.manifest``) and ``sysid import`` /
``export`` / ``fit MANIFEST.toml``: files from independent writers, per-experiment grids, exact
round trips in every format (API and command line), one-line errors naming manifest and experiment,
the rank condition, and the same model from a manifest as from the imported netCDF file.
"""

from __future__ import annotations

import csv
import json
import re
from pathlib import Path

import numpy as np
import pytest
import xarray as xr
from sysid_cloverleaf import CloverleafGyro

from sysid_core.cli import main
from sysid_core.data.schema import load_dataset, make_dataset, save_dataset
from sysid_core.errors import (
    FileFormatError,
    ManifestError,
    RankConditionError,
    TooFewExperimentsError,
)
from sysid_core.formats.manifest import (
    EXPORT_FORMATS,
    MANIFEST_NAME,
    data_files,
    export_dataset,
    export_files,
    load_data,
    load_manifest,
    read_manifest,
)
from sysid_core.formats.sweepfiles import CSV_HEADER

BIASES = [[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]]  # the paper's, B3 held at 0 V
# Per-experiment grids over 4385-4445 Hz (the paper's m_k points each), 61 points at most.
GRIDS = [
    np.linspace(4385.0, 4445.0, 61),
    np.linspace(4386.0, 4444.0, 59),
    np.linspace(4385.0, 4445.0, 41),
]


@pytest.fixture(scope="module")
def measured() -> xr.Dataset:
    """The simulated cloverleaf at the paper's biases, electrodes B1, B2, one grid each."""
    gyro = CloverleafGyro(seed=7)
    responses = [gyro.measure(b, f).values for b, f in zip(BIASES, GRIDS, strict=True)]
    return make_dataset(
        responses,
        GRIDS,
        [b[:2] for b in BIASES],
        ["B1", "B2"],
        15.58,
        device="cloverleaf",
        response_units="V/V",
    )


def csv_file(path: Path, f: np.ndarray, resp: np.ndarray) -> str:
    """One response file through the csv module (an independent writer)."""
    with open(path, "w", newline="") as fh:
        fh.write("# response_units: V/V\n")
        writer = csv.writer(fh)
        writer.writerow(CSV_HEADER.split(","))
        for k in range(f.size):
            row: list[float] = [float(f[k])]
            for z in resp[k].ravel():
                row += [z.real, z.imag]
            writer.writerow(row)
    return path.name


def manifest_text(files: list[str], biases: list[list[float]], extra: str = "") -> str:
    lines = [extra, "structure_potential_v = 15.58", 'electrodes = ["B1", "B2"]']
    for name, bias in zip(files, biases, strict=True):
        lines += ["[[experiment]]", f"bias_v = {bias}", f'file = "{name}"']
    return "\n".join(lines) + "\n"


@pytest.fixture
def csv_manifest(tmp_path: Path, measured: xr.Dataset) -> Path:
    """A hand-written manifest and CSV files from the csv module, in a sub-folder."""
    folder = tmp_path / "sweeps"
    folder.mkdir()
    files = []
    for k, f in enumerate(GRIDS):
        resp = measured["response"].values[k][measured["measured"].values[k]]
        files.append(csv_file(folder / f"sweep-{k}.csv", f, resp))
    path = tmp_path / "m.toml"
    text = manifest_text([f"sweeps/{n}" for n in files], [b[:2] for b in BIASES])
    path.write_text('device = "cloverleaf"\n' + text)
    return path


def test_manifest_with_per_experiment_grids(csv_manifest: Path, measured: xr.Dataset) -> None:
    ds = load_manifest(csv_manifest)
    xr.testing.assert_identical(ds, measured)
    assert ds["measured"].values.sum(axis=1).tolist() == [61, 59, 41]
    m = read_manifest(csv_manifest)
    assert m.electrodes == ("B1", "B2") and m.device == "cloverleaf"
    assert [e.file for e in m.experiments] == [
        csv_manifest.parent / "sweeps" / f"sweep-{k}.csv" for k in range(3)
    ]
    assert data_files(csv_manifest) == [csv_manifest, *(e.file for e in m.experiments)]
    xr.testing.assert_identical(load_data(csv_manifest), ds)


@pytest.mark.parametrize("fmt", EXPORT_FORMATS)
def test_export_load_round_trip(tmp_path: Path, measured: xr.Dataset, fmt: str) -> None:
    manifest = export_dataset(measured, tmp_path / "out", fmt)
    assert manifest == tmp_path / "out" / MANIFEST_NAME
    assert sorted(p.name for p in (tmp_path / "out").iterdir()) == sorted(
        p.name for p in export_files(measured, tmp_path / "out", fmt)
    )
    xr.testing.assert_identical(load_manifest(manifest), measured)


def test_export_then_import_of_a_shared_grid(tmp_path: Path, measured: xr.Dataset) -> None:
    """One grid for all: no 'measured' mask, before or after; the device name is kept."""
    shared = measured.isel(frequency=np.flatnonzero(measured["measured"].all("experiment")))
    shared = shared.drop_vars("measured")
    back = load_manifest(export_dataset(shared, tmp_path, "csv"))
    xr.testing.assert_identical(back, shared)
    assert back.attrs["device"] == "cloverleaf"


@pytest.mark.parametrize("fmt", EXPORT_FORMATS)
def test_cli_export_and_import_round_trip(
    tmp_path: Path, measured: xr.Dataset, fmt: str, capsys: pytest.CaptureFixture[str]
) -> None:
    data = save_dataset(measured, tmp_path / "data.nc")
    folder = tmp_path / fmt
    assert main(["export", str(data), "--format", fmt, "--out", str(folder)]) == 0
    assert f"wrote 3 {fmt} file(s)" in capsys.readouterr().out
    back = tmp_path / "back.nc"
    assert main(["import", str(folder / MANIFEST_NAME), "--out", str(back)]) == 0
    assert "3 experiment(s), 41-61 points" in capsys.readouterr().out
    xr.testing.assert_identical(load_dataset(back), load_dataset(data))


def test_cli_refuses_to_overwrite(
    tmp_path: Path, csv_manifest: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    def error() -> str:
        lines = capsys.readouterr().err.strip().splitlines()
        assert len(lines) == 1 and lines[0].startswith("sysid: error: "), lines
        return lines[0]

    assert main(["import", str(csv_manifest)]) == 0  # default: m.nc next to it
    data = csv_manifest.with_suffix(".nc")
    assert data.exists()
    assert main(["import", str(csv_manifest)]) == 1
    assert "m.nc already exists; pass --force" in error()
    assert main(["import", str(csv_manifest), "--force"]) == 0
    sweep = csv_manifest.parent / "sweeps" / "sweep-1.csv"
    assert main(["import", str(csv_manifest), "--out", str(sweep), "--force"]) == 1
    assert "refusing to write over the input file" in error()

    folder = tmp_path / "exported"
    folder.mkdir()
    (folder / "notes.txt").write_text("mine")
    assert main(["export", str(data), "--format", "mat", "--out", str(folder)]) == 1
    assert "is not empty; pass --force" in error()
    assert main(["export", str(data), "--format", "mat", "--out", str(folder), "--force"]) == 0
    capsys.readouterr()
    assert (folder / "notes.txt").read_text() == "mine"
    # A manifest exported into its own folder would replace its response files: refused.
    mine = folder / MANIFEST_NAME
    assert main(["export", str(mine), "--format", "mat", "--out", str(folder), "--force"]) == 1
    assert f"refusing to write over the input file {folder / 'exp0.mat'}" in error()
    assert main(["export", str(data), "--format", "csv", "--out", str(data)]) == 1
    assert "not a folder" in error()
    assert main(["export", str(data), "--format", "txt", "--out", str(folder)]) == 2


# ---------------------------------------------------------------------------------- errors
CASES = [
    ("structure_potential_v = 15.58\nelectrodes = ['B1', 'B2']\nexperiment = []\n", "empty"),
    (manifest_text(["a.csv"], [[0.0, 0.0]], "colour = 'red'"), r"unknown key 'colour'"),
    (manifest_text(["a.csv"], [[0.0]]), r"experiment 0: bias_v has 1 value\(s\); expected one"),
    (manifest_text(["a.csv", "b.csv"], [[0.0, 0.0], [1.0, 0.0, 0.0]]), r"experiment 1: bias_v"),
    (manifest_text(["a.csv", "gone.csv"], [[0.0, 0.0]] * 2), r"experiment 1: .*gone\.csv does not"),
    (manifest_text(["a.csv"], [[0.0, 0.0]]) + "gain = 2\n", r"experiment 0: unknown key 'gain'"),
    ("electrodes = ['B1']\n[[experiment]]\nbias_v = [0.0]\nfile = 'a.csv'\n", "missing key 'str"),
    (manifest_text(["a.csv"], [[0.0, 0.0]]).replace("15.58", "true"), "structure_potential_v"),
    (manifest_text(["a.csv"], [[0.0, 0.0]]).replace("0.0, 0.0", "0.0, nan"), r"bias_v\[1\]"),
    (manifest_text(["a.csv"], [[0.0, 0.0]]).replace("[[experiment]]", "[experiment]"), "double"),
    (manifest_text(["a.csv"], [[0.0, 0.0]]).replace('["B1", "B2"]', '["B1", "B1"]'), "twice"),
    (manifest_text(["a.csv"], [[0.0, 0.0]], "device = 3"), r"device is 3"),
    ("structure_potential_v = = 1\n", "not valid TOML"),
]


@pytest.mark.parametrize(("text", "message"), CASES, ids=[str(i) for i in range(len(CASES))])
def test_manifest_errors_name_manifest_and_experiment(
    tmp_path: Path, text: str, message: str
) -> None:
    path = tmp_path / "bad.toml"
    path.write_text(text)
    (tmp_path / "a.csv").write_text(f"{CSV_HEADER}\n1,1,2,3,4,5,6,7,8\n2,1,2,3,4,5,6,7,8\n")
    (tmp_path / "b.csv").write_text((tmp_path / "a.csv").read_text())
    with pytest.raises(ManifestError, match=rf"^{re.escape(str(path))}[:,] .*{message}") as info:
        load_manifest(path)
    assert "\n" not in str(info.value)


def test_bad_response_file_names_manifest_experiment_and_line(tmp_path: Path) -> None:
    path = tmp_path / "m.toml"
    path.write_text(manifest_text(["a.csv", "b.csv"], [[0.0, 0.0], [1.0, 0.0]]))
    (tmp_path / "a.csv").write_text(f"{CSV_HEADER}\n1,1,2,3,4,5,6,7,8\n2,1,2,3,4,5,6,7,8\n")
    (tmp_path / "b.csv").write_text(f"{CSV_HEADER}\n1,1,2,3,4,5,6,7,8\n2,1,2,3,4,5,x,7,8\n")
    with pytest.raises(FileFormatError, match=r"m\.toml, experiment 1: .*b\.csv, line 3: y2_u1_im"):
        load_manifest(path)
    (tmp_path / "b.csv").write_text(f"# response_units: A/V\n{CSV_HEADER}\n1,1,2,3,4,5,6,7,8\n")
    (tmp_path / "a.csv").write_text(f"# response_units: V/V\n{CSV_HEADER}\n1,1,2,3,4,5,6,7,8\n")
    with pytest.raises(ManifestError, match=r"different units \(0: 'V/V', 1: 'A/V'\)"):
        load_manifest(path)
    with pytest.raises(ManifestError, match="no such manifest"):
        load_manifest(tmp_path / "none.toml")


def test_rank_condition_failure_names_the_experiments(
    tmp_path: Path, measured: xr.Dataset, capsys: pytest.CaptureFixture[str]
) -> None:
    manifest = export_dataset(measured, tmp_path, "csv")
    text = manifest.read_text().replace("bias_v = [0.0, 1.0]", "bias_v = [2.0, 0.0]")
    manifest.write_text(text)  # experiment 2 now varies B1 again; B2 never changes
    with pytest.raises(RankConditionError) as info:
        load_manifest(manifest)
    message = str(info.value)
    assert message.startswith(f"{manifest}: the experiment design violates the rank condition")
    assert "experiment 2 is a combination of experiments [0, 1]" in message
    assert "electrode(s) B2 never changes" in message
    assert "(experiments: 0 = exp0.csv, 1 = exp1.csv, 2 = exp2.csv)" in message
    assert main(["import", str(manifest), "--out", str(tmp_path / "x.nc")]) == 1
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "experiment 2 is a combination" in err[0]
    assert not (tmp_path / "x.nc").exists()
    assert main(["fit", str(manifest)]) == 1
    assert "rank condition" in capsys.readouterr().err
    # Too few experiments: the same prefix, its own class.
    manifest.write_text(text.split("\n[[experiment]]\nbias_v = [1.0")[0])
    with pytest.raises(TooFewExperimentsError, match=rf"^{re.escape(str(manifest))}: 1 exp"):
        load_manifest(manifest)


# ------------------------------------------------------------------------------- sysid fit
def fit_json(args: list[str], capsys: pytest.CaptureFixture[str]) -> dict[str, object]:
    assert main(["fit", *args, "--json"]) == 0
    result: dict[str, object] = json.loads(capsys.readouterr().out.strip().splitlines()[-1])
    return result


def test_fit_manifest_equals_fit_of_imported_data(
    tmp_path: Path, csv_manifest: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    data = tmp_path / "imported.nc"
    assert main(["import", str(csv_manifest), "--out", str(data)]) == 0
    capsys.readouterr()
    from_manifest = fit_json([str(csv_manifest)], capsys)
    assert from_manifest["model"] == str(tmp_path / "m.model.nc")  # x.toml -> x.model.nc
    from_data = fit_json([str(data)], capsys)
    assert from_data["model"] == str(tmp_path / "imported.model.nc")
    assert from_manifest["gamma"] == from_data["gamma"]
    assert from_manifest["experiments"] == from_data["experiments"]  # modal frequencies, Q, ...
    freqs = [e["frequencies_hz"] for e in from_manifest["experiments"]]  # type: ignore[attr-defined]
    assert all(4400 < f < 4440 for pair in freqs for f in pair)
    sweep = csv_manifest.parent / "sweeps" / "sweep-0.csv"
    assert main(["fit", str(csv_manifest), "--out", str(sweep), "--force"]) == 1
    assert "refusing to write over the input file" in capsys.readouterr().err


def test_a_format_key_names_the_engine_of_files_without_its_extension(
    tmp_path: Path, measured: xr.Dataset
) -> None:
    names = []
    for k in range(3):
        keep = np.asarray(measured["measured"].values[k], dtype=bool)
        f = measured["frequency"].values[keep]
        name = csv_file(tmp_path / f"exp{k}.csv", f, measured["response"].values[k][keep])
        (tmp_path / name).rename(tmp_path / f"exp{k}.dat")  # an instrument's own extension
        names.append(f"exp{k}.dat")
    path = tmp_path / "m.toml"
    path.write_text(manifest_text(names, [b[:2] for b in BIASES], 'format = "csv"'))
    ds = load_manifest(path)
    assert np.array_equal(ds["response"].values, measured["response"].values, equal_nan=True)
    assert [e.format for e in read_manifest(path).experiments] == ["csv"] * 3

    path.write_text(manifest_text(names, [b[:2] for b in BIASES], 'format = "excel"'))
    with pytest.raises(ManifestError, match=r"format is 'excel'; expected one of .*csv"):
        read_manifest(path)
    path.write_text(manifest_text(names, [b[:2] for b in BIASES]))
    with pytest.raises(FileFormatError, match=r"exp0\.dat: unknown response-file extension"):
        load_manifest(path)
