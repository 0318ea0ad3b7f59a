"""Faults around the user's files: nothing the user has is lost or overwritten.

``sysid fit`` does not write over its input, a link or a device, nor over an output without
``--force``; ``--resume`` only continues a run; a second process in the same run folder is
refused; written files keep the user's umask. Nonsense data (all zero, constant, absurd
magnitudes) is named, not fitted silently.
"""

from __future__ import annotations

import json
import os
import stat
import warnings
from pathlib import Path
from typing import Any

import pytest
import xarray as xr
from faulting import (
    EXAMPLE_DATA,
    one_error_line,
    start,
    sysid,
    tables,
    wait_for,
)
from truths import write_toml

from sysid_core.api import fit
from sysid_core.cli import main
from sysid_core.data.schema import load_dataset, save_dataset
from sysid_core.errors import (
    DataError,
    FitWarning,
)


def test_fit_refuses_to_write_over_its_input_a_link_or_a_device(tmp_path: Path) -> None:
    data = tmp_path / "d.nc"
    data.write_bytes(EXAMPLE_DATA.read_bytes())
    before = data.read_bytes()
    assert main(["fit", str(data), "--out", str(data), "--force"]) == 1
    assert data.read_bytes() == before
    other = tmp_path / "other.nc"
    other.write_text("keep me")
    link = tmp_path / "link.nc"
    link.symlink_to(other)
    assert main(["fit", str(data), "--out", str(link), "--force"]) == 1
    assert link.is_symlink() and other.read_text() == "keep me"
    assert main(["fit", str(data), "--out", "/dev/null", "--force"]) == 1
    assert stat.S_ISCHR(os.stat("/dev/null").st_mode)


def test_fit_does_not_overwrite_without_force(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    data = tmp_path / "d.nc"
    data.write_bytes(EXAMPLE_DATA.read_bytes())
    model = tmp_path / "d.model.nc"
    model.write_text("an earlier model")
    assert main(["fit", str(data)]) == 1
    assert "already exists; pass --force" in capsys.readouterr().err
    assert model.read_text() == "an earlier model"
    assert main(["fit", str(data), "--force"]) == 0
    assert load_dataset(model)["M"].shape == (2, 2)


def test_resume_only_continues_a_run(tmp_path: Path) -> None:
    cfg = write_toml(tmp_path / "c.toml", tables())
    folder = tmp_path / "mine"
    folder.mkdir()
    (folder / "summary.json").write_text('{"mine": true}')
    for extra in ([], ["--resume"]):
        done = sysid("tune", str(cfg), "--out", str(folder), "--no-plots", *extra)
        assert done.returncode == 1
        assert "no sysid run" in one_error_line(done.stderr)
    assert json.loads((folder / "summary.json").read_text()) == {"mine": True}
    assert sorted(p.name for p in folder.iterdir()) == ["summary.json"]
    done = sysid("tune", str(cfg), "--out", str(tmp_path / "absent"), "--resume")
    assert done.returncode == 1 and "holds no run" in one_error_line(done.stderr)


def test_second_process_in_the_same_run_is_refused(tmp_path: Path) -> None:
    cfg = write_toml(
        tmp_path / "c.toml", tables(device={"fault": "hang", "on_call": 2, "hang_s": 60})
    )
    out = tmp_path / "run"
    first = start(["tune", str(cfg), "--out", str(out), "--no-plots"])
    try:
        wait_for(out / "iter01" / "exp0.nc", first)
        done = sysid("tune", str(cfg), "--out", str(out), "--no-plots", "--resume")
        assert done.returncode == 1
        assert "another sysid process is working in" in one_error_line(done.stderr)
    finally:
        first.kill()
        first.communicate()
    assert [p.name for p in (out / "iter01").glob("*.nc")] == ["exp0.nc"]


@pytest.mark.parametrize("umask", [0o022, 0o027])
def test_files_keep_the_users_umask(tmp_path: Path, umask: int) -> None:
    data = tmp_path / "d.nc"
    data.write_bytes(EXAMPLE_DATA.read_bytes())
    done = sysid(
        "fit", str(data), "--out", str(tmp_path / "m.nc"), preexec_fn=lambda: os.umask(umask)
    )
    assert done.returncode == 0, done.stderr
    assert stat.S_IMODE((tmp_path / "m.nc").stat().st_mode) == 0o666 & ~umask


def _scaled_example(tmp_path: Path, factor: complex | None = None, value: Any = None) -> Path:
    ds = load_dataset(EXAMPLE_DATA)
    if factor is not None:
        ds["response"] = ds["response"] * factor
    if value is not None:
        ds["response"] = xr.full_like(ds["response"], value)
    path = tmp_path / "bad.nc"
    save_dataset(ds, path)
    return path


def test_all_zero_data_is_an_error(tmp_path: Path) -> None:
    done = sysid("fit", str(_scaled_example(tmp_path, value=0j)))
    assert done.returncode == 1
    assert "all zero" in one_error_line(done.stderr)


def test_constant_data_warns(tmp_path: Path) -> None:
    # The paper's model (minimax, order 1, constant feedthrough) puts modes outside the band.
    path = _scaled_example(tmp_path, value=1 + 1j)
    done = sysid("fit", str(path), "--objective", "minimax", "--order", "1", "--bias-terms", "0")
    lines = [x for x in done.stderr.splitlines() if x.startswith("sysid: warning: ")]
    assert any("show no resonance" in w for w in lines), done.stderr
    assert any("outside the measured frequencies" in w for w in lines), done.stderr
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        fit(load_dataset(tmp_path / "bad.nc"), "act", 1, "least-squares")
    found = [str(w.message) for w in caught if issubclass(w.category, FitWarning)]
    assert any("no resonance" in m for m in found), found


def test_absurd_magnitudes_are_named(tmp_path: Path) -> None:
    with pytest.raises(DataError, match="outside the range"):
        fit(load_dataset(_scaled_example(tmp_path, factor=1e200)), "act")


def test_a_warning_that_is_not_the_toolkits_says_where_it_arose() -> None:
    from sysid_core.cli import _format_warning
    from sysid_core.errors import FitWarning

    own = _format_warning("no resonance", FitWarning, "/x/sysid_core/identification/fitting.py", 3)
    assert own == "sysid: warning: no resonance\n"
    other = _format_warning(
        "invalid value encountered in sqrt", RuntimeWarning, "/v/sysid_core/model/modal.py", 88
    )
    assert other == (
        "sysid: warning: invalid value encountered in sqrt "
        "(RuntimeWarning at sysid_core/model/modal.py:88)\n"
    )
