"""The run's bench (``Bench``): every measurement saved before it is used, counted (points,
acquisitions, bias changes), its bench time split by purpose, read back on resume instead of
measured again, and refused before the device is touched when the guard says so.

Truth: the simulated cloverleaf on a bench with a clock and no drift (the clock's own stamps).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from sysid_cloverleaf import CloverleafGyro

from sysid_core.clock.bench import Bench, purpose_of
from sysid_core.clock.runfolder import RunFolder
from sysid_core.data.schema import load_dataset
from sysid_core.device.measuring import GuardedDevice
from sysid_core.errors import BudgetSpentError

F = np.linspace(4425.0, 4436.0, 12)
ZERO = np.zeros(3)
STEP = np.array([1.0, 0.0, 0.0])


class Counting(CloverleafGyro):
    """The cloverleaf, counting the calls that reach it."""

    calls = 0

    def measure(self, bias, frequencies_hz):  # type: ignore[no-untyped-def]
        type(self).calls += 1
        return super().measure(bias, frequencies_hz)


def bench(folder: Path, device: CloverleafGyro, tones: int = 1, guard=None) -> Bench:  # type: ignore[no-untyped-def]
    guarded = GuardedDevice(device, "cloverleaf")
    return Bench(
        guarded,
        RunFolder(folder, "x"),
        list(device.electrodes),
        15.58,
        "cloverleaf",
        lambda line: None,
        owns_device=False,
        tones=tones,
        guard=guard,
    )


def test_a_measurement_is_saved_first_and_counted(tmp_path: Path) -> None:
    b = bench(tmp_path, CloverleafGyro(seed=1, bench={"clock": True}), tones=4)
    (tmp_path / "iter01").mkdir()
    ds = b.measure(ZERO, F, tmp_path / "iter01" / "exp0.nc")
    saved = load_dataset(tmp_path / "iter01" / "exp0.nc")
    np.testing.assert_array_equal(saved["response"].values, ds["response"].values)
    assert (b.measurements, b.points, b.acquisitions, b.bias_changes) == (1, 12, 3, 1)
    b.measure(ZERO, F, tmp_path / "iter01" / "verify.nc")  # same bias: no settling
    b.measure(STEP, F, tmp_path / "iter01" / "exp1.nc")
    assert (b.measurements, b.points, b.acquisitions, b.bias_changes) == (3, 36, 9, 2)
    # the clock's stamps: the time by purpose adds up to the span, settling and acquiring
    assert set(b.by_purpose) == {"design", "verification"}
    assert sum(b.by_purpose.values()) == pytest.approx(b.last_s - b.first_s)
    assert b.settling_s + b.acquiring_s == pytest.approx(b.last_s - b.first_s)
    assert b.settling_s > 0 and b.untimed == 0


def test_a_measurement_on_disk_is_read_not_measured_again(tmp_path: Path) -> None:
    (tmp_path / "iter01").mkdir()
    Counting.calls = 0
    first = bench(tmp_path, Counting(seed=1)).measure(ZERO, F, tmp_path / "iter01" / "exp0.nc")
    assert Counting.calls == 1
    again = bench(tmp_path, Counting(seed=1))  # a resumed run
    ds = again.measure(ZERO, F, tmp_path / "iter01" / "exp0.nc")
    assert Counting.calls == 1 and again.measurements == 1
    np.testing.assert_array_equal(ds["response"].values, first["response"].values)


def test_a_refused_measurement_touches_neither_the_device_nor_the_folder(tmp_path: Path) -> None:
    def spent(acquisitions: int, changes: bool) -> None:
        raise BudgetSpentError(f"{acquisitions} acquisitions would end past the budget")

    (tmp_path / "iter01").mkdir()
    Counting.calls = 0
    b = bench(tmp_path, Counting(seed=1), guard=spent)
    with pytest.raises(BudgetSpentError, match="12 acquisitions"):
        b.measure(ZERO, F, tmp_path / "iter01" / "exp0.nc")
    assert Counting.calls == 0 and not (tmp_path / "iter01" / "exp0.nc").exists()
    assert b.measurements == 0


@pytest.mark.parametrize(
    ("name", "purpose"),
    [
        ("exp0.nc", "design"),  # a probe too: it is the first design sweep
        ("exp3.nc", "design"),
        ("exp0-locate.nc", "locating"),
        ("exp0-zoom.nc", "locating"),  # windows around the modes a failed sweep placed
        ("exp2-zoom2.nc", "locating"),
        ("exp1-band.nc", "locating"),
        ("verify-fine.nc", "verification"),
        ("verify-pass2.nc", "repeats"),
        ("window-again.nc", "repeats"),
        ("model.nc", "other"),
    ],
)
def test_a_measurement_counts_for_what_its_file_says(name: str, purpose: str) -> None:
    assert purpose_of(name) == purpose


def test_points_are_measured_in_the_order_given_and_kept_in_frequency_order(
    tmp_path: Path,
) -> None:
    """A window measured least informative point first: the device sees that order, the data
    set holds the points by frequency with the stamps they were measured at, and a resumed run
    reads the same file back for the same points in any order."""
    seen: list[np.ndarray] = []

    class Recording(CloverleafGyro):
        def measure(self, bias, frequencies_hz):  # type: ignore[no-untyped-def]
            seen.append(np.array(frequencies_hz, dtype=float))
            return super().measure(bias, frequencies_hz)

    b = bench(tmp_path, Recording(seed=1, bench={"clock": True}))
    (tmp_path / "iter01").mkdir()
    order = F[[0, 11, 1, 10, 2, 9, 3, 8, 4, 7, 5, 6]]
    ds = b.measure(ZERO, order, tmp_path / "iter01" / "verify.nc")
    np.testing.assert_array_equal(seen[0], order)
    np.testing.assert_array_equal(ds["frequency"].values, F)
    t = ds["time_s"].values[0]
    assert np.all(np.diff(t[[0, 11, 1, 10, 2, 9, 3, 8, 4, 7, 5, 6]]) > 0)
    again = bench(tmp_path, Recording(seed=1, bench={"clock": True}))
    back = again.measure(ZERO, F[::-1], tmp_path / "iter01" / "verify.nc")
    assert len(seen) == 1
    np.testing.assert_array_equal(back["response"].values, ds["response"].values)
