"""The ``visa`` device: a frequency-response analyzer and a DC bias source over PyVISA.

Each measurement: every electrode's voltage is checked against ``bias_limits``, ramped to its
value in steps no larger than the source profile's ``max_step_v``, read back (a reading off by
more than ``readback_tolerance_v`` stops the run, naming the electrode, with the outputs set
safe), the outputs are switched on (first time), then the analyzer is given the frequency list
and, for each (output, input) pair of the gyro, selects it, triggers one sweep, waits for it
and reads the complex response: four sweeps. An analyzer whose profile says ``receivers = 2``
measures both outputs of a drive input in one sweep (one trace per output): for each input it
defines the two traces, triggers one sweep, waits for it and reads both traces: two sweeps.
The instruments' error queues (``SYST:ERR?``) are read after
every step; an error, a timeout or a lost connection is a one-line
:class:`~sysid_core.errors.DeviceError` (measurements saved so far stay; ``--resume``
continues once the instruments answer again). ``close()`` (called by the run when it ends,
fails or is interrupted) ramps every channel to the safe bias and switches the outputs off.

The instruments' commands come from profiles (:mod:`sysid_visa.profiles`); PyVISA's
pure-Python backend ``@py`` (pyvisa-py) is the default, ``visa_library`` names another (a
vendor's VISA library).
"""

from __future__ import annotations

import re
import time
from collections.abc import Callable, Sequence
from typing import Annotated, Any, ClassVar, Literal

import numpy as np
import xarray as xr
from annotated_types import Ge, Gt

from sysid_core.errors import BiasLimitError, ConfigError, DeviceError
from sysid_visa.profiles import AnalyzerProfile, SourceProfile, load_profile

__all__ = ["VisaDevice"]

#: (output, input) indices of the pairs, in the order one receiver sweeps them.
_PAIR_ORDER = ((0, 0), (0, 1), (1, 0), (1, 1))


