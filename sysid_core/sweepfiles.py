"""Response files: one sweep at one bias, its 2x2 complex frequency response, in four formats.

:func:`read_sweep` and :func:`write_sweep` choose the format by the file's extension (any case):

* ``.csv``: the header ``frequency_hz,y1_u1_re,y1_u1_im,y1_u2_re,y1_u2_im,y2_u1_re,y2_u1_im,
  y2_u2_re,y2_u2_im`` (:data:`CSV_HEADER`, row-major over outputs then inputs), one row per
  frequency; lines starting with ``#`` are comments, and ``# response_units: V/V`` gives the units.
* ``.s2p``: Touchstone, read and written with scikit-rf (``skrf.Network``); ``S_ij`` is output
  ``i`` over input ``j`` (``S21 = y2/u1``); a comment ``! response_units: V/V`` gives the units.
* ``.mat``: variables ``frequency_hz`` (n,) and ``response`` (n, 2, 2) complex, optionally a string
  ``response_units``.
* ``.nc``: a one-experiment data set as :func:`sysid_core.data.save_dataset` writes it, or a bare
  DataArray with dims ``frequency``, ``output``, ``input`` (complex, or split into
  ``<name>_real`` / ``<name>_imag`` as the data sets are).

Every reader checks what it read (complex, finite values; positive, finite, strictly increasing
frequencies; the columns or shape) and says in one line which file, which line (CSV, Touchstone)
or variable (.mat, .nc), and what is wrong (:class:`~sysid_core.errors.FileFormatError`). Nothing
here knows about runs, biases or manifests: a device that exchanges files reads its answers with
:func:`read_sweep` too. Longer than 300 lines because it holds the four formats' readers and
writers, which share their checks.
"""

from __future__ import annotations

import csv
import io
import os
import re
import warnings
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import Any

import numpy as np
import xarray as xr

from sysid_core.data import load_dataset, measured_mask, save_dataset
from sysid_core.errors import (
    DataError,
    DimensionError,
    FileFormatError,
    FrequencyGridError,
    NonFiniteDataError,
)
from sysid_core.io import atomic_write

__all__ = [
    "CSV_HEADER",
    "INPUTS",
    "OUTPUTS",
    "SWEEP_FORMATS",
    "make_sweep",
    "read_sweep",
    "write_sweep",
]

OUTPUTS = ("y1", "y2")
INPUTS = ("u1", "u2")
#: The file formats, by extension.
SWEEP_FORMATS = (".csv", ".s2p", ".mat", ".nc")
_CHANNELS = [f"{y}_{u}" for y in OUTPUTS for u in INPUTS]
CSV_COLUMNS = ("frequency_hz", *[f"{c}_{part}" for c in _CHANNELS for part in ("re", "im")])
CSV_HEADER = ",".join(CSV_COLUMNS)
_UNITS = re.compile(r"^\s*response_units\s*:(.*)$")


# ------------------------------------------------------------------------------ common parts
def make_sweep(
    frequency_hz: Sequence[float] | np.ndarray,
    response: np.ndarray,
    units: str = "",
    source: str = "",
) -> xr.DataArray:
    """The DataArray of one sweep: complex, dims ``(frequency, output, input)``, shape (n, 2, 2).

    Coordinates ``frequency`` (Hz), ``output`` (y1, y2), ``input`` (u1, u2); attributes
    ``units`` (the response's units, ``""`` if unknown) and ``source`` (where it came from).
    Nothing is checked here; :func:`read_sweep` checks before it calls this.
    """
    return xr.DataArray(
        np.asarray(response, dtype=complex),
        dims=("frequency", "output", "input"),
        coords={
            "frequency": ("frequency", np.asarray(frequency_hz, dtype=float), {"units": "Hz"}),
            "output": list(OUTPUTS),
            "input": list(INPUTS),
        },
        name="response",
        attrs={"units": units, "source": source},
    )


