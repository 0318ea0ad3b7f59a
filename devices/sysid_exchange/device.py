"""The ``exchange`` device: measurements requested and answered through files in a folder.

For measurement ``k`` (1, 2, ...) the device writes, atomically, ``request-000k.json``::

    {"id": k, "electrodes": [...], "bias_v": [...], "frequencies_hz": [...]}

(the frequencies increasing, as a sweep file holds them, whatever order the run asked for: the
answer's time stamps, if it has any, say when each point was measured)

and waits for the answer: ``response-000k.<csv|s2p|mat|nc>`` (one sweep at that bias, in one of
the formats of :mod:`sysid_core.formats.sweepfiles`; the answering side writes it under another name
and renames it, so that it appears complete) or ``error-000k.txt`` (its text becomes the run's
device error). An answer that is not a valid measurement (not complex, other frequencies,
non-finite, a file that cannot be read) is moved to ``rejected/`` with the reason and the device
keeps waiting: the answer may be written again.

A request for the same bias and frequencies as an earlier one in the folder reuses that
request's number and its answer if one is there (and says so), so a run resumed with
``--resume`` neither asks twice nor loses an answer that arrived after it stopped. Give each
new run its own exchange folder: answers in it are measurements of the gyro as it was then.
``wait_s`` limits the wait per answer (none: until the answer comes or Ctrl-C). The bias is
checked against ``bias_limits`` before a request is written.
"""

from __future__ import annotations

import json
import re
import shutil
import time
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import Annotated, Any, ClassVar

import numpy as np
import xarray as xr
from annotated_types import Gt

from sysid_core.data.io import write_json
from sysid_core.device.measuring import check_answer
from sysid_core.errors import BiasLimitError, ConfigError, DataError, DeviceError
from sysid_core.formats.engine import sweep_extensions
from sysid_core.formats.sweepfiles import read_sweep

__all__ = ["ExchangeDevice"]

_REQUEST = re.compile(r"request-(\d{4,})\.json")


