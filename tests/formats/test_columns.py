"""Column maps in the manifest (``sysid_core.formats.columnmap``, ``.columnsweep``) and
``sysid import --guess`` (``.columnguess``): the exports labs really have, written by the tests in
the layouts the instruments' manuals document (``tests/exports.py``), read through a manifest and
compared with the same sweeps in the toolkit's own CSV (1e-12, relative; time stamps exact); the
column maps ``--guess`` proposes read them as well; every error names the manifest, the
experiment and the column.
"""

from __future__ import annotations

import re
import runpy
import tomllib
from pathlib import Path

import numpy as np
import pytest
import xarray as xr
from exports import (
    write_copper_mountain,
    write_keysight_begin_end,
    write_keysight_e5071c,
    write_lockin,
)
from sysid_cloverleaf import CloverleafGyro

from sysid_core.cli import main
from sysid_core.data.schema import make_dataset
from sysid_core.errors import FileFormatError, ManifestError
from sysid_core.formats.columnguess import guess_column_map
from sysid_core.formats.columnmap import parse_column_map
from sysid_core.formats.columnsweep import read_columns
from sysid_core.formats.manifest import data_files, export_dataset, load_manifest, read_manifest

BIASES = [[0.0, 0.0], [1.0, 0.0], [0.0, 1.0]]  # the paper's, on B1 and B2 (B3 held at 0 V)
GRIDS = [np.linspace(4385.0, 4445.0, 61), np.linspace(4386.0, 4444.0, 59)]
GRIDS.append(GRIDS[0])
HEAD = 'device = "cloverleaf"\nstructure_potential_v = 15.58\nelectrodes = ["B1", "B2"]\n'
S_FILES = {"y1_u1": "S11", "y1_u2": "S12", "y2_u1": "S21", "y2_u2": "S22"}  # S_ij = y_i / u_j


@pytest.fixture(scope="module")
def truth() -> xr.Dataset:
    """Three sweeps of the simulated cloverleaf (V/V) with time stamps, one grid each."""
    gyro = CloverleafGyro(seed=21)
    responses = [gyro.measure([*b, 0.0], f).values for b, f in zip(BIASES, GRIDS, strict=True)]
    times = [600.0 * k + 0.25 * np.arange(f.size) for k, f in enumerate(GRIDS)]
    return make_dataset(responses, GRIDS, BIASES, ["B1", "B2"], 15.58, "cloverleaf", times_s=times)


@pytest.fixture(scope="module")
def reference(truth: xr.Dataset, tmp_path_factory: pytest.TempPathFactory) -> xr.Dataset:
    """The sweeps read back from the toolkit's own CSV files (through their manifest)."""
    folder = tmp_path_factory.mktemp("own")
    return load_manifest(export_dataset(truth, folder, "csv"))


def sweeps(truth: xr.Dataset) -> list[tuple[np.ndarray, np.ndarray, np.ndarray]]:
    """Per experiment: its frequencies, response (n, 2, 2) and time stamps."""
    mask = truth["measured"].values
    return [
        (
            truth["frequency"].values[m],
            truth["response"].values[k][m],
            truth["time_s"].values[k][m],
        )
        for k, m in enumerate(mask)
    ]


def manifest(folder: Path, columns: str, files: list[str], name: str = "m.toml") -> Path:
    """A manifest with the table ``[columns]`` and one experiment per ``files`` line."""
    text = HEAD + "[columns]\n" + columns + "\n"
    for bias, line in zip(BIASES, files, strict=True):
        text += f"\n[[experiment]]\nbias_v = {bias}\n{line}\n"
    path = folder / name
    path.write_text(text, encoding="utf-8")
    return path


def files_line(names: dict[str, str]) -> str:
    return "files = { " + ", ".join(f'{k} = "{v}"' for k, v in names.items()) + " }"


