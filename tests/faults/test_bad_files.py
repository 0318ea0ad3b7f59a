"""Bad lab files: every wrong file is refused in one line naming it, bounded in what is read.

Through the CLI (``sysid import`` of a manifest, ``sysid import --guess``, ``sysid fit``): exit
status 1, one line ``sysid: error: ...``, and the user's files unchanged. The reader
(:mod:`sysid_core.formats.textfile`) checks a file's size before it reads a byte and its first
block for NUL before it reads the rest; the tests count the bytes read, not the time.
"""

from __future__ import annotations

import hashlib
from pathlib import Path

import numpy as np
import pytest

import sysid_core.formats.textfile as textfile
from sysid_core.cli import main
from sysid_core.data.sweep import CSV_HEADER
from sysid_core.errors import DeviceError, FileFormatError
from sysid_core.formats.sweepfiles import read_sweep

ROW = "4385,1,2,3,4,5,6,7,8"
ROW2 = "4386,1,2,3,4,5,6,7,8"


def _manifest(tmp_path: Path, name: str) -> Path:
    path = tmp_path / "m.toml"
    path.write_text(
        'structure_potential_v = 15.58\nelectrodes = ["B1", "B2"]\n'
        f'[[experiment]]\nbias_v = [0.0, 0.0]\nfile = "{name}"\n'
    )
    return path


def _digest(folder: Path) -> dict[str, str]:
    return {
        p.name: hashlib.sha256(p.read_bytes()).hexdigest()
        for p in sorted(folder.iterdir())
        if p.is_file() and p.stat().st_size < 10**7
    }


def _refused(capsys: pytest.CaptureFixture[str], args: list[str]) -> str:
    assert main(args) == 1
    lines = capsys.readouterr().err.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("sysid: error: "), lines
    assert "internal error" not in lines[0]
    return lines[0]


@pytest.mark.parametrize(
    ("name", "content", "message"),
    [
        ("long.csv", f"{CSV_HEADER}\n{ROW}\n4386,{'1' * 200_000},2,3,4,5,6,7,8\n", "line 3: 200"),
        ("nul.csv", f"{CSV_HEADER}\n{ROW}\n".encode() + b"\x00\x00", "not a text file"),
    ],
    ids=["a-field-of-200000-characters", "nul-bytes"],
)
def test_a_broken_response_file_is_refused_in_one_line_through_import_and_fit(
    tmp_path: Path,
    capsys: pytest.CaptureFixture[str],
    name: str,
    content: str | bytes,
    message: str,
) -> None:
    path = tmp_path / name
    path.write_bytes(content if isinstance(content, bytes) else content.encode())
    manifest = _manifest(tmp_path, name)
    before = _digest(tmp_path)
    for args in (
        ["import", str(manifest)],
        ["fit", str(manifest)],
        ["import", "--guess", str(path)],
    ):
        line = _refused(capsys, args)
        assert name in line and message in line, line
    assert _digest(tmp_path) == before
    assert not (tmp_path / "m.nc").exists()


def _sparse(path: Path, size: int) -> Path:
    """A file of ``size`` NUL bytes that takes no disk space (a hole)."""
    with open(path, "wb") as fh:
        fh.truncate(size)
    return path


def test_a_huge_file_is_refused_by_its_size_before_a_byte_is_read(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], monkeypatch: pytest.MonkeyPatch
) -> None:
    """A 2 GB sparse file of NUL bytes named .csv (no disk space used)."""
    path = _sparse(tmp_path / "huge.csv", 2 * 1024**3)
    opened: list[str] = []
    real_open = open

    def counting_open(file: object, *args: object, **kwargs: object) -> object:
        opened.append(str(file))
        return real_open(file, *args, **kwargs)  # type: ignore[call-overload]

    monkeypatch.setattr(textfile, "open", counting_open, raising=False)
    line = _refused(capsys, ["import", str(_manifest(tmp_path, "huge.csv"))])
    assert "huge.csv" in line and "2048 MB" in line
    assert str(path) not in opened  # refused by its size
    line = _refused(capsys, ["import", "--guess", str(path)])
    assert "2048 MB" in line


