"""Talking to a device safely: the bias check, the timed measure, and the answer check.

Every call a run makes to a device goes through :class:`GuardedDevice`:

* the bias is checked against the device's limits before anything is applied
  (:func:`check_bias`);
* ``measure`` runs with an optional time limit in a daemon thread, so a device that hangs can
  neither keep the process alive nor deliver a late answer into the run: after a timeout the
  guard refuses every further call on that device object;
* the answer is checked (:func:`check_answer`): a complex, finite ``DataArray`` with dims
  ``("frequency", "output", "input")``, 2×2, on exactly the requested frequencies, with the same
  channel labels as the device's earlier answers, and not all zero; its optional coordinates
  ``time_s`` (finite stamps) and ``noise_var`` (variances, each finite and >= 0 or NaN) too.
"""

from __future__ import annotations

import threading
from collections.abc import Sequence
from typing import Any

import numpy as np
import xarray as xr

from sysid_core.device.capabilities import Capabilities, optional_method, read_capabilities
from sysid_core.device.protocol import Device, SimulatedDevice, check_device
from sysid_core.errors import BiasLimitError, DeviceError, InvalidAnswerError, SysidError

__all__ = ["GuardedDevice", "applied_bias", "check_answer", "check_bias", "ground_truth"]

_DIMS = ("frequency", "output", "input")


def ground_truth(device: object) -> SimulatedDevice | None:
    """The :class:`SimulatedDevice` that ``device`` is or guards, else None.

    ``device`` may be the device itself or a :class:`GuardedDevice` around it.
    """
    raw = device.device if isinstance(device, GuardedDevice) else device
    return raw if isinstance(raw, SimulatedDevice) else None


def applied_bias(device: object, bias: np.ndarray) -> np.ndarray | None:
    """The bias ``device`` would really apply for ``bias``, if it says (else None).

    Devices that quantise (a DAC) may offer ``applied_bias(bias)`` (optional, see
    ``docs/writing-a-device.md``); an answer that is not one finite value per electrode, or an
    error, counts as not saying.
    """
    raw = device.device if isinstance(device, GuardedDevice) else device
    method = optional_method(raw, "applied_bias")
    if method is None:
        return None
    try:
        values = np.asarray(method(np.asarray(bias, dtype=float)), dtype=float).reshape(-1)
    except Exception:  # optional, informative only: never let it stop a run
        return None
    if values.shape != np.shape(bias) or not np.all(np.isfinite(values)):
        return None
    return values


def check_bias(device: Device, bias: Sequence[float] | np.ndarray) -> np.ndarray:
    """The core's safety check: ``bias`` has one finite value per electrode, inside the limits.

    Raises
    ------
    BiasLimitError
        Before anything is applied to the device.
    """
    try:
        b = np.asarray(bias, dtype=float)
    except (TypeError, ValueError):
        raise BiasLimitError(f"bias {bias!r} is not a list of numbers (volts)") from None
    n_e = len(device.electrodes)
    if b.shape != (n_e,):
        raise BiasLimitError(f"bias has {b.size} value(s); the device has {n_e} electrodes")
    low, high = device.bias_limits
    bad = [p for p in range(n_e) if not (np.isfinite(b[p]) and low <= b[p] <= high)]
    if bad:
        p = bad[0]
        raise BiasLimitError(
            f"refusing to apply {b[p]} V to electrode {device.electrodes[p]}: outside the "
            f"device's limits [{low}, {high}] V"
        )
    return b


def check_answer(
    answer: object,
    frequencies_hz: np.ndarray,
    labels: tuple[list[str], list[str]] | None = None,
) -> xr.DataArray:
    """Check a device's answer to ``measure``; return it.

    Parameters
    ----------
    answer : object
        What ``measure`` returned.
    frequencies_hz : ndarray
        The frequencies that were requested.
    labels : (outputs, inputs), optional
        Channel labels of the device's earlier answers, which this one must repeat.

    Raises
    ------
    InvalidAnswerError
        Saying what is wrong with the answer.
    """
    f = np.asarray(frequencies_hz, dtype=float)
    checked = _check_values(answer, f)
    _check_frequencies(checked, f)
    _check_labels(checked, labels)
    _check_times(checked)
    _check_noise(checked)
    return checked


