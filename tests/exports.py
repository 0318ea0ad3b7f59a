"""Files as instruments and MATLAB write them, for the tests of the readers (``tests/data``).

Each writer follows the layout its maker documents; only the number of digits is the toolkit's
(every float in full, ``repr`` or 17 significant digits), so that a round trip holds to 1e-12.

* :func:`write_mat73`: a MATLAB v7.3 ``.mat`` file the way MATLAB's ``save -v7.3`` writes one:
  a 512-byte userblock holding MATLAB's header, then HDF5 (h5py) with each variable a dataset at
  the root, dimensions reversed (column-major), ``MATLAB_class`` attributes, complex values as a
  compound type ``(real, imag)`` and characters as UTF-16 code units.
* :func:`write_copper_mountain`: a Copper Mountain VNA's "trace data CSV file" ("db-Angle"
  format, comment on): three ``!`` comment lines, the last naming the columns, then
  ``F, dB, deg`` rows; with "Decimal Separator: Local" in a German locale, ``;`` and ``,``.
* :func:`write_keysight_e5071c`: the Keysight E5071C's "Save Trace Data" CSV: the quoted lines
  ``"# Channel 1"`` and ``"# Trace 1"``, the header ``Frequency, Formatted Data, Formatted
  Data`` (here the Polar format: real and imaginary part), rows in ``+1.23E+004`` notation.
* :func:`write_keysight_begin_end`: Keysight's CSV with ``!`` header lines and the data of one
  channel between ``BEGIN CH1_DATA`` and ``END`` (as the E4990A manual shows it), with two
  traces: one file per drive port, ``S1j`` and ``S2j`` in log magnitude (dB) and phase (deg).
* :func:`write_lockin`: a lock-in amplifier's sweeper export in a semicolon locale: ``;``
  between fields, decimal commas, magnitude ``r`` and phase ``theta`` in degrees, optionally
  a time column and one column pair per demodulator.
"""

from __future__ import annotations

from pathlib import Path

import h5py
import numpy as np

MATLAB_HEADER = (
    "MATLAB 7.3 MAT-file, Platform: GLNXA64, Created on: Mon Jan  8 10:00:00 2024 "
    "HDF5 schema 1.00 ."
)
_MATLAB_CLASSES = {
    "f8": "double",
    "f4": "single",
    "i1": "int8",
    "i2": "int16",
    "i4": "int32",
    "i8": "int64",
    "u1": "uint8",
    "u2": "uint16",
    "u4": "uint32",
    "u8": "uint64",
    "b1": "logical",
}


def write_mat73(path: Path, **variables: object) -> Path:
    """A MATLAB v7.3 file holding ``variables`` (see the module); 1-D arrays become columns."""
    with h5py.File(path, "w", userblock_size=512, libver="earliest") as fh:
        fh.create_group("#refs#")  # MATLAB's own group (cell arrays' contents): not a variable
        for name, value in variables.items():
            _matlab_dataset(fh, name, value)
    header = MATLAB_HEADER.encode("ascii").ljust(116, b" ")
    header += b" " * 8 + b"\x00\x02" + b"IM"  # subsystem offset, version 0x0200, endian mark
    with open(path, "r+b") as fh:
        fh.write(header.ljust(512, b"\x00"))
    return path


def _matlab_dataset(fh: h5py.File, name: str, value: object) -> None:
    if isinstance(value, dict):  # a struct: a group of fields
        group = fh.create_group(name)
        group.attrs["MATLAB_class"] = np.bytes_("struct")
        for key, field in value.items():
            _matlab_dataset(group, key, field)
        return
    if isinstance(value, str):  # a 1 x k char array: k x 1 in HDF5, UTF-16 code units
        codes = np.frombuffer(value.encode("utf-16-le"), dtype="<u2").reshape(1, -1)
        data, cls = codes.T, "char"
    else:
        array = np.asarray(value)
        if array.ndim == 0:
            array = array.reshape(1, 1)
        elif array.ndim == 1:
            array = array[:, None]  # MATLAB has no 1-D arrays: a column vector
        data = np.ascontiguousarray(array.T)  # column-major: the dimensions reversed
        cls = _MATLAB_CLASSES[data.real.dtype.str[1:]]
        if np.iscomplexobj(data):
            pair = np.dtype([("real", data.real.dtype), ("imag", data.real.dtype)])
            compound = np.empty(data.shape, dtype=pair)
            compound["real"], compound["imag"] = data.real, data.imag
            data = compound
        elif cls == "logical":
            data = data.astype("u1")
    dataset = fh.create_dataset(name, data=data)
    dataset.attrs["MATLAB_class"] = np.bytes_(cls)
    if cls == "char":
        dataset.attrs["MATLAB_int_decode"] = np.int32(2)