class ExchangeDevice:
    """A device whose measurements are answered through files in ``dir``.

    Parameters
    ----------
    dir : str
        The exchange folder (created if missing), relative to the current directory or
        absolute.
    electrodes : list of str
        The bias electrodes' names.
    bias_limits : [low, high]
        Allowed bias δv (volts) on every electrode.
    structure_potential : float
        ``v_gyro`` (volts).
    band_hz : [low, high]
        The band where the two modes are (Hz).
    wait_s : float, optional
        Longest wait for one answer (seconds); none by default (until it comes or Ctrl-C).
    poll_s : float
        How often the folder is looked at (seconds, default 0.2).
    """

    name: ClassVar[str] = "exchange"
    description: ClassVar[str] = "A gyro measured through request/response files (any lab setup)"

    def __init__(
        self,
        *,
        dir: str,
        electrodes: list[str],
        bias_limits: list[float],
        structure_potential: float,
        band_hz: list[float],
        wait_s: Annotated[float, Gt(0)] | None = None,
        poll_s: Annotated[float, Gt(0)] = 0.2,
    ) -> None:
        if len(bias_limits) != 2 or len(band_hz) != 2:
            raise ConfigError(
                "device 'exchange': bias_limits and band_hz must be [low, high] each, got "
                f"{bias_limits!r} and {band_hz!r}"
            )
        self.dir = Path(dir)
        self.electrodes: tuple[str, ...] = tuple(str(e) for e in electrodes)
        self.bias_limits: tuple[float, float] = (float(bias_limits[0]), float(bias_limits[1]))
        self.structure_potential = float(structure_potential)
        self.band_hz: tuple[float, float] = (float(band_hz[0]), float(band_hz[1]))
        self.wait_s = None if wait_s is None else float(wait_s)
        self.poll_s = float(poll_s)
        self._say: Callable[[str], None] = lambda _m: None

    def set_progress(self, say: Callable[[str], None]) -> None:
        """Receive the run's progress callback (the requests say what to measure)."""
        self._say = say

    # ------------------------------------------------------------------ requests
    def _requests(self) -> list[tuple[int, dict[str, Any]]]:
        found = []
        for path in self.dir.glob("request-*.json"):
            m = _REQUEST.fullmatch(path.name)
            if not m:
                continue
            try:
                found.append((int(m.group(1)), json.loads(path.read_text())))
            except (OSError, ValueError):
                continue
        return sorted(found, key=lambda item: item[0])

    def _request(self, bias: np.ndarray, f: np.ndarray) -> tuple[int, bool]:
        """The number of the request for this measurement, and whether it was written before."""
        self.dir.mkdir(parents=True, exist_ok=True)
        requests = self._requests()
        for k, req in reversed(requests):
            try:
                same = (
                    list(req["electrodes"]) == list(self.electrodes)
                    and np.allclose(req["bias_v"], bias, rtol=0, atol=1e-12)
                    and len(req["frequencies_hz"]) == f.size
                    and np.allclose(req["frequencies_hz"], f, rtol=0, atol=1e-9)
                )
            except (KeyError, TypeError, ValueError):
                continue
            if same:
                return k, True
        k = 1 + max((k for k, _ in requests), default=0)
        write_json(
            self.dir / f"request-{k:04d}.json",
            {
                "id": k,
                "electrodes": list(self.electrodes),
                "bias_v": [float(b) for b in bias],
                "frequencies_hz": [float(x) for x in f],
            },
        )
        return k, False

    # ------------------------------------------------------------------ the protocol
    def check_bias(self, bias: Sequence[float]) -> np.ndarray:
        """``bias`` as floats, or :class:`BiasLimitError` before anything is requested."""
        b = np.asarray(bias, dtype=float)
        low, high = self.bias_limits
        if b.shape != (len(self.electrodes),) or not np.all(np.isfinite(b)):
            raise BiasLimitError(
                f"exchange: refusing bias {list(bias)}: need one finite value per electrode "
                f"{list(self.electrodes)}"
            )
        if np.any((b < low) | (b > high)):
            raise BiasLimitError(
                f"exchange: refusing bias {b.tolist()} V: outside the limits [{low}, {high}] V"
            )
        return b

    def measure(self, bias: Sequence[float], frequencies_hz: np.ndarray) -> xr.DataArray:
        """Request the measurement and wait for its answer (see the module docstring)."""
        b = self.check_bias(bias)
        asked = np.asarray(frequencies_hz, dtype=float)
        order = np.argsort(asked, kind="stable")
        f = asked[order]  # a request (and a sweep file) lists its frequencies increasing
        k, earlier = self._request(b, f)
        stem = f"{k:04d}"
        extensions = sweep_extensions()
        others = ", ".join(ext for ext in extensions[1:])
        names = f"response-{stem}{extensions[0]} (or {others})"
        setting = ", ".join(f"{e} = {v:.6g} V" for e, v in zip(self.electrodes, b, strict=True))
        self._say(
            f"exchange: request-{stem}.json: set {setting}, measure {f[0]:.6g}-{f[-1]:.6g} Hz "
            f"({f.size} points); write {names} in {self.dir} (error-{stem}.txt if it failed)"
        )
        t0 = time.monotonic()
        rejected: list[str] = []  # why answers to this request were refused, for the error
        while True:
            error = self.dir / f"error-{stem}.txt"
            if error.exists():
                text = " ".join(error.read_text(errors="replace").split())
                raise DeviceError(
                    f"exchange: the answer to request-{stem}.json is an error: {text}"
                )
            for ext in extensions:
                path = self.dir / f"response-{stem}{ext}"
                if path.exists():
                    answer = self._read(path, f, rejected)
                    if answer is not None:
                        if earlier:
                            self._say(
                                f"exchange: {path.name} answers an identical earlier request: "
                                "reused (use a new exchange folder for a new run)"
                            )
                        return answer.isel(frequency=np.argsort(order))  # in the order asked
            if self.wait_s is not None and time.monotonic() - t0 > self.wait_s:
                why = f" (the last answer was rejected: {rejected[-1]})" if rejected else ""
                raise DeviceError(
                    f"exchange: no answer to request-{stem}.json in {self.dir} within "
                    f"{self.wait_s:g} s{why}; write {names}, then run again with --resume"
                )
            time.sleep(self.poll_s)

    def _read(
        self, path: Path, f: np.ndarray, rejected: list[str] | None = None
    ) -> xr.DataArray | None:
        """The answer in ``path``, or None after moving a bad one to ``rejected/``.

        The reason of a refusal is appended to ``rejected``, kept beside the file and said.
        """
        try:
            answer = read_sweep(path)
            check_answer(answer, f)
        except (DataError, DeviceError) as exc:
            folder = self.dir / "rejected"
            folder.mkdir(exist_ok=True)
            n = 1 + sum(1 for _ in folder.glob(f"{path.name}.*.txt"))
            shutil.move(str(path), folder / f"{path.name}.{n}")
            (folder / f"{path.name}.{n}.txt").write_text(f"{exc}\n")
            if rejected is not None:
                rejected.append(f"{exc}; kept as rejected/{path.name}.{n}")
            self._say(f"exchange: {path.name} rejected ({exc}); moved to rejected/, write it again")
            return None
        return answer

    def __repr__(self) -> str:
        return f"ExchangeDevice(dir={str(self.dir)!r}, electrodes={list(self.electrodes)})"