def _check(
    f: np.ndarray,
    resp: np.ndarray,
    where: str,
    freq_at: Callable[[int], str],
    value_at: Callable[[int, int, int], str],
    reading: bool = True,
) -> None:
    """Check a sweep's frequencies and values; ``freq_at(k)`` / ``value_at(k, o, i)`` locate.

    Reading, every problem is a :class:`FileFormatError`; writing, a :class:`DimensionError`,
    :class:`FrequencyGridError` or :class:`NonFiniteDataError`.
    """
    shape_error = FileFormatError if reading else DimensionError
    grid_error = FileFormatError if reading else FrequencyGridError
    value_error = FileFormatError if reading else NonFiniteDataError
    if f.size == 0:
        raise shape_error(f"{where}: no frequency points")
    if resp.shape != (f.size, 2, 2):
        raise shape_error(f"{where}: response has shape {resp.shape}; expected ({f.size}, 2, 2)")
    with np.errstate(invalid="ignore"):
        invalid = ~np.isfinite(f) | (f <= 0)
        unordered = np.concatenate([[False], ~(np.diff(f) > 0)]) & ~invalid
    problems = np.flatnonzero(invalid | unordered)
    if problems.size:  # the first one in the file's order
        k = int(problems[0])
        if invalid[k]:
            raise grid_error(
                f"{freq_at(k)}: frequency {float(f[k])!r} Hz; frequencies must be positive, finite"
            )
        raise grid_error(
            f"{freq_at(k)}: frequency {float(f[k])!r} Hz after {float(f[k - 1])!r} Hz; "
            "frequencies must be strictly increasing (sort the points, drop duplicates)"
        )
    bad = np.argwhere(~np.isfinite(resp))
    if bad.size:
        k, o, i = (int(v) for v in bad[0])
        raise value_error(
            f"{value_at(k, o, i)}: {resp[k, o, i]} at {f[k]} Hz; every value must be finite "
            f"({len(bad)} non-finite in all)"
        )


def _suffix(path: Path) -> str:
    ext = path.suffix.lower()
    if ext not in SWEEP_FORMATS:
        raise FileFormatError(
            f"{path}: unknown response-file extension {path.suffix or '(none)'!r}; supported: "
            f"{', '.join(SWEEP_FORMATS)}"
        )
    return ext


def read_sweep(path: str | os.PathLike[str]) -> xr.DataArray:
    """Read one sweep (a 2x2 complex frequency response) from a response file.

    Parameters
    ----------
    path : path-like
        A ``.csv``, ``.s2p``, ``.mat`` or ``.nc`` file (see the module for the formats).

    Returns
    -------
    xarray.DataArray
        Complex, dims ``(frequency, output, input)``, shape (n, 2, 2); coordinates ``frequency``
        (Hz), ``output`` ["y1", "y2"], ``input`` ["u1", "u2"]; attributes ``units`` (the
        response's, ``""`` if the file does not say) and ``source`` (the path).

    Raises
    ------
    FileFormatError
        A missing file, an unknown extension (listing the supported ones), or a file not in its
        format, naming the file and the line or variable.
    """
    path = Path(path)
    ext = _suffix(path)
    if not path.is_file():
        raise FileFormatError(
            f"{path}: no such file" if not path.exists() else f"{path}: not a file"
        )
    reader = {".csv": _read_csv, ".s2p": _read_s2p, ".mat": _read_mat, ".nc": _read_nc}[ext]
    return reader(path)


def write_sweep(
    path: str | os.PathLike[str], response: xr.DataArray, response_units: str = ""
) -> Path:
    """Write one sweep to a response file, atomically; the format follows the extension.

    Parameters
    ----------
    path : path-like
        ``.csv`` (every float written in full, so reading it back is exact), ``.s2p`` (with
        scikit-rf, real/imaginary parts in Hz, also exact), ``.mat`` or ``.nc``.
    response : xarray.DataArray
        Dims ``(frequency, output, input)``, shape (n, 2, 2); channels are taken in order.
    response_units : str, optional
        Written with the data (default: none, unless ``response.attrs["units"]`` says).

    Returns
    -------
    pathlib.Path
        ``path``.
    """
    path = Path(path)
    ext = _suffix(path)
    if not isinstance(response, xr.DataArray) or set(response.dims) != {
        "frequency",
        "output",
        "input",
    }:
        dims = getattr(response, "dims", type(response).__name__)
        raise DimensionError(f"a sweep needs dims ('frequency', 'output', 'input'), got {dims}")
    response = response.transpose("frequency", "output", "input")
    f = np.asarray(response["frequency"].values, dtype=float)
    resp = np.asarray(response.values, dtype=complex)
    units = response_units or str(response.attrs.get("units", ""))

    def value_at(k: int, o: int, i: int) -> str:
        return f"cannot write {path}: response[{k}, {o}, {i}]"

    def freq_at(k: int) -> str:
        return f"cannot write {path}: frequency[{k}]"

    _check(f, resp, f"cannot write {path}", freq_at, value_at, reading=False)
    writer = {".csv": _csv_text, ".s2p": _s2p_text}.get(ext)
    if writer is not None:
        text = writer(f, resp, units)
        return atomic_write(path, lambda tmp: tmp.write_text(text, encoding="utf-8"))
    if ext == ".mat":
        return atomic_write(path, lambda tmp: _write_mat(tmp, f, resp, units))
    sweep = make_sweep(f, resp)
    sweep.attrs = {}
    ds = xr.Dataset({"response": sweep}, attrs={"response_units": units})
    return save_dataset(ds, path)