# ------------------------------------------------------------------- instruments' exports
def _db(z: np.ndarray) -> np.ndarray:
    return 20.0 * np.log10(np.abs(z))


def _deg(z: np.ndarray) -> np.ndarray:
    return np.degrees(np.angle(z))


def _text(value: float, decimal: str = ".") -> str:
    text = repr(float(value))
    return text.replace(".", ",") if decimal == "," else text


def _keysight(value: float) -> str:
    """Keysight's notation (``+1.41837599227E-002``), with 17 significant digits."""
    mantissa, exponent = f"{value:+.16E}".split("E")
    return f"{mantissa}E{int(exponent):+04d}"


def write_copper_mountain(
    path: Path, f: np.ndarray, z: np.ndarray, parameter: str, local: bool = False
) -> Path:
    """One S-parameter's trace in dB and degrees (``local``: ``;`` and decimal commas)."""
    sep, dec = (";", ",") if local else (",", ".")
    lines = [
        "! COPPER MOUNTAIN TECHNOLOGIES, S5048, 21090001, 22.4.1",
        "! Date: 08.01.2024 10:00:00",
        f"! Stimulus(Hz){sep} {parameter} Log Mag [dB]{sep} {parameter} Phase [deg]",
    ]
    for fk, db, deg in zip(f, _db(z), _deg(z), strict=True):
        lines.append(sep.join(_text(v, dec) for v in (fk, db, deg)))
    path.write_text("\n".join(lines) + "\n", encoding="utf-8")
    return path


def write_keysight_e5071c(path: Path, f: np.ndarray, z: np.ndarray) -> Path:
    """One trace in the Polar format (real, imaginary), CRLF line ends as Windows writes them."""
    lines = [
        '"# Channel 1"',
        '"# Trace 1"',
        "Frequency,                    Formatted Data,            Formatted Data",
    ]
    for fk, zk in zip(f, z, strict=True):
        lines.append(", ".join(_keysight(v) for v in (fk, zk.real, zk.imag)))
    path.write_bytes(("\r\n".join(lines) + "\r\n").encode("ascii"))
    return path


def write_keysight_begin_end(path: Path, f: np.ndarray, z: np.ndarray, port: int) -> Path:
    """Port ``port`` driving: ``S1<port>`` and ``S2<port>`` (``z`` is (n, 2)) in dB and deg."""
    s1, s2 = f"S1{port}", f"S2{port}"
    lines = [
        "!CSV A.01.01",
        "!Keysight Technologies,E5080B,MY59100001,A.15.20.07",
        "!Date: Monday, January 08, 2024 10:00:00",
        "!Source: Standard",
        "",
        "BEGIN CH1_DATA",
        f"Freq(Hz),{s1} Log Mag(dB),{s1} Phase(deg),{s2} Log Mag(dB),{s2} Phase(deg)",
    ]
    for k, fk in enumerate(f):
        values = (fk, _db(z[k, 0]), _deg(z[k, 0]), _db(z[k, 1]), _deg(z[k, 1]))
        lines.append(",".join(_keysight(float(v)) for v in values))
    lines.append("END")
    path.write_text("\n".join(lines) + "\n", encoding="utf-8")
    return path


def write_lockin(
    path: Path,
    f: np.ndarray,
    z: np.ndarray,
    header: list[str],
    times: np.ndarray | None = None,
) -> Path:
    """Columns ``frequency[, time], r, theta[, r, theta]``: ``z`` is (n,) or (n, demodulators)."""
    z = z.reshape(f.size, -1)
    lines = [";".join(header)]
    for k, fk in enumerate(f):
        values = [fk] + ([times[k]] if times is not None else [])
        for zk in z[k]:
            values += [abs(zk), float(_deg(zk))]
        lines.append(";".join(_text(v, ",") for v in values))
    path.write_text("\n".join(lines) + "\n", encoding="utf-8")
    return path
