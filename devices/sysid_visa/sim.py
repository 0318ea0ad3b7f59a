"""``sysid instrument-sim``: a simulated analyzer and bias source on 127.0.0.1 (SCPI over TCP).

They speak the shipped profiles (``keysight-ena``, ``keysight-ena-1rx`` and
``keysight-n6700``) and are backed by any installed simulated device: the analyzer answers with
that device's response at the voltages the source currently outputs (on the channels whose
output is on; 0 V otherwise). Channel ``k`` (1, 2, ...) is the device's ``k``-th electrode. The
source quantises what it is told as the device's DAC would (its ``applied_bias``) and reads
that back.

The analyzer has traces as an ENA does: ``:CALC1:PAR:COUN n`` makes ``n`` of them (1 at
start), ``:CALC1:PAR{k}:DEF Sxy`` sets trace ``k``'s parameter (S31, S32, S41, S42),
``:CALC1:PAR{k}:SEL`` makes it the active trace, whose data ``:CALC1:DATA:SDAT?`` reads. One
``:TRIG:SING`` sweeps every trace (:attr:`InstrumentSim.triggers` counts them). One measurement
of the device is made per (bias, frequency list) and every trace is served from it, so a run
through the instruments sees the same data as the built-in device with the same seed, however
many sweeps it takes. ``tones`` makes the analyzer a lock-in with that many demodulators: each
acquisition measures that many consecutive frequencies of the list (the backing device should
measure with the same ``[device.bench] tones``, as ``sysid instrument-sim --tones`` builds
it). ``dwell_ms`` makes each acquisition take that long (one frequency point each, or
``tones`` of them).

A line that is not a known command queues ``-113,"Undefined header"`` for ``SYST:ERR?``;
queries answer one line. Faults for tests: ``readback_error`` adds volts to what one channel
reads back.
"""

from __future__ import annotations

import re
import socketserver
import threading
import time
from collections.abc import Callable
from typing import Any

import numpy as np

from sysid_core.errors import ConfigError

__all__ = ["InstrumentSim"]

_PAIRS = {"S31": (0, 0), "S32": (0, 1), "S41": (1, 0), "S42": (1, 1)}
#: The most traces of the channel (as an ENA's channel).
_MAX_TRACES = 16
_NUMBER = r"([-+]?(?:\d+\.?\d*|\.\d+)(?:[eE][-+]?\d+)?)"


class _Line(socketserver.StreamRequestHandler):
    def handle(self) -> None:
        answer: Callable[[str], str | None] = self.server.answer  # type: ignore[attr-defined]
        for raw in self.rfile:
            line = raw.decode("ascii", "replace").strip()
            if not line:
                continue
            reply = answer(line)
            if reply is not None:
                self.wfile.write((reply + "\n").encode("ascii"))
                self.wfile.flush()


class _Server(socketserver.ThreadingTCPServer):
    daemon_threads = True
    allow_reuse_address = True

    def __init__(self, port: int, answer: Callable[[str], str | None]) -> None:
        self.answer = answer
        super().__init__(("127.0.0.1", port), _Line)