# ------------------------------------------------------------------------------------- CSV
def _csv_text(f: np.ndarray, resp: np.ndarray, units: str) -> str:
    lines = [f"# response_units: {units}"] if units else []
    lines.append(CSV_HEADER)
    flat = resp.reshape(f.size, 4)
    for k in range(f.size):
        parts = [repr(float(f[k]))]
        for z in flat[k]:
            parts += [repr(float(z.real)), repr(float(z.imag))]
        lines.append(",".join(parts))
    return "\n".join(lines) + "\n"


def _header_problem(fields: list[str]) -> str:
    """What is wrong with a CSV header (it is not :data:`CSV_HEADER`)."""
    if len(fields) == 1 and ";" in fields[0]:
        return "fields must be separated by commas, not semicolons"
    try:
        [float(x) for x in fields]
    except ValueError:
        pass
    else:
        return "no header line; the first line that is not a comment must be the header"
    if fields and not any(name.endswith("_im") for name in fields):
        return (
            "no imaginary-part columns (*_im): the file holds a real-valued response, but the "
            "response must be complex (real and imaginary part of each channel)"
        )
    unknown = [name for name in fields if name not in CSV_COLUMNS]
    if unknown:
        return f"unknown column {unknown[0]!r}"
    missing = [name for name in CSV_COLUMNS if name not in fields]
    if missing:
        return f"missing column(s) {', '.join(missing)}"
    return "the columns are not in the required order"


def _read_csv(path: Path) -> xr.DataArray:
    try:
        text = path.read_text(encoding="utf-8-sig")
    except UnicodeDecodeError as exc:
        raise FileFormatError(f"{path}: not a UTF-8 text file ({exc.reason})") from exc
    units: str | None = None
    header_line = 0
    rows: list[list[float]] = []
    lines: list[int] = []
    for number, line in enumerate(text.splitlines(), start=1):
        if line.lstrip().startswith("#"):
            match = _UNITS.match(line.lstrip()[1:])
            if match:
                value = match.group(1).strip()
                if units is not None and value != units:
                    raise FileFormatError(
                        f"{path}, line {number}: a second response_units ({value!r}) differs "
                        f"from the first ({units!r})"
                    )
                units = value
            continue
        if not line.strip():
            continue
        fields = [x.strip() for x in next(csv.reader([line]))]
        if not header_line:
            if tuple(fields) != CSV_COLUMNS:
                raise FileFormatError(
                    f"{path}, line {number}: {_header_problem(fields)}; the header must be "
                    f"exactly {CSV_HEADER}"
                )
            header_line = number
            continue
        if len(fields) != len(CSV_COLUMNS):
            raise FileFormatError(
                f"{path}, line {number}: {len(fields)} field(s); expected {len(CSV_COLUMNS)} "
                f"({CSV_HEADER})"
            )
        row = []
        for name, field in zip(CSV_COLUMNS, fields, strict=True):
            try:
                row.append(float(field))
            except ValueError:
                raise FileFormatError(
                    f"{path}, line {number}: {name} is {field!r}, not a number"
                ) from None
        rows.append(row)
        lines.append(number)
    if not header_line:
        raise FileFormatError(f"{path}: no header line; expected {CSV_HEADER}")
    if not rows:
        raise FileFormatError(f"{path}: no data rows after the header (line {header_line})")
    data = np.array(rows)
    f = data[:, 0]
    flat = np.empty((f.size, 4), dtype=complex)  # not re + 1j*im: nan*1j spoils the real part
    flat.real, flat.imag = data[:, 1::2], data[:, 2::2]
    resp = flat.reshape(-1, 2, 2)

    def value_at(k: int, o: int, i: int) -> str:
        part = "re" if not np.isfinite(resp[k, o, i].real) else "im"
        return f"{path}, line {lines[k]}: {OUTPUTS[o]}_{INPUTS[i]}_{part}"

    _check(f, resp, str(path), lambda k: f"{path}, line {lines[k]}", value_at)
    return make_sweep(f, resp, units or "", str(path))