class VisaDevice:
    """A gyro on a bench driven over PyVISA (see the module docstring).

    Parameters
    ----------
    analyzer, source : str
        VISA resource strings, e.g. ``"TCPIP::192.168.1.20::5025::SOCKET"`` or
        ``"GPIB0::17::INSTR"``.
    electrodes : list of str
        The bias electrodes' names.
    bias_limits : [low, high]
        Allowed bias on every electrode (volts); nothing outside is ever sent.
    structure_potential : float
        ``v_gyro`` (volts).
    band_hz : [low, high]
        The band where the two modes are (Hz).
    channels : list of int, optional
        The source channel of each electrode (default 1, 2, ...).
    analyzer_profile, source_profile : str
        A shipped profile's name or a profile file's path.
    visa_library : str
        PyVISA's backend: ``"@py"`` (pyvisa-py, default) or a VISA library's path.
    if_bandwidth_hz : float
        The analyzer's IF bandwidth (Hz): each point integrates about ``1/if_bandwidth_hz``.
    point_delay_s : float, optional
        Settling time before each point (seconds): a high-Q mode needs a few ``Q/(π f)``.
        Left out, the analyzer's default (0 in the shipped profile's segment table) and the
        run's bench time estimate the settling as ``5 Q/ω`` of the fitted modes.
    safe_bias : "zero" or "first"
        Where ``close()`` leaves the electrodes: 0 V, or the first bias of the run (its start).
    bias_resolution : float, optional
        The source's voltage step (volts per DAC code), if it quantises.
    tones : int, optional
        Frequencies the analyzer measures per acquisition (a lock-in with several
        demodulators); default: the analyzer profile's ``tones`` (1 in the shipped ones).

    Attributes
    ----------
    receivers : int
        Outputs one sweep measures (the analyzer profile's ``receivers``, 1 or 2).
    points_per_frequency : int
        Sweeps per measurement, each measuring every frequency once: ``4 // receivers``.
    tones : int
        Frequencies per acquisition (the device protocol's ``tones``).
    """

    name: ClassVar[str] = "visa"
    description: ClassVar[str] = (
        "A bench over PyVISA: a frequency-response analyzer and a DC source"
    )

    def __init__(
        self,
        *,
        analyzer: str,
        source: str,
        electrodes: list[str],
        bias_limits: list[float],
        structure_potential: float,
        band_hz: list[float],
        channels: list[int] | None = None,
        analyzer_profile: str = "keysight-ena",
        source_profile: str = "keysight-n6700",
        visa_library: str = "@py",
        if_bandwidth_hz: Annotated[float, Gt(0)] = 10.0,
        point_delay_s: Annotated[float, Ge(0)] | None = None,
        safe_bias: Literal["zero", "first"] = "zero",
        bias_resolution: Annotated[float, Gt(0)] | None = None,
        tones: Annotated[int, Ge(1)] | None = None,
    ) -> None:
        self.electrodes: Sequence[str] = tuple(str(e) for e in electrodes)
        self.bias_limits = (float(bias_limits[0]), float(bias_limits[1]))
        self.structure_potential = float(structure_potential)
        self.band_hz = (float(band_hz[0]), float(band_hz[1]))
        if channels is None:
            channels = list(range(1, len(self.electrodes) + 1))
        if len(channels) != len(self.electrodes) or len(set(channels)) != len(channels):
            raise ConfigError(
                f"visa: channels {channels} must give one distinct source channel per electrode "
                f"({len(self.electrodes)})"
            )
        if safe_bias not in ("zero", "first"):
            raise ConfigError(f"visa: safe_bias must be 'zero' or 'first', got {safe_bias!r}")
        self.channels = [int(c) for c in channels]
        an = load_profile(analyzer_profile, "analyzer")
        so = load_profile(source_profile, "source")
        assert isinstance(an, AnalyzerProfile) and isinstance(so, SourceProfile)
        self.aprof, self.sprof = an, so
        self.receivers = an.receivers
        #: Every frequency is measured once per sweep: one sweep per (output, input) pair, or
        #: per input with two receivers.
        self.points_per_frequency = 4 // self.receivers
        self.tones = an.tones if tones is None else int(tones)
        self.if_bandwidth_hz = float(if_bandwidth_hz)
        self.point_delay_s = None if point_delay_s is None else float(point_delay_s)
        self.safe_mode = safe_bias
        if bias_resolution is not None:
            self.bias_resolution = float(bias_resolution)
        self.resources = (analyzer, source)
        self.visa_library = visa_library
        self._rm: Any = None
        self._an: Any = None
        self._so: Any = None
        self._set: np.ndarray | None = None  # what the source was last told
        self._first: np.ndarray | None = None
        self._source_ready = False
        self._analyzer_ready = False
        self._say: Callable[[str], None] = lambda _m: None

    # ------------------------------------------------------------------ bench time
    @property
    def dwell_s(self) -> float | None:
        """Seconds per acquisition of one sweep, ``1/if_bandwidth_hz + point_delay_s``: one
        frequency point each, or :attr:`tones` of them; None without ``point_delay_s`` (the run
        then estimates the settling from the modes)."""
        if self.point_delay_s is None:
            return None
        return 1.0 / self.if_bandwidth_hz + self.point_delay_s

    def set_progress(self, say: Callable[[str], None]) -> None:
        """Receive the run's progress callback."""
        self._say = say

    # ------------------------------------------------------------------ connecting
    def _open(self) -> None:
        if self._an is not None:
            return
        import pyvisa

        try:
            self._rm = pyvisa.ResourceManager(self.visa_library)
        except Exception as exc:
            raise DeviceError(
                f"visa: cannot load the VISA library {self.visa_library!r}: {exc} (the default "
                "'@py' needs pyvisa-py)"
            ) from None
        self._an = self._connect(self.resources[0], self.aprof, "analyzer")
        self._so = self._connect(self.resources[1], self.sprof, "source")

    def _connect(
        self, resource: str, profile: AnalyzerProfile | SourceProfile, role: str, say: bool = True
    ) -> Any:
        try:
            inst = self._rm.open_resource(resource)
            inst.read_termination = profile.connection.read_termination
            inst.write_termination = profile.connection.write_termination
            inst.timeout = profile.connection.timeout_s * 1000.0
            ident = str(inst.query(profile.commands.identify)).strip()
        except Exception as exc:
            raise DeviceError(
                f"visa: cannot reach the {role} at {resource}: {_short(exc)}; is it on and "
                "connected? (then --resume)"
            ) from None
        if say:
            self._say(f"visa: {role} {resource}: {ident}")
        return inst

    # ------------------------------------------------------------------ talking
    def _write(self, role: str, command: str) -> None:
        inst = self._an if role == "analyzer" else self._so
        try:
            inst.write(command)
        except Exception as exc:
            raise self._lost(role, command, exc) from None

    def _query(self, role: str, command: str) -> str:
        inst = self._an if role == "analyzer" else self._so
        try:
            return str(inst.query(command)).strip()
        except Exception as exc:
            raise self._lost(role, command, exc) from None

    def _lost(self, role: str, command: str, exc: Exception) -> DeviceError:
        resource = self.resources[0 if role == "analyzer" else 1]
        return DeviceError(
            f"visa: the {role} at {resource} failed on {command[:60]!r}: {_short(exc)}; "
            "measurements so far are saved: continue with --resume once it answers"
        )

    def _errors(self, role: str, after: str) -> None:
        profile = self.aprof if role == "analyzer" else self.sprof
        answer = self._query(role, profile.commands.error)
        if not re.match(profile.commands.no_error, answer):
            raise DeviceError(f"visa: the {role} reports {answer!r} after {after[:60]!r}")

    # ------------------------------------------------------------------ the source
    def _check(self, bias: Sequence[float]) -> np.ndarray:
        b = np.asarray(bias, dtype=float)
        lo, hi = self.bias_limits
        if b.shape != (len(self.electrodes),):
            raise BiasLimitError(
                f"visa: {b.size} bias value(s) for {len(self.electrodes)} electrodes"
            )
        for e, v in zip(self.electrodes, b, strict=True):
            if not (np.isfinite(v) and lo <= v <= hi):
                raise BiasLimitError(
                    f"visa: refusing to set {v} V on electrode {e}: outside [{lo}, {hi}] V"
                )
        return b

    def _set_one(self, p: int, volts: float) -> None:
        command = self.sprof.commands.set.format(volts=f"{volts:.6f}", channel=self.channels[p])
        self._write("source", command)
        self._errors("source", command)

    def _ramp(self, target: np.ndarray) -> None:
        """Move every channel to ``target`` in steps of at most ``max_step_v``."""
        start = self._set if self._set is not None else self._read_all()
        step = self.sprof.safety.max_step_v
        n = int(np.ceil(np.max(np.abs(target - start)) / step - 1e-12)) if target.size else 0
        for k in range(1, max(n, 1) + 1):
            now = start + (target - start) * k / max(n, 1)
            for p in range(len(self.electrodes)):
                if self._set is None or now[p] != self._set[p]:
                    self._set_one(p, float(now[p]))
            self._set = now.copy()
            if self.sprof.safety.step_settle_s:
                time.sleep(self.sprof.safety.step_settle_s)

    def _read_all(self) -> np.ndarray:
        values = []
        for p, ch in enumerate(self.channels):
            command = self.sprof.commands.measure.format(channel=ch)
            text = self._query("source", command)
            try:
                values.append(float(text.split(",")[0]))
            except ValueError:
                raise DeviceError(
                    f"visa: the source answered {text!r} to {command!r} (electrode "
                    f"{self.electrodes[p]}), not a voltage"
                ) from None
        return np.array(values)

    def _outputs(self, on: bool) -> None:
        template = self.sprof.commands.output_on if on else self.sprof.commands.output_off
        for ch in self.channels:
            command = template.format(channel=ch)
            self._write("source", command)
            self._errors("source", command)

    def _apply(self, bias: np.ndarray) -> np.ndarray:
        if not self._source_ready:
            # from whatever the channels output now (a run cut off earlier may have left them
            # on), ramp to 0 V, switch on, then ramp to the bias: no jump larger than a step
            for command in self.sprof.commands.setup:
                self._write("source", command)
            self._set = None
            self._ramp(np.zeros_like(bias))
            self._outputs(True)
            self._source_ready = True
        self._ramp(bias)
        read = self._read_all()
        tol = self.sprof.safety.readback_tolerance_v
        expected = self.applied_bias(bias)
        off = np.abs(read - expected) > tol
        if np.any(off):
            p = int(np.flatnonzero(off)[0])
            self._safe_quietly()
            raise DeviceError(
                f"visa: electrode {self.electrodes[p]} reads back {read[p]:.6g} V after "
                f"{bias[p]:.6g} V was set (tolerance {tol} V); the outputs were set safe. "
                "Check the wiring and the source, then --resume"
            )
        return read

    # ------------------------------------------------------------------ the analyzer
    def _plan(self) -> list[list[tuple[int, int, int]]]:
        """The sweeps of a measurement: each a list of ``(trace, output, input)`` it reads.

        One receiver: one sweep per pair, on trace 1. Two: one sweep per input, output ``i``
        on trace ``i + 1``.
        """
        if self.receivers == 1:
            return [[(1, i, j)] for i, j in _PAIR_ORDER]
        return [[(1, 0, j), (2, 1, j)] for j in (0, 1)]

    def _pair_fields(self, trace: int, i: int, j: int) -> dict[str, str]:
        return {
            "trace": str(trace),
            "parameter": self.aprof.pairs[f"y{i + 1}/u{j + 1}"],
            "output": f"y{i + 1}",
            "input": f"u{j + 1}",
        }

    def _read_trace(self, fields: dict[str, str], n: int) -> np.ndarray:
        """Read one trace (its ``activate`` commands first): ``n`` complex points."""
        c = self.aprof.commands
        for command in c.activate:
            self._write("analyzer", command.format(**fields))
        if c.activate:
            self._errors("analyzer", c.activate[-1].format(**fields))
        # one receiver: `read` is sent as written (it was never a template)
        read = c.read.format(**fields) if self.receivers == 2 else c.read
        text = self._query("analyzer", read)
        self._errors("analyzer", read)
        parameter = fields["parameter"]
        try:
            values = np.array([float(v) for v in text.split(",")])
        except ValueError:
            raise DeviceError(
                f"visa: the analyzer's data for {parameter} are not numbers ({text[:40]!r})"
            ) from None
        if values.size != 2 * n:
            raise DeviceError(
                f"visa: the analyzer returned {values.size // 2} points for {parameter}; "
                f"{n} were asked"
            )
        return values[0::2] + 1j * values[1::2]

    def _sweep(self, f: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """The 2×2 response at ``f`` and each point's time stamp.

        One sweep per pair (one receiver) or per input (two receivers, :meth:`_plan`). The
        stamps are the host's monotonic clock: per sweep, its start and end interpolated over
        its acquisitions (:attr:`tones` consecutive points each share one), averaged over the
        sweeps made.
        """
        c = self.aprof.commands
        fields = {
            "if_bandwidth_hz": f"{self.if_bandwidth_hz:g}",
            "delay_s": f"{self.point_delay_s or 0.0:g}",
        }
        if not self._analyzer_ready:
            for command in c.setup:
                command = command.format(**fields)
                self._write("analyzer", command)
                self._errors("analyzer", command)
            self._analyzer_ready = True
        segments = ",".join(c.segment.format(frequency_hz=f"{x:.9g}", **fields) for x in f)
        command = c.frequencies.format(
            count=f.size, segments=segments, start_hz=f"{f[0]:.9g}", stop_hz=f"{f[-1]:.9g}"
        )
        self._write("analyzer", command)
        self._errors("analyzer", "the frequency list")
        out = np.empty((f.size, 2, 2), dtype=complex)
        stamps = np.zeros(f.size)
        acquisition = np.arange(f.size) // self.tones
        done = (acquisition + 1) / (acquisition[-1] + 1)  # of the sweep, when each point is
        plan = self._plan()
        for sweep in plan:
            started = time.monotonic()
            for trace, i, j in sweep:
                pair = self._pair_fields(trace, i, j)
                for command in c.select:
                    self._write("analyzer", command.format(**pair))
                if c.select:
                    self._errors("analyzer", c.select[-1].format(**pair))
            # one receiver: the pair's fields; two: the input's (both outputs are measured)
            first = self._pair_fields(*sweep[0])
            trigger = first if self.receivers == 1 else {"input": first["input"]}
            for command in c.trigger:
                self._write("analyzer", command.format(**trigger))
            self._query("analyzer", c.wait)
            for trace, i, j in sweep:
                out[:, i, j] = self._read_trace(self._pair_fields(trace, i, j), f.size)
            ended = time.monotonic()
            stamps += started + (ended - started) * done
        return out, stamps / len(plan)

    # ------------------------------------------------------------------ the protocol
    def applied_bias(self, bias: Sequence[float] | np.ndarray) -> np.ndarray:
        """What the source applies for ``bias``: rounded to ``bias_resolution`` if stated."""
        b = np.asarray(bias, dtype=float)
        step = getattr(self, "bias_resolution", None)
        return b if step is None else np.round(b / step) * step

    def measure(self, bias: Sequence[float], frequencies_hz: np.ndarray) -> xr.DataArray:
        """Set the biases safely, sweep every pair, return the 2×2 response."""
        b = self._check(bias)
        f = np.asarray(frequencies_hz, dtype=float)
        self._open()
        if self._first is None:
            self._first = b.copy()
        read = self._apply(b)
        data, stamps = self._sweep(f)
        da = xr.DataArray(
            data,
            dims=("frequency", "output", "input"),
            coords={
                "frequency": f,
                "output": ["y1", "y2"],
                "input": ["u1", "u2"],
                "time_s": ("frequency", stamps, {"units": "s"}),
            },
        )
        da.attrs["applied_bias"] = [float(v) for v in read]
        return da

    def _safe_target(self) -> np.ndarray:
        n = len(self.electrodes)
        if self.safe_mode == "first" and self._first is not None:
            return self._first.copy()
        return np.zeros(n)

    def _safe_quietly(self) -> None:
        try:
            self._ramp(self._safe_target())
        except Exception:  # already failing: the caller's error is the one reported
            pass

    def close(self) -> None:
        """Ramp every channel to the safe bias, switch the outputs off, release the instruments."""
        if self._so is None:
            return
        try:
            # a fresh connection: an interrupted query may have left an answer unread
            try:
                self._so.close()
            except Exception:
                pass
            self._so = self._connect(self.resources[1], self.sprof, "source", say=False)
            self._ramp(self._safe_target())
            self._outputs(False)
        finally:
            for inst in (self._an, self._so):
                try:
                    inst.close()
                except Exception:
                    pass
            self._an = self._so = None
            self._source_ready = self._analyzer_ready = False
            self._set = None

    def __repr__(self) -> str:
        return f"VisaDevice(analyzer={self.resources[0]!r}, source={self.resources[1]!r})"


def _short(exc: BaseException) -> str:
    text = str(exc).strip().splitlines()[0] if str(exc).strip() else ""
    return f"{type(exc).__name__}: {text}" if text else type(exc).__name__
