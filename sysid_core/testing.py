"""Contract tests a device author runs on their device (pytest).

:class:`DeviceContract` is a mixin of pytest tests that checks an object against the
:class:`~sysid_core.plugin.interfaces.Device` protocol and the behaviour the toolkit relies on.
Subclass it in a test module, give the subclass a name pytest collects (``Test...``) and say how to
build the device::

    # tests/test_contract.py of your package
    from sysid_core.testing import DeviceContract
    from my_gyro import MyGyro

    class TestMyGyro(DeviceContract):
        checks_bias_limits = True          # my device refuses out-of-limit biases itself

        def make_device(self):
            return MyGyro(seed=1)

        def device_factory(self):          # optional: the factory registered in sysid_devices()
            return MyGyro

Then ``pytest tests/test_contract.py``. Only pytest itself is needed (no plugins). Every test
uses a fresh device from :meth:`DeviceContract.make_device` through the ``device`` fixture; the
class attributes tune the checks to a device (tolerances, sweep size) and are documented below.

What is checked
---------------
* what ``sysid tune`` itself checks: the device's attributes before the first measurement, and
  every answer (``check_device`` and ``check_answer`` of :mod:`sysid_core.device.measuring`);
* the protocol attributes exist with the right types: ``electrodes`` (non-empty, unique
  strings), ``bias_limits`` (two finite numbers, ordered), ``structure_potential`` (finite),
  ``band_hz`` (two finite positive numbers, ordered), ``measure`` callable;
* ``measure`` at the reference bias (0 V, or the middle of the limits if 0 V is not allowed)
  returns a complex ``xarray.DataArray`` with dims ``("frequency", "output", "input")``, 2×2,
  exactly the requested frequencies (an irregular grid) and finite values; a list and an array
  bias are both accepted;
* a resonance exists in ``band_hz``: the largest response entry inside the band exceeds the band
  edges' by :attr:`DeviceContract.resonance_ratio`;
* measuring twice at the same bias gives the same response within
  :attr:`DeviceContract.repeat_tolerance` of its peak (noise, not drift or state);
* if the device has ``true_modal_frequencies_hz`` (simulated devices), it returns two finite,
  ascending frequencies inside ``band_hz`` (widened by :attr:`DeviceContract.band_margin`);
* optional (:attr:`DeviceContract.checks_bias_limits`): the device itself refuses a bias outside
  ``bias_limits`` or with the wrong number of values, raising
  :class:`~sysid_core.errors.BiasLimitError` (the core checks first; this is defence in depth);
* optional (:meth:`DeviceContract.device_factory`): building the factory as the registry does
  (:func:`sysid_core.plugin.options.build`) rejects an unknown option with a
  :class:`~sysid_core.errors.ConfigError` naming it.

These tests measure, so on real hardware they drive it. The reference bias is inside the limits
and the out-of-limit tests run only when :attr:`DeviceContract.checks_bias_limits` is set.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from typing import ClassVar

import numpy as np
import pytest
import xarray as xr

from sysid_core.device.measuring import check_answer
from sysid_core.device.protocol import Device, SimulatedDevice, check_device, is_real
from sysid_core.errors import BiasLimitError, ConfigError
from sysid_core.plugin.options import build

__all__ = ["DeviceContract"]

_DIMS = ("frequency", "output", "input")


class DeviceContract:
    """Pytest mixin: the contract every device plugin must satisfy.

    Override :meth:`make_device` (required) and, optionally, :meth:`device_factory`,
    :meth:`reference_bias`, :meth:`frequencies` and the class attributes.
    """

    #: Points of the band sweep in the resonance test (resolve your sharpest peak).
    band_points: ClassVar[int] = 601
    #: The in-band peak must exceed the larger band-edge magnitude by this factor.
    resonance_ratio: ClassVar[float] = 2.0
    #: Two measurements at the same bias may differ by this fraction of the response's peak.
    repeat_tolerance: ClassVar[float] = 1e-2
    #: ``true_modal_frequencies_hz`` may lie outside ``band_hz`` by this fraction of its width.
    band_margin: ClassVar[float] = 0.1
    #: Set to True if ``measure`` itself refuses forbidden biases (tests then try some).
    checks_bias_limits: ClassVar[bool] = False

    # ------------------------------------------------------------ to override
    def make_device(self) -> Device:
        """Return a fresh device to test. Must be overridden."""
        raise NotImplementedError(
            f"{type(self).__name__} must override make_device() to return the device under test"
        )

    def device_factory(self) -> Callable[..., Device] | None:
        """The factory registered in ``sysid_devices()``, to test option handling; or None."""
        return None

    def reference_bias(self, device: Device) -> list[float]:
        """A bias that is safe to apply: 0 V on every electrode, or mid-limits if 0 V is not."""
        low, high = device.bias_limits
        value = 0.0 if low <= 0.0 <= high else 0.5 * (low + high)
        return [value] * len(device.electrodes)

    def frequencies(self, device: Device, n: int) -> np.ndarray:
        """``n`` equally spaced frequencies across ``band_hz`` (Hz)."""
        low, high = device.band_hz
        return np.linspace(low, high, n)

    @pytest.fixture
    def device(self) -> Device:
        """A fresh device from :meth:`make_device`."""
        return self.make_device()

    # -------------------------------------------------------------- helpers
    @staticmethod
    def _peak(response: xr.DataArray | np.ndarray) -> np.ndarray:
        """Largest absolute entry per frequency point."""
        return np.abs(np.asarray(response)).max(axis=(1, 2))

    # ---------------------------------------------------------- attributes
    def test_core_accepts_the_device(self, device: Device) -> None:
        """What ``sysid tune`` checks before its first measurement (raises DeviceError: why)."""
        check_device(device, type(device).__name__)

    def test_core_accepts_the_answers(self, device: Device) -> None:
        """What ``sysid tune`` checks on every answer, including the same labels every time."""
        f = self.frequencies(device, 11)
        first = check_answer(device.measure(self.reference_bias(device), f), f)
        labels = ([str(v) for v in first["output"].values], [str(v) for v in first["input"].values])
        check_answer(device.measure(self.reference_bias(device), f), f, labels)

    def test_follows_device_protocol(self, device: Device) -> None:
        """The device has every attribute of the protocol, and ``measure`` is callable."""
        assert isinstance(device, Device), (
            "the device lacks one of electrodes, bias_limits, structure_potential, band_hz, "
            "measure (see sysid_core.plugin.interfaces.Device)"
        )
        assert callable(device.measure)

    def test_electrodes(self, device: Device) -> None:
        """``electrodes``: a non-empty sequence of unique, non-empty strings."""
        electrodes = device.electrodes
        assert isinstance(electrodes, Sequence) and not isinstance(electrodes, str), (
            f"electrodes must be a sequence of names, got {electrodes!r}"
        )
        assert len(electrodes) >= 1, "a tunable device has at least one bias electrode"
        assert all(isinstance(e, str) and e for e in electrodes), (
            f"names must be strings: {electrodes!r}"
        )
        assert len(set(electrodes)) == len(electrodes), f"electrode names repeat: {electrodes!r}"

    def test_bias_limits_ordered(self, device: Device) -> None:
        """``bias_limits``: a ``(low, high)`` tuple of finite numbers, ``low < high``."""
        limits = device.bias_limits
        assert isinstance(limits, tuple) and len(limits) == 2, (
            f"bias_limits must be a (low, high) tuple, got {limits!r}"
        )
        low, high = limits
        assert is_real(low) and is_real(high), f"bias_limits must be numbers, got {limits!r}"
        assert math.isfinite(low) and math.isfinite(high), f"bias_limits must be finite: {limits!r}"
        assert low < high, f"bias_limits must be ordered (low < high), got {limits!r}"

    def test_structure_potential(self, device: Device) -> None:
        """``structure_potential``: a finite number."""
        v = device.structure_potential
        assert is_real(v) and math.isfinite(v), (
            f"structure_potential must be a finite number: {v!r}"
        )

    def test_band_ordered_and_positive(self, device: Device) -> None:
        """``band_hz``: a ``(low, high)`` tuple of finite numbers, ``0 < low < high``."""
        band = device.band_hz
        assert isinstance(band, tuple) and len(band) == 2, (
            f"band_hz must be a (low, high) tuple, got {band!r}"
        )
        low, high = band
        assert is_real(low) and is_real(high), f"band_hz must be numbers, got {band!r}"
        assert math.isfinite(low) and math.isfinite(high), f"band_hz must be finite: {band!r}"
        assert 0 < low < high, f"band_hz must be positive and ordered, got {band!r}"

    # ------------------------------------------------------------- measure
    def test_measure_schema(self, device: Device) -> None:
        """``measure`` gives a finite complex 2×2 response at exactly the requested frequencies."""
        rng = np.random.default_rng(12345)
        low, high = device.band_hz
        f = np.sort(rng.uniform(low, high, 37))  # an irregular grid: returned exactly
        result = device.measure(self.reference_bias(device), f)
        assert isinstance(result, xr.DataArray), (
            f"measure must return a DataArray, got {type(result)}"
        )
        assert tuple(result.dims) == _DIMS, f"dims must be {_DIMS}, got {tuple(result.dims)}"
        assert np.iscomplexobj(result.values), f"the response must be complex, got {result.dtype}"
        assert result.shape == (f.size, 2, 2), (
            f"expected shape ({f.size}, 2, 2), got {result.shape}"
        )
        assert "frequency" in result.coords, "the frequency coordinate (Hz) is missing"
        assert np.array_equal(np.asarray(result["frequency"].values, dtype=float), f), (
            "the frequency coordinate must be exactly the requested frequencies"
        )
        assert np.all(np.isfinite(result.values)), "the response has NaN or infinite values"

    def test_measure_accepts_list_and_array(self, device: Device) -> None:
        """``measure`` takes the bias as a list, a tuple or an array."""
        f = self.frequencies(device, 5)
        bias = self.reference_bias(device)
        for given in (list(bias), tuple(bias), np.asarray(bias, dtype=float)):
            # deliberately beyond the protocol's Sequence[float]: devices must take arrays too
            result = device.measure(given, f)  # type: ignore[arg-type]
            assert result.shape == (5, 2, 2)

    def test_resonance_in_band(self, device: Device) -> None:
        """The in-band peak exceeds the band edges' magnitude by :attr:`resonance_ratio`."""
        f = self.frequencies(device, self.band_points)
        magnitude = self._peak(device.measure(self.reference_bias(device), f))
        edges = max(magnitude[0], magnitude[-1])
        inside = magnitude[1:-1].max()
        assert inside > self.resonance_ratio * edges, (
            f"no resonance in band_hz {device.band_hz}: in-band peak {inside:.3g} vs band-edge "
            f"magnitude {edges:.3g} (need a ratio above {self.resonance_ratio})"
        )

    def test_repeatable(self, device: Device) -> None:
        """Two measurements at one bias agree within :attr:`repeat_tolerance` of the peak."""
        f = self.frequencies(device, 61)
        bias = self.reference_bias(device)
        first = np.asarray(device.measure(bias, f).values)
        second = np.asarray(device.measure(bias, f).values)
        scale = np.abs(first).max()
        worst = np.abs(first - second).max()
        assert worst <= self.repeat_tolerance * scale, (
            f"two measurements at the same bias differ by {worst:.3g}, more than "
            f"{self.repeat_tolerance} of the peak {scale:.3g}"
        )

    # -------------------------------------------------------- ground truth
    def test_true_modal_frequencies(self, device: Device) -> None:
        """A simulated device's true modes: two finite, ascending frequencies inside ``band_hz``."""
        if not isinstance(device, SimulatedDevice):
            pytest.skip("the device has no true_modal_frequencies_hz (real hardware)")
        f = np.asarray(device.true_modal_frequencies_hz(self.reference_bias(device)), dtype=float)
        assert f.shape == (2,), f"expected two modal frequencies, got shape {f.shape}"
        assert np.all(np.isfinite(f)), f"modal frequencies must be finite: {f}"
        assert f[0] <= f[1], f"modal frequencies must be ascending: {f}"
        low, high = device.band_hz
        margin = self.band_margin * (high - low)
        assert low - margin <= f[0] and f[1] <= high + margin, (
            f"true modes {f} Hz are not inside band_hz {device.band_hz}"
        )

    # ------------------------------------------------------------ optional
    def test_refuses_bias_outside_limits(self, device: Device) -> None:
        """With :attr:`checks_bias_limits`, ``measure`` refuses a bad bias with BiasLimitError."""
        if not self.checks_bias_limits:
            pytest.skip("checks_bias_limits is False: the device relies on the core's check")
        low, high = device.bias_limits
        f = self.frequencies(device, 3)
        span = high - low
        good = self.reference_bias(device)
        for p in range(len(good)):
            for bad_value in (high + 0.01 * span, low - 0.01 * span, float("nan")):
                bad = list(good)
                bad[p] = bad_value
                with pytest.raises(BiasLimitError):
                    device.measure(bad, f)
        with pytest.raises(BiasLimitError):
            device.measure([*good, good[0]], f)
        if len(good) > 1:
            with pytest.raises(BiasLimitError):
                device.measure(good[:-1], f)

    def test_factory_rejects_unknown_option(self) -> None:
        """Building :meth:`device_factory` as the registry does rejects an unknown option."""
        factory = self.device_factory()
        if factory is None:
            pytest.skip("device_factory() returns None: option handling not tested")
        with pytest.raises(ConfigError, match="no_such_option_for_the_contract"):
            build("device", "under test", factory, {"no_such_option_for_the_contract": 1})
