"""MATLAB v7.3 ``.mat`` files: HDF5 behind a 512-byte MATLAB header, read with h5py.

MATLAB (``save(..., '-v7.3')``) writes the text header ``MATLAB 7.3 MAT-file, ...`` (116 bytes,
then the subsystem offset, the version ``0x0200`` and the endian mark ``IM``) in the file's first
512 bytes, HDF5 after it. Each variable is a dataset at the root:

* its dimensions reversed (MATLAB is column-major: an ``n x 2 x 2`` array is a dataset of shape
  ``(2, 2, n)``, a column vector ``n x 1`` one of shape ``(1, n)``);
* an attribute ``MATLAB_class``: ``double``, ``single``, ``int8`` ... ``uint64``, ``logical``,
  ``char`` (UTF-16 code units), or ``struct``, ``cell``, ... (not numeric arrays);
* complex values as a compound type with fields ``real`` and ``imag``;
* an empty array as a dataset holding its dimensions, with an attribute ``MATLAB_empty``.

:func:`load_mat73` gives the variables as ``scipy.io.loadmat(..., squeeze_me=False)`` gives a
v4-v7 file's (numeric arrays of at least two dimensions in MATLAB's order, a character array as
an array of strings, one per row), so that :mod:`sysid_core.formats.matsweep` checks both alike.
"""

from __future__ import annotations

from collections.abc import Collection
from pathlib import Path
from typing import Any

import numpy as np

from sysid_core.errors import FileFormatError

__all__ = ["is_mat73", "load_mat73"]


def _head(path: Path, size: int = 128) -> bytes:
    with open(path, "rb") as fh:
        return fh.read(size)


def is_mat73(path: Path) -> bool:
    """Whether the file starts with MATLAB's v7.3 header (text, version 0x0200)."""
    head = _head(path)
    return head.startswith(b"MATLAB 7.3 MAT-file") or (
        head.startswith(b"MATLAB") and head[124:128] in (b"\x00\x02IM", b"\x02\x00MI")
    )


def load_mat73(path: Path, wanted: Collection[str]) -> dict[str, Any]:
    """The variables of a MATLAB v7.3 file: those in ``wanted`` read, the others ``None``.

    Raises
    ------
    FileFormatError
        No HDF5 behind the header, or a wanted variable that is not a numeric or character
        array (a struct, cell array, sparse matrix or object), naming the file and variable.
    """
    import h5py  # type: ignore[import-untyped]

    if not h5py.is_hdf5(path):
        raise FileFormatError(
            f"{path}: MATLAB's v7.3 header but no HDF5 data after it: the file is damaged or "
            "truncated"
        )
    try:
        with h5py.File(path, "r") as fh:
            return {
                name: _variable(fh[name], path, name) if name in wanted else None
                for name in fh
                if not name.startswith("#")  # #refs#, #subsystem#: MATLAB's own
            }
    except OSError as exc:
        raise FileFormatError(
            f"{path}: a MATLAB v7.3 file that HDF5 cannot read, damaged or truncated ({exc})"
        ) from exc


def _matlab_class(obj: Any) -> str:
    value = obj.attrs.get("MATLAB_class", b"")
    return value.decode("ascii", "replace") if isinstance(value, bytes) else str(value)


def _variable(obj: Any, path: Path, name: str) -> np.ndarray:
    """One variable as scipy's ``loadmat`` would give it (see the module)."""
    import h5py

    cls = _matlab_class(obj)
    if isinstance(obj, h5py.Group) or cls in ("struct", "cell", "function_handle"):
        kind = "sparse matrix" if obj.attrs.get("MATLAB_sparse") is not None else cls or "group"
        raise FileFormatError(
            f"{path}, variable {name!r}: a MATLAB {kind}, not a numeric or character array"
        )
    if obj.attrs.get("MATLAB_empty"):
        dims = tuple(int(d) for d in np.ravel(obj[()]))
        return np.array([], dtype="<U1") if cls == "char" else np.zeros(dims)
    data = np.asarray(obj[()])
    if data.dtype.kind == "O":  # object references: a cell array written another way
        raise FileFormatError(f"{path}, variable {name!r}: object references, not numbers")
    if cls == "char":
        return _strings(data.T)
    if data.dtype.names is not None:
        return _complex(data, path, name).T
    return (data.astype(bool) if cls == "logical" else data).T


def _complex(data: np.ndarray, path: Path, name: str) -> np.ndarray:
    """A compound ``(real, imag)`` array as complex numbers."""
    fields = data.dtype.names or ()
    pair = next((p for p in (("real", "imag"), ("r", "i")) if set(p) <= set(fields)), None)
    if pair is None:
        raise FileFormatError(
            f"{path}, variable {name!r}: a compound type with fields {', '.join(fields)}; "
            "complex values have fields real and imag"
        )
    out = np.empty(data.shape, dtype=complex)  # not re + 1j*im: nan*1j spoils the real part
    out.real, out.imag = data[pair[0]], data[pair[1]]
    return out


def _strings(codes: np.ndarray) -> np.ndarray:
    """A character array (rows of UTF-16 code units) as one string per row."""
    rows = np.atleast_2d(codes).astype("<u2")
    return np.array([row.tobytes().decode("utf-16-le", "replace") for row in rows])
