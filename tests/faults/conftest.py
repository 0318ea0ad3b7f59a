"""The fault tests may use the faulty-gyro device (a plugin package installed for the session)."""

from __future__ import annotations

from pathlib import Path

import pytest


@pytest.fixture(scope="module", autouse=True)
def _faulty(faulty_plugin: Path) -> None:
    """Every fault test may use the faulty-gyro device."""