def test_a_large_file_of_nul_bytes_is_refused_after_its_first_block(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """100 MB of NUL bytes (under the size bound): only the first block is read."""
    path = _sparse(tmp_path / "zeros.csv", 100 * 1024**2)
    read: list[int] = []
    real_open = open

    class Counting:
        def __init__(self, fh: object) -> None:
            self.fh = fh

        def __enter__(self) -> Counting:
            return self

        def __exit__(self, *exc: object) -> None:
            self.fh.close()  # type: ignore[attr-defined]

        def read(self, n: int = -1) -> bytes:
            data = self.fh.read(n)  # type: ignore[attr-defined]
            read.append(len(data))
            return data

    monkeypatch.setattr(
        textfile,
        "open",
        lambda file, mode="r": Counting(real_open(file, mode)),
        raising=False,
    )
    with pytest.raises(
        FileFormatError, match=r"zeros\.csv: not a text file \(a NUL byte at byte 1\)"
    ):
        read_sweep(path)
    assert sum(read) <= textfile.SNIFF_BYTES


def test_the_own_csv_reader_takes_what_the_column_reader_takes(tmp_path: Path) -> None:
    """One reader, one set of rules: a trailing comma on every line and a Latin-1 comment line
    (an instrument's µ from a Windows PC) are read, as the column-map reader reads them."""
    plain = tmp_path / "plain.csv"
    plain.write_text(f"{CSV_HEADER}\n{ROW}\n{ROW2}\n")
    trailing = tmp_path / "trailing.csv"
    trailing.write_text(f"{CSV_HEADER},\n{ROW},\n{ROW2},\n")
    latin = tmp_path / "latin.csv"
    latin.write_bytes(f"# gain 1 \xb5V/V\n{CSV_HEADER}\n{ROW}\n{ROW2}\n".encode("latin-1"))
    ref = read_sweep(plain)
    for path in (trailing, latin):
        got = read_sweep(path)
        np.testing.assert_array_equal(got.values, ref.values)
        np.testing.assert_array_equal(got["frequency"].values, ref["frequency"].values)


def _lockin(tmp_path: Path, time_keys: str) -> Path:
    """A lock-in's export: frequency, the four channels as re/im, and a timestamp in ticks of a
    60 MHz clock (a point every 2 s, 1.6e17 ticks since its epoch)."""
    f = np.linspace(4385.0, 4445.0, 31)
    ticks = 1.6e17 + np.arange(f.size) * 2.0 * 60e6
    rows = ["frequency,timestamp,a,b,c,d,e,g,h,i"]
    for k in range(f.size):
        rows.append(f"{float(f[k])!r},{ticks[k]:.0f},1,2,3,4,5,6,7,8")
    (tmp_path / "lockin.csv").write_text("\n".join(rows) + "\n")
    path = tmp_path / "m.toml"
    path.write_text(
        'structure_potential_v = 15.58\nelectrodes = ["B1", "B2"]\n[columns]\n'
        f'frequency = "frequency"\ntime_s = "timestamp"\n{time_keys}'
        'y1_u1 = { re = "a", im = "b" }\ny1_u2 = { re = "c", im = "d" }\n'
        'y2_u1 = { re = "e", im = "g" }\ny2_u2 = { re = "h", im = "i" }\n'
        + "".join(
            f'[[experiment]]\nbias_v = {b}\nfile = "lockin.csv"\n'
            for b in ([0.0, 0.0], [1.0, 0.0], [0.0, 1.0])
        )
    )
    return path


def test_a_clock_in_ticks_is_refused_unless_the_map_gives_its_rate(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """A lock-in's tick count mapped as seconds spans 114 years in one sweep: refused, naming the
    column and the keys to set; with ``time_unit = "ticks"`` and ``ticks_per_s`` it reads as
    a point every 2 s."""
    from sysid_core.formats.manifest import load_manifest

    line = _refused(capsys, ["import", str(_lockin(tmp_path, ""))])
    assert "lockin.csv" in line and "timestamp" in line and "ticks_per_s" in line, line
    assert "spans 114 years read in s" in line, line
    data = load_manifest(_lockin(tmp_path, 'time_unit = "ticks"\nticks_per_s = 60e6\n'))
    t = np.asarray(data["time_s"].values[0], dtype=float)
    np.testing.assert_allclose(np.diff(t), 2.0, rtol=1e-9)
    line = _refused(capsys, ["import", str(_lockin(tmp_path, 'time_unit = "ticks"\n'))])
    assert "ticks_per_s" in line, line


def test_an_exchange_answer_with_a_huge_field_is_rejected_and_the_reason_ends_the_wait(
    tmp_path: Path,
) -> None:
    """Through the exchange device: an answer with one field of 200 000 characters is moved to
    rejected/ with its reason (not an internal error), and when no answer follows, the one line
    that ends the run says why the last answer was refused (with --json it is the only line)."""
    from sysid_exchange.device import ExchangeDevice

    folder = tmp_path / "exchange"
    folder.mkdir()
    device = ExchangeDevice(
        dir=str(folder),
        electrodes=["B1", "B2"],
        bias_limits=[-10.0, 10.0],
        structure_potential=15.58,
        band_hz=[4385.0, 4445.0],
        wait_s=0.3,
        poll_s=0.05,
    )
    (folder / "response-0001.csv").write_text(
        f"{CSV_HEADER}\n{ROW}\n4386,{'1' * 200_000},2,3,4,5,6,7,8\n"
    )
    with pytest.raises(FileFormatError) as never:  # what the reader says of it
        read_sweep(folder / "response-0001.csv")
    with pytest.raises(
        DeviceError, match=r"the last answer was rejected: .*line 3: 200019"
    ) as info:
        device.measure([0.0, 0.0], np.array([4385.0, 4386.0]))
    assert "\n" not in str(info.value) and "rejected/response-0001.csv.1" in str(info.value)
    reason = (folder / "rejected" / "response-0001.csv.1.txt").read_text()
    assert str(never.value).split(": ", 1)[1] in reason
