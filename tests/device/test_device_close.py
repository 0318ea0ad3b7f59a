"""A device's optional ``close()``: called when the run ends, fails or is interrupted."""

from __future__ import annotations

from pathlib import Path
from typing import Any, ClassVar

import pytest
import xarray as xr
from sysid_cloverleaf import CloverleafGyro

from sysid_core import hookimpl
from sysid_core.errors import DeviceError
from sysid_core.plugin.registry import Registry
from sysid_core.run.config import parse_config
from sysid_core.run.pipeline import TuningRun


class ClosingGyro(CloverleafGyro):
    """A cloverleaf that records ``close()`` calls; it may fail or be interrupted."""

    name: ClassVar[str] = "closing-gyro"
    closed: ClassVar[list[str]] = []

    def __init__(
        self, fail_on: int = 0, interrupt_on: int = 0, bad_close: bool = False, **kw: Any
    ) -> None:
        super().__init__(**kw)
        self.fail_on, self.interrupt_on, self.bad_close = fail_on, interrupt_on, bad_close
        self.calls = 0

    def measure(self, bias: Any, frequencies_hz: Any) -> xr.DataArray:
        self.calls += 1
        if self.calls == self.fail_on:
            raise RuntimeError("lost the analyzer")
        if self.calls == self.interrupt_on:
            raise KeyboardInterrupt
        return super().measure(bias, frequencies_hz)

    def close(self) -> None:
        ClosingGyro.closed.append("closed")
        if self.bad_close:
            raise OSError("the source does not answer")


class _Plugin:
    @hookimpl
    def sysid_devices(self) -> dict[str, Any]:
        return {ClosingGyro.name: ClosingGyro}


def run(tmp_path: Path, progress: Any = None, **device: Any) -> TuningRun:
    registry = Registry()
    registry.register(_Plugin(), name="closing", distribution="tests")
    cfg = parse_config(
        {
            "device": {"name": "closing-gyro", "seed": 1, **device},
            "tuning": {"criterion": "degenerate", "electrodes": ["B1", "B2"], "max_iterations": 1},
        }
    )
    ClosingGyro.closed.clear()
    return TuningRun(cfg, tmp_path / "run", registry=registry, plots=False, progress=progress)


def test_closed_when_the_run_ends(tmp_path: Path) -> None:
    run(tmp_path).run()
    assert ClosingGyro.closed == ["closed"]


@pytest.mark.parametrize("fault", ["fail_on", "interrupt_on"])
def test_closed_when_the_run_fails_or_is_interrupted(tmp_path: Path, fault: str) -> None:
    expected = DeviceError if fault == "fail_on" else KeyboardInterrupt
    with pytest.raises(expected):
        run(tmp_path, **{fault: 3}).run()
    assert ClosingGyro.closed == ["closed"]


def test_a_close_that_fails_is_an_error_only_when_nothing_else_failed(tmp_path: Path) -> None:
    with pytest.raises(DeviceError, match=r"could not be closed \(made safe\): OSError"):
        run(tmp_path, bad_close=True).run()
    messages: list[str] = []
    r = run(tmp_path / "b", messages.append, bad_close=True, fail_on=2)
    with pytest.raises(DeviceError, match="lost the analyzer"):
        r.run()
    assert any("could not be closed" in m for m in messages)


def test_a_device_passed_in_belongs_to_the_caller(tmp_path: Path) -> None:
    cfg = parse_config(
        {
            "device": {"name": "cloverleaf", "seed": 1},
            "tuning": {"criterion": "degenerate", "electrodes": ["B1", "B2"], "max_iterations": 1},
        }
    )
    ClosingGyro.closed.clear()
    TuningRun(cfg, tmp_path / "run", device=ClosingGyro(seed=1), plots=False).run()
    assert ClosingGyro.closed == []
