"""``faulty-gyro``: the simulated cloverleaf, with one fault injected on chosen measurements.

Options (the ``[device]`` table), besides the cloverleaf's (``noise``, ``seed``, ...):

``fault``
    What goes wrong, one of :data:`FAULTS`: ``"none"``; ``"raise"`` (an exception);
    ``"hang"`` (sleeps ``hang_s``); ``"slow"`` (sleeps ``hang_s`` then answers); ``"real"``,
    ``"zero"``, ``"nan"``, ``"frequencies"`` (other frequencies than requested), ``"shape"``,
    ``"labels"`` (other channel labels than before), ``"type"`` (a numpy array, not a
    DataArray).
``on_call``
    The first ``measure`` call (1-based) with the fault; later calls too if ``repeat``.
``once_file``
    If given, the fault happens once across processes: the file is created when it does, and
    no fault happens while it exists (so a resumed run gets a good answer).
``warp``
    Bias-law deviation: the electrodes act as if the bias were ``dv + warp * dv**2`` (volts),
    so a model identified near 0 V mispredicts far from it (modes move far from the
    prediction). ``true_modal_frequencies_hz`` includes it.
``broken``
    Break a protocol attribute: ``"electrodes"`` (none), ``"limits"`` (strings).
"""

from __future__ import annotations

import time
from pathlib import Path
from typing import Any, ClassVar

import numpy as np
from sysid_cloverleaf import CloverleafGyro

FAULTS = (
    "none",
    "raise",
    "hang",
    "slow",
    "real",
    "zero",
    "nan",
    "frequencies",
    "shape",
    "labels",
    "type",
)


class FaultyGyro(CloverleafGyro):
    """The cloverleaf with an injected fault (see the module docstring)."""

    name: ClassVar[str] = "faulty-gyro"
    description: ClassVar[str] = "Test device: the cloverleaf with injectable faults"

    def __init__(
        self,
        fault: str = "none",
        on_call: int = 1,
        repeat: bool = False,
        hang_s: float = 3600.0,
        once_file: str | None = None,
        warp: float = 0.0,
        broken: str | None = None,
        **options: Any,
    ) -> None:
        if fault not in FAULTS:
            raise ValueError(f"fault must be one of {FAULTS}, got {fault!r}")
        self.fault, self.on_call, self.repeat = fault, int(on_call), bool(repeat)
        self.hang_s = float(hang_s)
        self.once_file = Path(once_file) if once_file else None
        self.warp = float(warp)
        self.calls = 0
        super().__init__(**options)
        if broken == "electrodes":
            self.electrodes = ()
        elif broken == "limits":
            self.bias_limits = ("-10", "10")  # type: ignore[assignment]

    def _effective(self, bias: Any) -> np.ndarray:
        b = np.asarray(bias, dtype=float)
        return b + self.warp * b**2

    def applied_bias(self, bias: Any) -> np.ndarray:
        return super().applied_bias(np.clip(self._effective(bias), *self.bias_limits))

    def _faulty_now(self) -> bool:
        hit = self.calls == self.on_call or (self.repeat and self.calls > self.on_call)
        if not hit or self.fault == "none":
            return False
        if self.once_file is not None:
            if self.once_file.exists():
                return False
            self.once_file.write_text("fired\n")
        return True

    def measure(self, bias: Any, frequencies_hz: np.ndarray) -> Any:
        self.calls += 1
        if not self._faulty_now():
            return super().measure(bias, frequencies_hz)
        f = np.asarray(frequencies_hz, dtype=float)
        if self.fault == "raise":
            raise RuntimeError("lost the connection to the analyzer")
        if self.fault in ("hang", "slow"):
            time.sleep(self.hang_s)
            return super().measure(bias, frequencies_hz)
        good = super().measure(bias, frequencies_hz)
        if self.fault == "real":
            return good.real
        if self.fault == "zero":
            return good * 0
        if self.fault == "nan":
            bad = good.copy()
            bad[len(f) // 2] = np.nan
            return bad
        if self.fault == "frequencies":
            return good.assign_coords(frequency=f + 0.5)
        if self.fault == "shape":
            return good.isel(frequency=slice(0, len(f) // 2))
        if self.fault == "labels":
            return good.assign_coords(output=["a", "b"])
        if self.fault == "type":
            return np.asarray(good.values)
        raise AssertionError(self.fault)  # pragma: no cover

    def __repr__(self) -> str:
        return f"FaultyGyro(fault={self.fault!r}, on_call={self.on_call})"