# ------------------------------------------------------------------------- Touchstone (.s2p)
def _s2p_text(f: np.ndarray, resp: np.ndarray, units: str) -> str:
    import skrf  # type: ignore[import-untyped]

    comments = " sysid-toolkit response file: S_ij = y_i / u_j"
    if units:
        comments += f"\n response_units: {units}"
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        net = skrf.Network(frequency=skrf.Frequency.from_f(f, unit="Hz"), s=resp, comments=comments)
        text = net.write_touchstone("sweep", return_string=True, skrf_comment=False, form="ri")
    return str(text)


def _touchstone_records(text: str) -> list[int]:
    """The line on which each two-port record (9 numbers) starts; only to locate errors."""
    starts: list[int] = []
    count = 0
    for number, line in enumerate(text.splitlines(), start=1):
        body = line.split("!", 1)[0].strip()
        if not body or body.startswith("#"):
            continue
        if body.startswith("["):
            if body.lower().startswith(("[noise data]", "[end]")):
                break
            continue
        for _ in body.split():
            if count % 9 == 0:
                starts.append(number)
            count += 1
    return starts


def _read_s2p(path: Path) -> xr.DataArray:
    import skrf

    raw = path.read_bytes()
    try:
        text = raw.decode("utf-8")
    except UnicodeDecodeError:
        text = raw.decode("latin-1")
    option = next(
        (
            (n, line.strip())
            for n, line in enumerate(text.splitlines(), start=1)
            if line.lstrip().startswith("#")
        ),
        None,
    )
    if option is None:
        raise FileFormatError(f"{path}: no option line ('# Hz S RI R 50'): not a Touchstone file")
    buf = io.StringIO(text)
    buf.name = str(path.with_suffix(".s2p"))  # StringIO: read as Touchstone, never unpickled
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            net = skrf.Network(buf)
    except Exception as exc:  # scikit-rf's errors are ValueError, IndexError, ...
        raise FileFormatError(
            f"{path}: not a two-port Touchstone file (scikit-rf: {type(exc).__name__}: {exc})"
        ) from exc
    words = option[1].lstrip("#").upper().split()
    if any(p in words for p in ("Y", "Z", "G", "H")):
        raise FileFormatError(
            f"{path}, line {option[0]}: option line {option[1]!r} does not declare S "
            "parameters; a response file holds S_ij = y_i / u_j as S parameters ('# Hz S RI')"
        )
    starts = _touchstone_records(text)

    def at(k: int) -> str:
        return f"{path}, line {starts[k]}" if k < len(starts) else f"{path}, frequency point {k}"

    f = np.asarray(net.f, dtype=float)
    s = np.asarray(net.s)
    if s.ndim != 3 or s.shape[1:] != (2, 2):
        raise FileFormatError(f"{path}: {s.shape[1:]} ports; a response file is a two-port")
    if getattr(net, "noisy", False):
        raise FileFormatError(
            f"{at(f.size)}: the frequency decreases there, so Touchstone reads the rest as noise "
            "parameters; frequencies must be strictly increasing"
        )
    units = None
    for line in text.splitlines():  # a comment anywhere, before or after the option line
        match = _UNITS.match(line.lstrip()[1:]) if line.lstrip().startswith("!") else None
        if match:
            units = match.group(1).strip()
    _check(f, s, str(path), at, lambda k, o, i: f"{at(k)}: S{o + 1}{i + 1}")
    return make_sweep(f, s, units or "", str(path))


# -------------------------------------------------------------------------------- MATLAB .mat
def _write_mat(tmp: Path, f: np.ndarray, resp: np.ndarray, units: str) -> None:
    from scipy.io import savemat

    variables: dict[str, Any] = {"frequency_hz": f, "response": resp}
    if units:
        variables["response_units"] = units
    savemat(str(tmp), variables, appendmat=False, oned_as="column")