def _check_noise(answer: xr.DataArray) -> None:
    """Check the optional ``noise_var``: a real variance per entry, finite and >= 0, or NaN.

    NaN says the device does not know that entry's noise.
    """
    if "noise_var" not in answer.coords:
        return
    var = answer.coords["noise_var"]
    if set(var.dims) != set(_DIMS):
        raise InvalidAnswerError(
            f"the device's noise_var coordinate has dims {var.dims}; expected {_DIMS}: one "
            "variance per point and channel"
        )
    values = np.asarray(var.values)
    if values.dtype.kind not in "iuf":
        raise InvalidAnswerError(
            f"the device's noise_var is {values.dtype}, not real: a variance is a real number"
        )
    values = values.astype(float)
    if np.any(np.isinf(values) | (values < 0)):
        raise InvalidAnswerError(
            "the device's noise_var must be finite and >= 0 (a variance; NaN: unknown)"
        )


def _check_times(answer: xr.DataArray) -> None:
    """Check the optional ``time_s`` stamps (the bench clock): one per point, finite.

    They need not increase along the frequency grid: a device may measure the points in any
    order.
    """
    if "time_s" not in answer.coords:
        return
    t = answer["time_s"]
    if t.dims != ("frequency",):
        raise InvalidAnswerError(
            f"the device's time_s coordinate has dims {t.dims}; expected ('frequency',): one "
            "time stamp per point"
        )
    values = np.asarray(t.values)
    if values.dtype.kind not in "iuf" or not np.all(np.isfinite(values.astype(float))):
        raise InvalidAnswerError(
            "the device's time_s stamps must be finite numbers of seconds (its own clock)"
        )


def _check_values(answer: object, f: np.ndarray) -> xr.DataArray:
    """``answer`` as a complex, finite, not all zero 2x2 ``DataArray`` at ``f.size`` points."""
    if not isinstance(answer, xr.DataArray):
        raise InvalidAnswerError(
            f"the device returned a {type(answer).__name__}, not an xarray.DataArray"
        )
    if tuple(answer.dims) != _DIMS:
        raise InvalidAnswerError(f"the device's answer has dims {answer.dims}; expected {_DIMS}")
    if answer.shape != (f.size, 2, 2):
        raise InvalidAnswerError(
            f"the device's answer has shape {answer.shape}; expected ({f.size}, 2, 2) for "
            f"{f.size} requested frequencies and a 2x2 (output x input) response"
        )
    if not np.iscomplexobj(answer.values):
        raise InvalidAnswerError(
            f"the device's answer is {answer.dtype}, not complex: a frequency response has "
            "magnitude and phase"
        )
    values = np.asarray(answer.values)
    if not np.all(np.isfinite(values)):
        bad = int(np.count_nonzero(~np.isfinite(values).all(axis=(1, 2))))
        raise InvalidAnswerError(f"the device's answer has non-finite values at {bad} point(s)")
    if not np.any(values):
        raise InvalidAnswerError(
            "the device's answer is all zero: is the analyzer connected and driving the gyro?"
        )
    return answer


def _check_frequencies(answer: xr.DataArray, f: np.ndarray) -> None:
    """The answer's ``frequency`` coordinate is the requested ``f`` (within rounding)."""
    if "frequency" not in answer.coords:
        raise InvalidAnswerError("the device's answer has no 'frequency' coordinate (Hz)")
    got = np.asarray(answer["frequency"].values, dtype=float)
    tol = 1e-9 * max(float(np.abs(f).max()), 1.0)
    if got.shape != f.shape:
        raise InvalidAnswerError(
            f"the device answered at {got.size} frequencies; {f.size} were requested"
        )
    off = np.flatnonzero(~np.isclose(got, f, rtol=0, atol=tol))
    if off.size:
        i = int(off[0])
        raise InvalidAnswerError(
            f"the device answered at other frequencies than requested ({off.size} point(s); "
            f"first: {got[i]} Hz instead of {f[i]} Hz)"
        )


