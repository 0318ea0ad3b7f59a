"""Response files in Touchstone ``.s2p``, with scikit-rf (:mod:`sysid_core.formats.sweepfiles`)."""

from __future__ import annotations

import io
import warnings
from pathlib import Path

import numpy as np
import xarray as xr

from sysid_core.data.sweep import (
    UNITS_LINE,
    check_sweep,
    make_sweep,
)
from sysid_core.errors import (
    FileFormatError,
)
from sysid_core.formats.textfile import read_text

__all__ = ["read_s2p", "s2p_text"]


# ------------------------------------------------------------------------- Touchstone (.s2p)
def s2p_text(f: np.ndarray, resp: np.ndarray, units: str) -> str:
    """The Touchstone ``.s2p`` file of a sweep (real/imaginary parts, Hz; units in a comment)."""
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


def read_s2p(path: Path) -> xr.DataArray:
    """The sweep in the Touchstone ``.s2p`` file at ``path``, checked (errors name the line)."""
    import skrf

    text = read_text(path)
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
        match = UNITS_LINE.match(line.lstrip()[1:]) if line.lstrip().startswith("!") else None
        if match:
            units = match.group(1).strip()
    check_sweep(f, s, str(path), at, lambda k, o, i: f"{at(k)}: S{o + 1}{i + 1}")
    return make_sweep(f, s, units or "", str(path))