class InstrumentSim:
    """The simulated instrument pair.

    Parameters
    ----------
    device : simulated device
        Any installed device object (``measure``, ``electrodes``; ``applied_bias`` optional).
    analyzer_port, source_port : int
        TCP ports on 127.0.0.1 (0: any free port; see :attr:`ports`).
    dwell_ms : float
        Time per acquisition of each sweep (milliseconds): per frequency point, or per
        ``tones`` of them.
    readback_error : (channel, volts), optional
        A fault: that channel reads back this much more than it outputs.
    tones : int, optional
        Frequencies per acquisition (a lock-in's demodulators); default: the device's
        ``tones`` (1 without).

    Attributes
    ----------
    triggers : int
        Analyzer sweeps triggered (``:TRIG:SING`` with a frequency list loaded).
    acquisitions : int
        Acquisitions of those sweeps (``ceil(points / tones)`` each).
    sweeps : int
        Measurements of the backing device (one per new bias or frequency list).
    """

    def __init__(
        self,
        device: Any,
        analyzer_port: int = 0,
        source_port: int = 0,
        dwell_ms: float = 0.0,
        readback_error: tuple[int, float] | None = None,
        tones: int | None = None,
    ) -> None:
        self.device = device
        self.n = len(device.electrodes)
        self.volts = np.zeros(self.n)
        self.on = np.zeros(self.n, dtype=bool)
        self.dwell_s = dwell_ms / 1000.0
        self.readback_error = readback_error
        self.lock = threading.Lock()
        self.errors: dict[str, list[str]] = {"analyzer": [], "source": []}
        self.tones = int(getattr(device, "tones", 1) if tones is None else tones)
        if self.tones < 1:
            raise ConfigError(f"instrument-sim: tones must be an integer >= 1, got {self.tones}")
        self.freqs: np.ndarray | None = None
        #: Each trace's parameter (trace 1, 2, ...), the active trace, each trace's last data.
        self.parameters = ["S31"]
        self.active = 1
        self.data: list[np.ndarray | None] = [None]
        self.cache: dict[bytes, np.ndarray] = {}
        self.sweeps = 0
        self.triggers = 0
        self.acquisitions = 0
        self.analyzer = _Server(analyzer_port, self._analyzer)
        self.source = _Server(source_port, self._source)
        self.ports = (self.analyzer.server_address[1], self.source.server_address[1])
        self._threads: list[threading.Thread] = []

    # ------------------------------------------------------------------ running
    def start(self) -> InstrumentSim:
        """Serve both instruments in background threads; return self."""
        for server in (self.analyzer, self.source):
            t = threading.Thread(target=server.serve_forever, daemon=True)
            t.start()
            self._threads.append(t)
        return self

    def stop(self) -> None:
        """Stop serving and close the ports."""
        for server in (self.analyzer, self.source):
            server.shutdown()
            server.server_close()

    # ------------------------------------------------------------------ common
    def _common(self, who: str, line: str) -> str | None:
        if line == "*IDN?":
            if who == "source":
                name = "sysid-sim,N6700-like"
            elif self.tones == 1:
                name = "sysid-sim,ENA-like analyzer"
            else:
                name = f"sysid-sim,lock-in-like analyzer ({self.tones} tones)"
            return f"{name},0,1.0"
        if line == "*CLS":
            self.errors[who].clear()
            return None
        if line.upper() == "SYST:ERR?":
            return self.errors[who].pop(0) if self.errors[who] else '+0,"No error"'
        if line == "*OPC?":
            return "1"
        self.errors[who].append('-113,"Undefined header"')
        return "0" if line.endswith("?") else None

    def _bias(self) -> np.ndarray:
        return np.where(self.on, self.volts, 0.0)

    # ------------------------------------------------------------------ the source
    def _applied(self, volts: np.ndarray) -> np.ndarray:
        method = getattr(self.device, "applied_bias", None)
        if callable(method):
            return np.asarray(method(volts), dtype=float)
        return volts

    def _channel(self, text: str) -> int | None:
        """Index of channel ``text`` (1-based), or None with ``-222`` queued if out of range."""
        ch = int(text)
        if 1 <= ch <= self.n:
            return ch - 1
        self.errors["source"].append('-222,"Data out of range"')
        return None

    def _source(self, line: str) -> str | None:
        with self.lock:
            if m := re.fullmatch(rf"VOLT\s+{_NUMBER}\s*,\s*\(@(\d+)\)", line, re.IGNORECASE):
                if (p := self._channel(m.group(2))) is not None:
                    target = self.volts.copy()
                    target[p] = float(m.group(1))
                    self.volts[p] = self._applied(target)[p]
                return None
            if m := re.fullmatch(r"MEAS:VOLT\?\s*\(@(\d+)\)", line, re.IGNORECASE):
                if (p := self._channel(m.group(1))) is None:
                    return "0"
                value = self.volts[p] if self.on[p] else 0.0
                if self.readback_error is not None and self.readback_error[0] == p + 1:
                    value += self.readback_error[1]
                return f"{value:+.6E}"
            if m := re.fullmatch(r"OUTP\s+(ON|OFF|1|0)\s*,\s*\(@(\d+)\)", line, re.IGNORECASE):
                if (p := self._channel(m.group(2))) is not None:
                    self.on[p] = m.group(1).upper() in ("ON", "1")
                return None
            if m := re.fullmatch(r"OUTP\?\s*\(@(\d+)\)", line, re.IGNORECASE):
                p = self._channel(m.group(1))
                return "1" if p is not None and self.on[p] else "0"
            return self._common("source", line)

    # ------------------------------------------------------------------ the analyzer
    def _trace(self, text: str) -> int | None:
        """Index of trace ``text`` (1-based; empty: 1), or None with ``-114`` queued."""
        k = int(text) if text else 1
        if 1 <= k <= len(self.parameters):
            return k - 1
        self.errors["analyzer"].append('-114,"Header suffix out of range"')
        return None

    def _analyzer(self, line: str) -> str | None:
        upper = line.upper()
        if upper.startswith(":SENS1:SEGM:DATA "):
            self._segments(line.split(None, 1)[1])
            return None
        if m := re.fullmatch(r":CALC1:PAR:COUN\s+(\d+)", line, re.IGNORECASE):
            n = int(m.group(1))
            if not 1 <= n <= _MAX_TRACES:
                self.errors["analyzer"].append('-222,"Data out of range"')
                return None
            kept = min(n, len(self.parameters))
            self.parameters = self.parameters[:kept] + ["S31"] * (n - kept)
            self.data = self.data[:kept] + [None] * (n - kept)
            if self.active > n:
                self.active = 1
            return None
        if m := re.fullmatch(r":CALC1:PAR(\d*):DEF\s+(\S+)", line, re.IGNORECASE):
            if (k := self._trace(m.group(1))) is None:
                return None
            if m.group(2).upper() not in _PAIRS:
                self.errors["analyzer"].append('-224,"Illegal parameter value"')
            else:
                self.parameters[k] = m.group(2).upper()
                self.data[k] = None
            return None
        if m := re.fullmatch(r":CALC1:PAR(\d*):SEL", line, re.IGNORECASE):
            if (k := self._trace(m.group(1))) is not None:
                self.active = k + 1
            return None
        if upper == ":TRIG:SING":
            self._sweep()
            return None
        if upper == ":CALC1:DATA:SDAT?":
            data = self.data[self.active - 1]
            if data is None:
                self.errors["analyzer"].append('-230,"Data corrupt or stale"')
                return "0"
            values = np.column_stack([data.real, data.imag]).ravel()
            return ",".join(f"{v:.12E}" for v in values)
        if re.fullmatch(r":SENS1:BAND\s+" + _NUMBER, line, re.IGNORECASE) or upper in (
            ":SENS1:SWE:TYPE SEGM",
            ":TRIG:SOUR BUS",
            ":INIT1:CONT ON",
        ):
            return None
        return self._common("analyzer", line)

    def _segments(self, text: str) -> None:
        try:
            v = [float(x) for x in text.split(",")]
            flags, count = v[1:6], int(v[6])
            width = 3 + int(sum(flags[1:5]))
            rows = np.array(v[7 : 7 + width * count]).reshape(count, width)
        except (ValueError, IndexError):
            self.errors["analyzer"].append('-104,"Data type error"')
            return None
        if np.any(rows[:, 2] != 1) or np.any(rows[:, 0] != rows[:, 1]):
            self.errors["analyzer"].append('-224,"Illegal parameter value"')
            return None
        self.freqs = rows[:, 0].copy()
        self.data = [None] * len(self.parameters)
        return None

    def _sweep(self) -> None:
        if self.freqs is None:
            self.errors["analyzer"].append('-221,"Settings conflict"')
            return
        with self.lock:
            bias = self._bias()
        key = bias.tobytes() + self.freqs.tobytes()
        if key not in self.cache:
            self.cache = {key: np.asarray(self.device.measure(bias.tolist(), self.freqs).values)}
            self.sweeps += 1
        acquisitions = -(-self.freqs.size // self.tones)
        if self.dwell_s:
            time.sleep(self.dwell_s * acquisitions)
        self.triggers += 1
        self.acquisitions += acquisitions
        for k, parameter in enumerate(self.parameters):  # one sweep serves every trace
            i, j = _PAIRS[parameter]
            self.data[k] = self.cache[key][:, i, j]


def main_loop(sim: InstrumentSim, say: Callable[[str], None]) -> None:
    """Serve until SIGINT or SIGTERM; ``say("listening ...")`` once both ports accept."""
    import signal

    stop = threading.Event()

    def handler(_signum: int, _frame: object) -> None:
        stop.set()

    signal.signal(signal.SIGTERM, handler)
    signal.signal(signal.SIGINT, handler)
    sim.start()
    say(f"listening: analyzer on 127.0.0.1:{sim.ports[0]}, source on 127.0.0.1:{sim.ports[1]}")
    try:
        while not stop.wait(0.2):
            pass
    finally:
        sim.stop()