def _read_mat(path: Path) -> xr.DataArray:
    from scipy.io import loadmat

    try:
        mat = loadmat(path, squeeze_me=False)
    except NotImplementedError as exc:  # MATLAB v7.3 (HDF5)
        raise FileFormatError(
            f"{path}: a MATLAB v7.3 (HDF5) file; save it with save(..., '-v7') ({exc})"
        ) from exc
    except Exception as exc:  # scipy raises ValueError, TypeError, MatReadError, ...
        raise FileFormatError(f"{path}: not a MATLAB .mat file ({exc})") from exc
    found = sorted(k for k in mat if not k.startswith("__"))
    for name in ("frequency_hz", "response"):
        if name not in mat:
            raise FileFormatError(
                f"{path}: no variable {name!r} (found: {', '.join(found) or 'none'}); expected "
                "frequency_hz (n,) and response (n, 2, 2) complex"
            )
    f = np.asarray(mat["frequency_hz"])
    if f.ndim == 2 and 1 in f.shape:
        f = f.ravel()
    if f.ndim != 1 or f.dtype.kind not in "iuf":
        raise FileFormatError(
            f"{path}, variable 'frequency_hz': {f.dtype} of shape {f.shape}; expected a real "
            "vector (n,) in Hz"
        )
    r = np.asarray(mat["response"])
    n = f.size
    if r.dtype.kind not in "iufc":
        raise FileFormatError(f"{path}, variable 'response': {r.dtype}, not numbers")
    if r.shape != (n, 2, 2):
        hint = ""
        if r.shape == (2, 2, n):
            hint = " (MATLAB's freqresp layout: use permute(H, [3 1 2]))"
        raise FileFormatError(
            f"{path}, variable 'response': shape {r.shape}; expected ({n}, 2, 2) "
            f"(frequency, output, input) with n = numel(frequency_hz) = {n}{hint}"
        )
    if r.dtype.kind != "c":
        raise FileFormatError(
            f"{path}, variable 'response': real values ({r.dtype}), no imaginary part; the "
            "response must be complex"
        )
    units = ""
    if "response_units" in mat:
        u = np.asarray(mat["response_units"])
        if u.dtype.kind != "U" or u.size > 1:
            raise FileFormatError(
                f"{path}, variable 'response_units': {u.dtype} of shape {u.shape}; expected a "
                "character string such as 'V/V'"
            )
        units = str(u.item()).strip() if u.size else ""

    def freq_at(k: int) -> str:
        return f"{path}, variable 'frequency_hz'[{k}]"

    def value_at(k: int, o: int, i: int) -> str:
        return f"{path}, variable 'response'[{k}, {o}, {i}]"

    _check(f.astype(float), r.astype(complex), str(path), freq_at, value_at)
    return make_sweep(f, r, units, str(path))


# -------------------------------------------------------------------------------------- netCDF
def _read_nc(path: Path) -> xr.DataArray:
    try:
        ds = load_dataset(path)
    except DataError as exc:
        raise FileFormatError(str(exc)) from exc
    names = [str(v) for v in ds.data_vars if str(v) != "measured"]
    name = "response" if "response" in names else (names[0] if len(names) == 1 else None)
    if name is None:
        raise FileFormatError(
            f"{path}: no variable 'response' and not a single variable (found: "
            f"{', '.join(names) or 'none'})"
        )
    da = ds[name]
    where = f"{path}, variable {name!r}"
    if "experiment" in da.dims:
        if da.sizes["experiment"] != 1:
            raise FileFormatError(
                f"{where}: {da.sizes['experiment']} experiments; a response file holds one "
                "(use a manifest, or sysid export, for several)"
            )
        keep = measured_mask(ds)[0]
        da = da.isel(experiment=0, frequency=np.flatnonzero(keep))
    if set(da.dims) != {"frequency", "output", "input"}:
        raise FileFormatError(f"{where}: dims {da.dims}; expected (frequency, output, input)")
    da = da.transpose("frequency", "output", "input")
    for dim, labels in (("output", OUTPUTS), ("input", INPUTS)):
        if da.sizes[dim] != 2:
            raise FileFormatError(f"{where}: {da.sizes[dim]} {dim}s; a response file is 2x2")
        if dim in da.coords and {str(v) for v in da[dim].values} == set(labels):
            da = da.sel({dim: list(labels)})
    if not np.iscomplexobj(da.values):
        raise FileFormatError(
            f"{where}: real values ({da.dtype}), no imaginary part; the response must be complex"
        )
    if "frequency" not in da.coords:
        raise FileFormatError(f"{where}: no 'frequency' coordinate (Hz)")
    f = np.asarray(da["frequency"].values, dtype=float)
    resp = np.asarray(da.values, dtype=complex)

    def value_at(k: int, o: int, i: int) -> str:
        return f"{where}[{k}, {o}, {i}]"

    _check(f, resp, where, lambda k: f"{path}, variable 'frequency'[{k}]", value_at)
    units = str(da.attrs.get("units", ds.attrs.get("response_units", "")))
    return make_sweep(f, resp, units, str(path))
