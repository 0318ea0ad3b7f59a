"""The run's bench: its device and folder; every measurement checked, saved first, counted.

The device's clock is read here once per measurement: its stamps (checked finite by
:func:`sysid_core.device.measuring.check_answer`) must not run backwards from one measurement
to the next (the contract's one monotonic clock per run), and their span is the run's bench
time (:attr:`Bench.clock_span_s`). Before a measurement is made, the run's ``guard`` may refuse
it (the bench-time budget, :mod:`sysid_core.clock.budget`).
"""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path

import numpy as np
import xarray as xr

from sysid_core.clock.benchtime import acquisitions, points_per_frequency
from sysid_core.clock.runfolder import RunFolder
from sysid_core.data.schema import experiment_from_measurement, point_times
from sysid_core.device.capabilities import optional_method
from sysid_core.device.measuring import GuardedDevice
from sysid_core.errors import DeviceError, InvalidAnswerError

__all__ = [
    "PURPOSES",
    "Bench",
    "purpose_of",
]


class Bench:
    """Measurements of one run: read from its folder when there (resume), else measured.

    Parameters
    ----------
    device : GuardedDevice
        The run's device, with the core's checks around it.
    folder : RunFolder
        Where every measurement is written before anything else is done with it.
    electrodes : list of str
        The device's electrodes.
    structure_potential : float
        ``v_gyro`` (volts).
    name : str
        The device's name in the configuration.
    say : callable
        Receives one-line progress messages.
    owns_device : bool
        The run built the device (then :meth:`close` closes it).
    tones : int
        Frequencies one acquisition measures (:func:`sysid_core.clock.benchtime.tones`).
    guard : callable, optional
        Called before a measurement is made (not when one is read) with its acquisitions and
        whether the bias changes; raises to refuse it.
    """

    def __init__(
        self,
        device: GuardedDevice,
        folder: RunFolder,
        electrodes: list[str],
        structure_potential: float,
        name: str,
        say: Callable[[str], None],
        owns_device: bool,
        tones: int = 1,
        guard: Callable[[int, bool], None] | None = None,
    ) -> None:
        self.device = device
        self.folder = folder
        self.electrodes = electrodes
        self.structure_potential = structure_potential
        self.name = name
        self.say = say
        self.owns_device = owns_device
        self.tones = max(int(tones), 1)
        self.guard = guard
        #: Measurements made or read so far, their frequency points, their acquisitions
        #: (``tones`` points each) and the bias changes before them.
        self.measurements = 0
        self.points = 0
        self.acquisitions = 0
        self.bias_changes = 0
        self._last_bias: np.ndarray | None = None
        #: The earliest and latest time stamps seen (the device's clock), and how many
        #: measurements came without them.
        self.first_s: float | None = None
        self.last_s: float | None = None
        self.untimed = 0
        #: The bench clock by purpose (:func:`purpose_of`), and split into the time between
        #: measurements (settling after a bias change, and waiting) and the time their points
        #: span (acquiring), in seconds: from the time stamps only.
        self.by_purpose: dict[str, float] = {}
        self.settling_s = 0.0
        self.acquiring_s = 0.0
        #: The latest stamp of a measurement this process made (not read): the next must not
        #: be earlier.
        self._clock_s: float | None = None

    def measure(self, bias: np.ndarray, freqs: np.ndarray, path: Path) -> xr.Dataset:
        """Read ``path`` if it holds this measurement (resume), else measure and save it first.

        The device measures ``freqs`` in the order given (a window's least informative point
        first: :func:`~sysid_core.measure.information.measuring_order`); the data set holds
        them in frequency order, each with its time stamp.
        """
        order, freqs = np.asarray(freqs, dtype=float), np.sort(np.asarray(freqs, dtype=float))
        per = points_per_frequency(self.device.capabilities)
        n_acq = self.acquisitions_for(int(freqs.size))
        changes = self._last_bias is None or not np.array_equal(self._last_bias, bias)

        def measure() -> xr.Dataset:
            if self.guard is not None:
                self.guard(n_acq, changes)
            self.say(
                f"measuring at [{', '.join(f'{b:.4f}' for b in bias)}] V, "
                f"{freqs[0]:.3f}-{freqs[-1]:.3f} Hz, {freqs.size} points"
            )
            da = self.device.measure(bias, order).sortby("frequency")
            self._check_clock(da)
            return experiment_from_measurement(
                da, bias, self.electrodes, self.structure_potential, self.name
            )

        ds, was_read = self.folder.read_or_measure(path, bias, freqs, measure)
        if was_read:
            self.say(f"read {path.relative_to(self.folder.path)} (measured earlier)")
        self.measurements += 1
        self.points += int(freqs.size) * per
        self.acquisitions += n_acq
        if changes:
            self.bias_changes += 1
        self._last_bias = np.array(bias, dtype=float)
        times = point_times(ds, 0)
        if times is None or times.size == 0:
            self.untimed += 1
        else:
            low, high = float(times.min()), float(times.max())
            gap = 0.0 if self.last_s is None else max(low - self.last_s, 0.0)
            purpose = purpose_of(path.name)
            self.by_purpose[purpose] = self.by_purpose.get(purpose, 0.0) + gap + (high - low)
            self.settling_s += gap
            self.acquiring_s += high - low
            self.first_s = low if self.first_s is None else min(self.first_s, low)
            self.last_s = high if self.last_s is None else max(self.last_s, high)
        return ds

    def acquisitions_for(self, n_points: int) -> int:
        """The acquisitions a sweep of ``n_points`` frequencies takes on this bench."""
        per = points_per_frequency(self.device.capabilities)
        return acquisitions(int(n_points), self.tones) * per

    def _check_clock(self, answer: xr.DataArray) -> None:
        """Refuse an answer whose stamps start before the previous answer's last one."""
        if "time_s" not in answer.coords or answer["time_s"].size == 0:
            return
        t = np.asarray(answer["time_s"].values, dtype=float)
        low, high = float(t.min()), float(t.max())
        if self._clock_s is not None and low < self._clock_s:
            exc = InvalidAnswerError(
                f"device {self.name!r}: its clock ran backwards: this measurement's first time "
                f"stamp {low:.6g} s is before the previous measurement's last, "
                f"{self._clock_s:.6g} s; time_s must come from one monotonic clock for the "
                "whole run (docs/contracts.md)"
            )
            exc.answer = answer  # type: ignore[attr-defined]  # kept in rejected/
            raise exc
        self._clock_s = high

    @property
    def clock_span_s(self) -> float | None:
        """The device clock's span over the run (seconds), or ``None``.

        The latest minus the earliest time stamp, when every measurement carried ``time_s``;
        ``None`` when one did not.
        """
        if self.untimed or self.first_s is None or self.last_s is None:
            return None
        return self.last_s - self.first_s

    def close(self, failing: bool) -> None:
        """Call the device's optional ``close()`` when the run ends (made safe, released).

        Only a device the run built from the configuration is closed (one passed in belongs to
        the caller). When the run is failing anyway, a failed close is a progress note and the
        run's own error is what is raised; when the run succeeded, a failed close is a
        :class:`~sysid_core.errors.DeviceError`: the bench may not be safe.
        """
        close = optional_method(self.device.device, "close")
        if not self.owns_device or close is None:
            return
        try:
            close()
        except Exception as exc:
            message = (
                f"device {self.name!r} could not be closed (made safe): {type(exc).__name__}: {exc}"
            )
            if failing:
                self.say(f"note: {message}")
                return
            raise DeviceError(message) from exc


#: What a run measures for, by the name of the file it saves a measurement in.
PURPOSES = ("design", "verification", "locating", "repeats", "other")


def purpose_of(name: str) -> str:
    """The purpose of the measurement saved as ``name`` (one of :data:`PURPOSES`).

    ``exp<j>.nc``: the design of an identification (a probe too: it is the design's centre);
    ``verify*.nc``: a verification window; ``*locate*``, ``*probe*``, ``*-band*`` and
    ``*-zoom*``: sweeps that locate the modes (a zoom: windows around the modes a failed sweep
    placed); ``*-pass<k>*`` and ``window-again.nc``: a window measured again.
    """
    if "-pass" in name or name.startswith("window-again"):
        return "repeats"
    if any(word in name for word in ("locate", "probe", "-band", "-zoom")):
        return "locating"
    if name.startswith("verify"):
        return "verification"
    if name.startswith("exp"):
        return "design"
    return "other"