def _check_labels(answer: xr.DataArray, labels: tuple[list[str], list[str]] | None) -> None:
    """The answer's channel labels: present, distinct, and the earlier ``labels`` if given."""
    outs_ins: list[list[str]] = []
    for dim in ("output", "input"):
        if dim not in answer.coords:
            raise InvalidAnswerError(f"the device's answer has no '{dim}' coordinate (labels)")
        names = [str(v) for v in answer[dim].values]
        if len(set(names)) != len(names):
            raise InvalidAnswerError(f"the device's answer repeats {dim} labels: {names}")
        outs_ins.append(names)
    if labels is not None and (outs_ins[0], outs_ins[1]) != (list(labels[0]), list(labels[1])):
        raise InvalidAnswerError(
            f"the device's answer has channels {outs_ins[0]} x {outs_ins[1]}, but its earlier "
            f"answers had {labels[0]} x {labels[1]}"
        )


class GuardedDevice:
    """A device with the core's checks around every call (see the module docstring).

    Parameters
    ----------
    device : Device
        The device; its protocol attributes are checked here (:func:`check_device`), and its
        optional capabilities read and checked once
        (:func:`~sysid_core.device.capabilities.read_capabilities`).
    name : str
        Its name, for messages.
    timeout_s : float or None
        Limit per ``measure`` call (None: wait as long as it takes).
    """

    def __init__(self, device: object, name: str, timeout_s: float | None = None) -> None:
        self.device = check_device(device, name)
        #: What the device states of its bench (tones, dwell, settling, ...), checked once.
        self.capabilities: Capabilities = read_capabilities(self.device, name)
        self.name = name
        self.timeout_s = timeout_s
        self.labels: tuple[list[str], list[str]] | None = None
        self._abandoned: str | None = None

    def measure(
        self, bias: Sequence[float] | np.ndarray, frequencies_hz: np.ndarray
    ) -> xr.DataArray:
        """Check ``bias``, measure, and check the answer.

        Raises
        ------
        BiasLimitError
            Before anything is applied.
        DeviceError
            If the device fails, does not answer in time, or was abandoned after a timeout.
        InvalidAnswerError
            If the answer is not a valid measurement (:func:`check_answer`); the answer is in
            the exception's ``answer`` attribute.
        """
        if self._abandoned is not None:
            raise DeviceError(
                f"device {self.name!r} timed out earlier ({self._abandoned}) and its call may "
                "still be running; create a new device (or restart) before measuring again"
            )
        b = check_bias(self.device, bias)
        f = np.array(frequencies_hz, dtype=float)
        answer = self._call(b, f)
        try:
            checked = check_answer(answer, f, self.labels)
        except InvalidAnswerError as exc:
            exc.answer = answer  # type: ignore[attr-defined]
            raise
        if self.labels is None:
            self.labels = (
                [str(v) for v in checked["output"].values],
                [str(v) for v in checked["input"].values],
            )
        return checked

    def _call(self, bias: np.ndarray, f: np.ndarray) -> object:
        where = f"at [{', '.join(f'{x:.4f}' for x in bias)}] V"
        if self.timeout_s is None:
            return self._wrap(lambda: self.device.measure(bias.tolist(), f.copy()), where)
        box: dict[str, Any] = {}

        def work() -> None:
            try:
                box["answer"] = self.device.measure(bias.tolist(), f.copy())
            except BaseException as exc:  # handed to the waiting thread
                box["error"] = exc

        # A daemon thread: if the device hangs, the process can still exit.
        thread = threading.Thread(target=work, name=f"sysid-measure-{self.name}", daemon=True)
        thread.start()
        thread.join(self.timeout_s)
        if thread.is_alive():
            self._abandoned = f"no answer within {self.timeout_s} s {where}"
            raise DeviceError(
                f"device {self.name!r} did not answer within {self.timeout_s} s {where}; "
                "check the instrument, raise [experiment] timeout_s, or resume with --resume"
            )
        if "error" in box:
            return self._wrap(lambda: _reraise(box["error"]), where)
        return box["answer"]

    def _wrap(self, call: Any, where: str) -> object:
        try:
            return call()
        except SysidError:
            raise
        except Exception as exc:
            raise DeviceError(
                f"device {self.name!r} failed while measuring {where}: {type(exc).__name__}: {exc}"
            ) from exc


def _reraise(exc: BaseException) -> None:
    raise exc