def assert_round_trip(got: xr.Dataset, reference: xr.Dataset, times: bool = True) -> None:
    """The responses within 1e-12 (relative); frequencies, biases, times and the rest exact."""
    np.testing.assert_allclose(
        got["response"].values, reference["response"].values, rtol=1e-12, atol=0
    )
    if not times:
        reference = reference.drop_vars("time_s", errors="ignore")
    xr.testing.assert_identical(got.drop_vars("response"), reference.drop_vars("response"))


# ------------------------------------------------------------------- the instruments' layouts
def network_analyzer_per_parameter(folder: Path, truth: xr.Dataset, local: bool) -> list[str]:
    """Copper Mountain exports, one per S-parameter and experiment; the experiments' lines."""
    lines = []
    for k, (f, h, _) in enumerate(sweeps(truth)):
        names = {}
        for channel, s in S_FILES.items():
            o, i = int(channel[1]) - 1, int(channel[4]) - 1
            names[channel] = write_copper_mountain(
                folder / f"exp{k}_{s}.csv", f, h[:, o, i], s, local=local
            ).name
        lines.append(files_line(names))
    return lines


@pytest.mark.parametrize("local", [False, True], ids=["point", "german-locale"])
def test_network_analyzer_one_file_per_s_parameter(
    tmp_path: Path, truth: xr.Dataset, reference: xr.Dataset, local: bool
) -> None:
    lines = network_analyzer_per_parameter(tmp_path, truth, local)
    separators = 'delimiter = ";"\ndecimal = ","\n' if local else ""
    columns = (
        f'{separators}comment = "!"\nheader = false\nfrequency = 1\nresponse_units = "V/V"\n'
        "channel = { db = 2, phase_deg = 3 }"
    )
    path = manifest(tmp_path, columns, lines)
    assert_round_trip(load_manifest(path), reference, times=False)
    assert len(data_files(path)) == 1 + 3 * 4
    m = read_manifest(path)
    assert [key for key, _ in m.experiments[1].files] == ["y1_u1", "y1_u2", "y2_u1", "y2_u2"]
    assert m.experiments[1].file == tmp_path / "exp1_S11.csv"
    text = (tmp_path / "exp0_S21.csv").read_text().splitlines()
    assert text[2].startswith("! Stimulus(Hz)") and len(text) == 3 + 61


def test_network_analyzer_one_file_per_drive_port(
    tmp_path: Path, truth: xr.Dataset, reference: xr.Dataset
) -> None:
    lines = []
    for k, (f, h, _) in enumerate(sweeps(truth)):
        ports = {
            f"u{j}": write_keysight_begin_end(
                tmp_path / f"exp{k}_port{j}.csv", f, h[:, :, j - 1], j
            )
            for j in (1, 2)
        }
        lines.append(files_line({key: p.name for key, p in ports.items()}))
    columns = (
        'comment = ["!", "BEGIN", "END"]\nfrequency = "Freq(Hz)"\nresponse_units = "V/V"\n'
        "y1 = { db = 2, phase_deg = 3 }\ny2 = { db = 4, phase_deg = 5 }"
    )
    assert_round_trip(load_manifest(manifest(tmp_path, columns, lines)), reference, times=False)
    assert "S12 Log Mag(dB)" in (tmp_path / "exp0_port2.csv").read_text()


def test_network_analyzer_real_imaginary_traces(
    tmp_path: Path, truth: xr.Dataset, reference: xr.Dataset
) -> None:
    lines = []
    for k, (f, h, _) in enumerate(sweeps(truth)):
        names = {}
        for channel, s in S_FILES.items():
            o, i = int(channel[1]) - 1, int(channel[4]) - 1
            names[channel] = write_keysight_e5071c(tmp_path / f"{s}_{k}.csv", f, h[:, o, i]).name
        lines.append(files_line(names))
    columns = 'frequency = "Frequency"\nresponse_units = "V/V"\nchannel = { re = 2, im = 3 }'
    assert_round_trip(load_manifest(manifest(tmp_path, columns, lines)), reference, times=False)
    # The two columns share one name: by name the map is ambiguous, and says so.
    bad = manifest(tmp_path, columns.replace("re = 2", 're = "Formatted Data"'), lines, "n.toml")
    with pytest.raises(FileFormatError, match=r"channel\.re = 'Formatted Data': the header has 2"):
        load_manifest(bad)


