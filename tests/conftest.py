"""Fixtures and hooks of the test suite.

Helpers live in ``truths.py``, ``installing.py`` and ``exports.py`` (files as instruments and
MATLAB write them).
"""

from __future__ import annotations

from collections.abc import Iterator
from pathlib import Path

import pytest
from installing import install, remove_all
from truths import OUTPUT_LOWPASS, cloverleaf_truth

from sysid_core.device.simulation import GyroTruth


@pytest.fixture(scope="session")
def in_class_truth() -> GyroTruth:
    return cloverleaf_truth()


@pytest.fixture(scope="session")
def realistic_truth() -> GyroTruth:
    """Out of class: the cloverleaf's output low-passes (1 degree differential phase, 4430 Hz)."""
    return cloverleaf_truth(h_out=OUTPUT_LOWPASS)


# ------------------------------------------------------------------ third-party plugin packages
ROOT = Path(__file__).resolve().parents[1]


@pytest.fixture(scope="session")
def example_plugin() -> Iterator[Path]:
    """The docs' example device package, installed for this session only (tests/installing.py)."""
    yield install(ROOT / "docs" / "examples" / "sysid-example-device", "sysid-example-device")


@pytest.fixture(scope="session")
def example_format() -> Iterator[Path]:
    """The docs' example format package (.npz sweeps), installed for this session only."""
    yield install(ROOT / "docs" / "examples" / "sysid-example-format", "sysid-example-format")


@pytest.fixture(scope="session")
def faulty_plugin() -> Iterator[Path]:
    """The fault-injecting device package, installed for this session only."""
    yield install(ROOT / "tests" / "plugins" / "sysid-faulty-device", "sysid-faulty-device")


def pytest_sessionfinish(session: pytest.Session, exitstatus: int) -> None:
    remove_all()
