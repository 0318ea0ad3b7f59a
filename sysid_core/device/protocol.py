"""The device protocol, and the check of a device's attributes before anything is measured.

A device is any object with the attributes of :class:`Device` (no base class needed). A
simulation that knows its ground truth is also a :class:`SimulatedDevice`; studies and tests
read the TRUE split from it, which a tuning never sees.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from numbers import Real
from typing import Any, Protocol, runtime_checkable

import numpy as np
import xarray as xr

from sysid_core.errors import DeviceError

__all__ = ["Device", "ReportsProgress", "SimulatedDevice", "check_device", "is_real"]


@runtime_checkable
class Device(Protocol):
    """What the toolkit needs of a gyro, simulated or real (duck-typed).

    Attributes
    ----------
    electrodes : Sequence[str]
        Names of the bias electrodes (``n_e`` of them).
    bias_limits : tuple of float
        Allowed bias ``dv`` in volts, ``(low, high)``, for every electrode.
    structure_potential : float
        ``v_gyro`` in volts; the electrode potential seen by the structure is ``v_gyro - dv``.
    band_hz : tuple of float
        The frequency band, in Hz, where the two modes are.
    """

    electrodes: Sequence[str]
    bias_limits: tuple[float, float]
    structure_potential: float
    band_hz: tuple[float, float]

    def measure(self, bias: Sequence[float], frequencies_hz: np.ndarray) -> xr.DataArray:
        """Apply ``bias`` (volts, one per electrode) and measure the frequency response.

        Returns a complex ``DataArray`` with dims ``("frequency", "output", "input")``. The core
        checks ``bias`` against ``bias_limits`` before calling.
        """
        ...


@runtime_checkable
class SimulatedDevice(Device, Protocol):
    """A device that knows its own ground truth (a simulation; real hardware has none).

    Studies and tests use it to report the TRUE split of a tuning, which the tuning itself
    never sees.
    """

    def true_modal_frequencies_hz(self, bias: Sequence[float]) -> np.ndarray:
        """The true undamped modal frequencies at ``bias`` (Hz, ascending)."""
        ...


def is_real(value: Any) -> bool:
    """A real number (Python or NumPy), not a bool."""
    return isinstance(value, (Real, np.floating, np.integer)) and not isinstance(value, bool)


def _pair(value: Any) -> tuple[float, float] | None:
    try:
        a, b = value
    except (TypeError, ValueError):
        return None
    if not (is_real(a) and is_real(b) and math.isfinite(a) and math.isfinite(b)):
        return None
    return float(a), float(b)


@runtime_checkable
class ReportsProgress(Protocol):
    """A device that says what it is doing (optional): the run hands it its progress callback.

    For example the ``exchange`` device says which biases to set and which file to write.
    """

    def set_progress(self, say: Callable[[str], None]) -> None:
        """Receive the callback that prints the run's progress lines."""
        ...


def check_device(device: object, name: str = "device") -> Device:
    """Check the :class:`~sysid_core.plugin.interfaces.Device` protocol's attributes.

    Returns ``device`` itself once its attributes pass.

    Raises
    ------
    DeviceError
        Naming the device and the attribute that is missing or wrong, and what it must be.
    """
    where = f"device {name!r}"
    missing = [
        attr
        for attr in ("electrodes", "bias_limits", "structure_potential", "band_hz", "measure")
        if not hasattr(device, attr)
    ]
    if missing:
        raise DeviceError(
            f"{where} does not follow the Device protocol: missing {', '.join(missing)} "
            "(see docs/writing-a-device.md)"
        )
    electrodes = device.electrodes  # type: ignore[attr-defined]
    if isinstance(electrodes, str) or not isinstance(electrodes, Sequence) or not electrodes:
        raise DeviceError(
            f"{where}: 'electrodes' must be a non-empty sequence of names, got {electrodes!r}"
        )
    if not all(isinstance(e, str) and e for e in electrodes) or len(set(electrodes)) != len(
        electrodes
    ):
        raise DeviceError(
            f"{where}: 'electrodes' must be unique non-empty strings, got {list(electrodes)!r}"
        )
    limits = _pair(device.bias_limits)  # type: ignore[attr-defined]
    if limits is None or not limits[0] < limits[1]:
        raise DeviceError(
            f"{where}: 'bias_limits' must be two finite numbers (low, high) in volts with "
            f"low < high, got {device.bias_limits!r}"  # type: ignore[attr-defined]
        )
    vg = device.structure_potential  # type: ignore[attr-defined]
    if not is_real(vg) or not math.isfinite(vg):
        raise DeviceError(
            f"{where}: 'structure_potential' must be a finite number of volts, got {vg!r}"
        )
    band = _pair(device.band_hz)  # type: ignore[attr-defined]
    if band is None or not 0 < band[0] < band[1]:
        raise DeviceError(
            f"{where}: 'band_hz' must be two frequencies (low, high) in Hz with "
            f"0 < low < high, got {device.band_hz!r}"  # type: ignore[attr-defined]
        )
    if not callable(device.measure):  # type: ignore[attr-defined]
        raise DeviceError(f"{where}: 'measure' must be a method")
    return device  # type: ignore[return-value]