def lockin_per_input(folder: Path, truth: xr.Dataset) -> list[str]:
    """Lock-in sweeps, one file per drive input, a demodulator per output, time stamps."""
    header = [
        "Frequency (Hz)",
        "Time (s)",
        "R Demod 1 (V)",
        "Theta Demod 1 (deg)",
        "R Demod 2 (V)",
        "Theta Demod 2 (deg)",
    ]
    lines = []
    for k, (f, h, t) in enumerate(sweeps(truth)):
        names = {
            f"u{j}": write_lockin(folder / f"sweep{k}_u{j}.csv", f, h[:, :, j - 1], header, t).name
            for j in (1, 2)
        }
        lines.append(files_line(names))
    return lines


LOCKIN_COLUMNS = """delimiter = ";"
decimal = ","
frequency = "Frequency (Hz)"
time_s = "Time (s)"
response_units = "V/V"
y1 = { mag = "R Demod 1 (V)", phase_deg = "Theta Demod 1 (deg)" }
y2 = { mag = "R Demod 2 (V)", phase_deg = "Theta Demod 2 (deg)" }"""


def test_lockin_one_file_per_drive_input_with_time_stamps(
    tmp_path: Path, truth: xr.Dataset, reference: xr.Dataset
) -> None:
    lines = lockin_per_input(tmp_path, truth)
    got = load_manifest(manifest(tmp_path, LOCKIN_COLUMNS, lines))
    assert_round_trip(got, reference)  # time_s included, exactly
    assert "4385,0;0,0;" in (tmp_path / "sweep0_u1.csv").read_text()


def test_lockin_frequency_r_theta_one_file_per_channel(
    tmp_path: Path, truth: xr.Dataset, reference: xr.Dataset
) -> None:
    """The sweeper's ``frequency;r;theta`` in a semicolon locale, in kHz, per experiment's map."""
    lines = []
    for k, (f, h, _) in enumerate(sweeps(truth)):
        names = {}
        for o in (1, 2):
            for i in (1, 2):
                path = tmp_path / f"e{k}-y{o}u{i}.txt"
                write_lockin(path, f / 1e3, h[:, o - 1, i - 1], ["frequency", "r", "theta"])
                names[f"y{o}_u{i}"] = path.name
        lines.append(files_line(names) + '\ncolumns = { frequency_unit = "kHz" }')
    columns = (
        'delimiter = ";"\ndecimal = ","\nfrequency = "frequency"\nresponse_units = "V/V"\n'
        'channel = { mag = "r", phase_deg = "theta" }'
    )
    got = load_manifest(manifest(tmp_path, columns, lines))
    # kHz: f / 1e3 * 1e3 may differ from f in the last bit; the rest as before.
    np.testing.assert_allclose(got["frequency"].values, reference["frequency"].values, rtol=1e-15)
    assert_round_trip(got.assign_coords(frequency=reference["frequency"]), reference, times=False)


