"""The command line as documented: every error class in docs/errors.md, ``sysid fit`` options.

The fault tests of every kind (files, devices, configurations, signals, claims, outputs) are in
``tests/faults/``.
"""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from sysid_core.cli import main

EXAMPLE_DATA = Path(__file__).resolve().parents[2] / "examples" / "cloverleaf-3exp.nc"


def test_every_error_class_is_documented() -> None:
    import sysid_core.errors

    text = (Path(__file__).resolve().parents[2] / "docs" / "errors.md").read_text()
    missing = [name for name in sysid_core.errors.__all__ if f"`{name}`" not in text]
    assert not missing, f"not in docs/errors.md: {missing}"


def test_fit_stiffness_option(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    """``sysid fit --stiffness``: a bad law is one line naming the option; the default is the
    toolkit's (``auto``), which keeps the linear law on this one-sided design and says so."""
    data = tmp_path / "d.nc"
    data.write_bytes(EXAMPLE_DATA.read_bytes())
    assert main(["fit", str(data), "--stiffness", "cubic"]) == 1
    err = capsys.readouterr().err.strip().splitlines()
    assert err == ["sysid: error: --stiffness cubic: use one of linear, quadratic, auto"]
    assert not (tmp_path / "d.model.nc").exists()
    assert main(["fit", str(data), "--json"]) == 0
    line = json.loads(capsys.readouterr().out.strip().splitlines()[-1])
    assert line["stiffness_law"] == "linear" and line["order"] == 2
    assert main(["fit", str(data), "--stiffness", "quadratic", "--force"]) == 1
    assert "rank condition" in capsys.readouterr().err