def test_one_file_with_every_channel_and_a_mixed_manifest(
    tmp_path: Path, truth: xr.Dataset, reference: xr.Dataset
) -> None:
    """One export holding all four channels; an experiment in .s2p is read as always."""
    export_dataset(truth, tmp_path / "s2p", "s2p")
    lines = ['file = "s2p/exp1.s2p"']
    for k, (f, h, t) in enumerate(sweeps(truth)):
        if k == 1:
            continue
        rows = [
            "Freq [kHz]\tY1U1 mag\tY1U1 phase [rad]\tY1U2 mag\tY1U2 phase [rad]"
            "\tY2U1 mag\tY2U1 phase [rad]\tY2U2 mag\tY2U2 phase [rad]\tt"
        ]
        for n in range(f.size):
            z = h[n].ravel()
            values = [f[n] / 1e3, *[v for zk in z for v in (abs(zk), np.angle(zk))], t[n]]
            rows.append("\t".join(repr(float(v)) for v in values))
        (tmp_path / f"all{k}.tsv").write_text("\n".join(rows) + "\n")
        lines.insert(k, f'file = "all{k}.tsv"')
    channels = "\n".join(
        f'y{o}_u{i} = {{ mag = "Y{o}U{i} mag", phase_rad = "Y{o}U{i} phase [rad]" }}'
        for o in (1, 2)
        for i in (1, 2)
    )
    columns = f'delimiter = "\\t"\nfrequency = 1\nfrequency_unit = "kHz"\ntime_s = "t"\n{channels}'
    got = load_manifest(manifest(tmp_path, columns, lines))
    assert read_manifest(tmp_path / "m.toml").experiments[1].columns is None  # the .s2p file
    np.testing.assert_allclose(got["frequency"].values, reference["frequency"].values, rtol=1e-15)
    got = got.assign_coords(frequency=reference["frequency"])
    # Touchstone has no time stamps: experiment 1 has none, the others theirs.
    expected = reference.copy()
    expected["time_s"] = reference["time_s"].where(reference["experiment"] != 1)
    assert_round_trip(got, expected)


# ---------------------------------------------------------------------- sysid import --guess
def guessed_columns(path: Path, capsys: pytest.CaptureFixture[str], complete: bool = True) -> str:
    """What ``sysid import --guess`` prints for ``path``: a [columns] table, checked as TOML
    (and as a column map when ``complete``)."""
    assert main(["import", "--guess", str(path)]) == 0
    text = capsys.readouterr().out
    assert text == guess_column_map(path).toml()
    table = tomllib.loads(text)["columns"]
    if complete:
        parse_column_map(table, "guess")
    return text.split("[columns]\n", 1)[1]


def test_guess_network_analyzer_exports(
    tmp_path: Path, truth: xr.Dataset, reference: xr.Dataset, capsys: pytest.CaptureFixture[str]
) -> None:
    lines = network_analyzer_per_parameter(tmp_path, truth, local=True)
    text = guessed_columns(tmp_path / "exp0_S21.csv", capsys)
    assert 'delimiter = ";"\ndecimal = ","\ncomment = ["!"]\nheader = false\n' in text
    assert "channel = { db = 2, phase_deg = 3 }" in text
    assert '# files = { y2_u1 = "exp0_S21.csv", ... }' in text  # S21 = y2/u1
    path = manifest(tmp_path, text + 'response_units = "V/V"', lines)
    assert_round_trip(load_manifest(path), reference, times=False)

    folder = tmp_path / "ports"
    folder.mkdir()
    f, h, _ = sweeps(truth)[0]
    write_keysight_begin_end(folder / "port2.csv", f, h[:, :, 1], 2)
    text = guessed_columns(folder / "port2.csv", capsys)
    # the comment lines and the BEGIN/END markers as comments, not a count of lines to skip:
    # the map also reads a file with one more "!" line (issue: skip_lines = 6 broke on it)
    assert 'comment = ["!", "BEGIN", "END"]\nfrequency = "Freq(Hz)"' in text
    assert "skip_lines" not in text
    longer = folder / "port2-more.csv"
    lines_ = (folder / "port2.csv").read_text().splitlines()
    longer.write_text("\n".join(["!Calibration: on", *lines_]) + "\n")
    table = parse_column_map(tomllib.loads("[c]\n" + text)["c"], "guess")
    again = read_columns({"u1": longer, "u2": longer}, table)
    np.testing.assert_allclose(again.values[:, :, 1], h[:, :, 1], rtol=1e-12, atol=0)
    assert "y1 = { db = 2, phase_deg = 3 }\ny2 = { db = 4, phase_deg = 5 }" in text  # S12, S22
    assert '# files = { u2 = "port2.csv", u1 = "..." }' in text
    read = read_columns(
        {"u1": folder / "port2.csv", "u2": folder / "port2.csv"},
        parse_column_map(tomllib.loads("[c]\n" + text)["c"], "guess"),
    )
    np.testing.assert_allclose(read.values[:, :, 1], h[:, :, 1], rtol=1e-12, atol=0)

    write_keysight_e5071c(folder / "trace.csv", f, h[:, 1, 0])
    text = guessed_columns(folder / "trace.csv", capsys, complete=False)
    assert "frequency = 1\n" in text  # repeated names: every column by number
    assert "could not decide which columns hold which channel" in text
    assert "2 ('Formatted Data'), 3 ('Formatted Data')" in text


def test_guess_lockin_exports(
    tmp_path: Path, truth: xr.Dataset, reference: xr.Dataset, capsys: pytest.CaptureFixture[str]
) -> None:
    lines = lockin_per_input(tmp_path, truth)
    text = guessed_columns(tmp_path / "sweep1_u2.csv", capsys)
    assert text.startswith('delimiter = ";"\ndecimal = ","\n')
    assert 'time_s = "Time (s)"' in text
    assert 'y2 = { mag = "R Demod 2 (V)", phase_deg = "Theta Demod 2 (deg)" }' in text
    path = manifest(tmp_path, text + 'response_units = "V/V"', lines)
    assert_round_trip(load_manifest(path), reference)

    f, h, _ = sweeps(truth)[0]
    write_lockin(tmp_path / "one.csv", f, h[:, 0, 0], ["frequency", "r", "theta"])
    text = guessed_columns(tmp_path / "one.csv", capsys)
    assert 'channel = { mag = "r", phase_deg = "theta" }' in text
    assert "column 3 ('theta'): phase in deg (the name does not say; its values are beyond" in text
    assert "frequency_unit: the name does not say; took Hz" in text


def test_guess_of_bad_input_is_one_line(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    def error(args: list[str], status: int = 1) -> str:
        assert main(["import", *args]) == status
        lines = capsys.readouterr().err.strip().splitlines()
        if status == 1:
            assert len(lines) == 1 and lines[0].startswith("sysid: error: "), lines
        return "\n".join(lines)

    assert "no such file" in error(["--guess", str(tmp_path / "none.csv")])
    (tmp_path / "words.csv").write_text("a,b\nc,d\n")
    assert "no rows of numbers" in error(["--guess", str(tmp_path / "words.csv")])
    (tmp_path / "x.dat").write_bytes(bytes(range(256)))
    assert "not a text file" in error(["--guess", str(tmp_path / "x.dat")])
    (tmp_path / "x.mat").write_bytes(b"MATLAB 5.0 MAT-file")
    assert "read as it is" in error(["--guess", str(tmp_path / "x.mat")])
    assert "--guess" in error(["m.toml", "--guess", str(tmp_path / "words.csv")], status=2)
    assert "MANIFEST" in error([], status=2)


# ----------------------------------------------------------------------------------- errors
def set_field(path: Path, number: int, field: int, value: str) -> None:
    """Set field ``field`` (from 0; one past the last appends one) of line ``number``."""
    lines = path.read_text().splitlines()
    fields = lines[number - 1].split(";")
    fields[field : field + 1] = [value]
    lines[number - 1] = ";".join(fields)
    path.write_text("\n".join(lines) + "\n")


def lockin_manifest(tmp_path: Path, truth: xr.Dataset, columns: str = LOCKIN_COLUMNS) -> Path:
    return manifest(tmp_path, columns, lockin_per_input(tmp_path, truth))


MAP_CASES = [  # (replace in the manifest, by, error message after "m.toml, experiment k: ")
    (
        'sweep1_u2.csv" }',
        'sweep1_u2.csv" }\ncolumns = { y1 = { mag = "R Demod 1 (V)" } }',
        r"1: experiment\.columns\.y1: gives mag; a channel needs re and im",
    ),
    ('decimal = ","', 'decimal = ","\nphase_unit = "deg"', r"0: unknown key 'columns\.phase_unit'"),
    ('u2 = "sweep2_u2.csv"', 'u3 = "sweep2_u2.csv"', r"2: files has u1, u3; expected one file"),
    (
        'files = { u1 = "sweep1_u1.csv"',
        'file = "x.csv"\nfiles = { u1 = "sweep1_u1.csv"',
        "1: both 'file' and",
    ),
    ('y1 = { mag = "R Demod 1 (V)"', "y1 = { mag = 0", r"0: columns\.y1\.mag = 0: 0 is not a col"),
    ('decimal = ","', 'decimal = ","\nheader = false', "0: column map: header = false, so col"),
    ('delimiter = ";"', 'delimiter = ","', r"0: column map: decimal = ',' needs another"),
    ('delimiter = ";"', 'delimiter = "||"', r"0: columns\.delimiter = '\|\|': expected one"),
    (
        'files = { u1 = "sweep2_u1.csv", u2 = "sweep2_u2.csv" }',
        'files = { y1_u1 = "sweep2_u1.csv", y1_u2 = "sweep2_u2.csv", y2_u1 = "sweep2_u1.csv", '
        'y2_u2 = "sweep2_u2.csv" }',
        r"2: the column map names the channel\(s\) y1, y2, which is for one file per drive input "
        r".*; this experiment has one file per channel",
    ),
    (
        'files = { u1 = "sweep1_u1.csv", u2 = "sweep1_u2.csv" }',
        'file = "exp1.mat"\ncolumns = { response_units = "V" }',
        r"1: a column map reads text files only; exp1\.mat has its own format",
    ),
]


@pytest.mark.parametrize(("old", "new", "message"), MAP_CASES, ids=[str(i) for i in range(10)])
def test_column_map_errors_name_manifest_experiment_and_key(
    tmp_path: Path, truth: xr.Dataset, old: str, new: str, message: str
) -> None:
    path = lockin_manifest(tmp_path, truth)
    export_dataset(truth, tmp_path / "mat", "mat")
    (tmp_path / "exp1.mat").write_bytes((tmp_path / "mat" / "exp1.mat").read_bytes())
    text = path.read_text()
    assert old in text
    path.write_text(text.replace(old, new, 1))
    with pytest.raises(ManifestError, match=rf"^{re.escape(str(path))}, experiment {message}"):
        load_manifest(path)
    no_map = HEAD + "[[experiment]]\nbias_v = [0.0, 0.0]\nfiles = { u1 = 'a', u2 = 'b' }\n"
    (tmp_path / "a").write_text("")
    (tmp_path / "b").write_text("")
    path.write_text(no_map)
    with pytest.raises(ManifestError, match="experiment 0: several files need a column map"):
        read_manifest(path)


FILE_CASES = [  # (file, line, field, new value, the error after "m.toml, experiment k: ")
    (
        "sweep1_u2.csv",
        5,
        6,
        "1,0",
        r"sweep1_u2\.csv, line 5: 7 field\(s\), but the header \(line 1\) has 6; check the deli",
    ),
    (
        "sweep1_u2.csv",
        4,
        3,
        "n/a",
        r"sweep1_u2\.csv, line 4: column 'Theta Demod 1 \(deg\)' \(y1\.phase_deg\) is 'n/a', "
        r"not a number \(decimal mark ','\)",
    ),
    (
        "sweep2_u1.csv",
        7,
        0,
        "4390.0",
        r"sweep2_u1\.csv, line 7: column 'Frequency \(Hz\)' \(frequency\) is '4390\.0', not a",
    ),
    (
        "sweep0_u2.csv",
        3,
        0,
        "4386,5",
        r"sweep0_u2\.csv, line 3: frequency 4386\.5, but .*sweep0_u1\.csv has 4386\.0 at that "
        r"point \(line 3\); the files of one experiment must share their frequency grid",
    ),
    (
        "sweep0_u1.csv",
        1,
        4,
        "R2",
        r"sweep0_u1\.csv, line 1: y2\.mag = 'R Demod 2 \(V\)': the header has no column of that "
        r"name \(its columns: 'Frequency \(Hz\)', 'Time \(s\)', 'R Demod 1 \(V\)', ",
    ),
    (
        "sweep1_u1.csv",
        9,
        2,
        "nan",
        r"sweep1_u1\.csv, line 9: y1_u1 \(columns 'R Demod 1 \(V\)', 'Theta Demod 1 \(deg\)'\): "
        r"\(nan\+nanj\) at 4393\.0 Hz; every value must be finite",
    ),
]


@pytest.mark.parametrize(("name", "line", "field", "value", "message"), FILE_CASES)
def test_read_errors_name_manifest_experiment_file_line_and_column(
    tmp_path: Path,
    truth: xr.Dataset,
    capsys: pytest.CaptureFixture[str],
    name: str,
    line: int,
    field: int,
    value: str,
    message: str,
) -> None:
    path = lockin_manifest(tmp_path, truth)
    set_field(tmp_path / name, line, field, value)
    k = name[5]
    with pytest.raises(
        FileFormatError, match=rf"^{re.escape(str(path))}, experiment {k}: .*{message}"
    ):
        load_manifest(path)
    assert main(["import", str(path), "--out", str(tmp_path / "x.nc")]) == 1
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and re.search(rf"experiment {k}: .*{message}", err[0]), err
    assert not (tmp_path / "x.nc").exists()


def test_a_magnitude_in_db_mapped_as_linear_is_named(tmp_path: Path, truth: xr.Dataset) -> None:
    lines = network_analyzer_per_parameter(tmp_path, truth, local=False)
    columns = 'comment = "!"\nheader = false\nfrequency = 1\nchannel = { mag = 2, phase_deg = 3 }'
    path = manifest(tmp_path, columns, lines)
    message = r"experiment 0: .*exp0_S11\.csv, line 4: column 2 \(channel\.mag\) is -\d.*: a linear"
    with pytest.raises(FileFormatError, match=message):
        load_manifest(path)


# ----------------------------------------------------------------- the example and the docs
ROOT = Path(__file__).resolve().parents[2]


def test_the_lockin_example_is_the_measured_example(tmp_path: Path) -> None:
    """``examples/lockin/`` reads as ``examples/measured/`` (1e-12), and its script makes it."""
    lockin = load_manifest(ROOT / "examples" / "lockin" / "manifest.toml")
    own = load_manifest(ROOT / "examples" / "measured" / "manifest.toml")
    assert_round_trip(lockin, own, times=False)
    runpy.run_path(str(ROOT / "examples" / "make_lockin_example.py"), run_name="example")["main"](
        tmp_path
    )
    shipped = sorted((ROOT / "examples" / "lockin").iterdir())
    assert [p.name for p in shipped] == sorted(p.name for p in tmp_path.iterdir())
    # the same files: the manifest byte for byte; the exports' numbers to 1e-12 (magnitude and
    # phase may differ in the last digit with the CPU's math kernels)
    assert (ROOT / "examples" / "lockin" / "manifest.toml").read_bytes() == (
        tmp_path / "manifest.toml"
    ).read_bytes()
    assert_round_trip(load_manifest(tmp_path / "manifest.toml"), lockin)


def docs_manifests() -> list[dict[str, object]]:
    """The manifests with a column map among the toml blocks of docs/column-maps.md."""
    text = (ROOT / "docs" / "column-maps.md").read_text()
    blocks = re.findall(r"```toml\n(.*?)```", text, flags=re.DOTALL)
    return [tomllib.loads(b) for b in blocks if "[columns]" in b]


def test_the_docs_column_maps_are_valid() -> None:
    manifests = docs_manifests()
    assert len(manifests) == 3
    for doc in manifests:
        top = doc["columns"]
        assert isinstance(top, dict) and isinstance(doc["experiment"], list)
        for k, experiment in enumerate(doc["experiment"]):
            column_map = parse_column_map({**top, **experiment.get("columns", {})}, f"exp {k}")
            files = experiment["files"]
            assert set(files) == {"u1", "u2"} or column_map.layout == "channel"
    shipped = tomllib.loads((ROOT / "examples" / "lockin" / "manifest.toml").read_text())
    assert manifests[1] == {k: v for k, v in shipped.items() if k != "device"}


# ---------------------------------------------------------------------- the map's other keys
def test_other_layouts_read_exactly(tmp_path: Path, truth: xr.Dataset) -> None:
    """Whitespace, skipped lines, no header, rad/s, re/im, quotes, UTF-16, Latin-1, tabs."""
    f, h, _ = sweeps(truth)[0]
    omega = 2 * np.pi * f
    rows = [
        f"{float(w)!r}   {float(z.real)!r}\t{float(z.imag)!r}"
        for w, z in zip(omega, h[:, 1, 0], strict=True)
    ]
    path = tmp_path / "plain.dat"
    path.write_text("Sweep 12 (a title line)\nNo header follows\n" + "\n".join(rows) + "\n")
    columns = parse_column_map(
        {
            "delimiter": "whitespace",
            "skip_lines": 2,
            "header": False,
            "frequency": 1,
            "frequency_unit": "rad/s",
            "channel": {"re": 2, "im": 3},
        },
        "test",
    )
    files = {c: path for c in ("y1_u1", "y1_u2", "y2_u1", "y2_u2")}
    sweep = read_columns(files, columns)
    np.testing.assert_allclose(sweep["frequency"].values, f, rtol=1e-15)
    assert (sweep.values[:, 1, 1] == h[:, 1, 0]).all() and sweep.attrs["units"] == ""
    with pytest.raises(FileFormatError, match=r"for files keyed 'y1_u1', .*; got 'u1', 'u2'"):
        read_columns({"u1": path, "u2": path}, columns)

    # Quoted fields, a trailing delimiter, a degree sign in Latin-1, then in UTF-16.
    lines = ['"Freq; Hz";"Mag";"Phase (°)";'] + [
        f'"{float(fk)!r}";{float(abs(z))!r};{float(np.degrees(np.angle(z)))!r};'
        for fk, z in zip(f, h[:, 0, 0], strict=True)
    ]
    columns = parse_column_map(
        {
            "delimiter": ";",
            "frequency": "Freq; Hz",
            "channel": {"mag": "Mag", "phase_deg": "Phase (°)"},
        },
        "test",
    )
    for encoding in ("latin-1", "utf-16"):
        path = tmp_path / f"{encoding}.csv"
        path.write_bytes(("\r\n".join(lines) + "\r\n").encode(encoding))
        sweep = read_columns(dict.fromkeys(files, path), columns)
        np.testing.assert_allclose(sweep.values[:, 0, 0], h[:, 0, 0], rtol=1e-12, atol=0)
        guess = guess_column_map(path)
        assert guess.keys["channel"] == {"mag": "Mag", "phase_deg": "Phase (°)"}, guess.toml()

    path = tmp_path / "tabs.txt"
    path.write_text("f\tre\tim\n" + "\n".join(r.replace("   ", "\t") for r in rows) + "\n")
    assert 'delimiter = "\\t"\n' in guess_column_map(path).toml()


def test_a_manifest_experiment_made_with_one_file_lists_it() -> None:
    from sysid_core.formats.manifest import ManifestExperiment

    e = ManifestExperiment(0, (0.0,), Path("a.csv"))
    assert e.files == (("", Path("a.csv")),) and e.columns is None
