"""Faults of devices: a device that hangs, answers late or answers nonsense.

A timed-out device does not keep the process alive, an abandoned call cannot write into the run,
and an invalid answer is kept aside (``rejected/``), never measured, and measured again on
resume. The faulty device is a plugin package (``tests/plugins/sysid-faulty-device``) installed
the way a third party's is.
"""

from __future__ import annotations

import time
from pathlib import Path

import numpy as np
import pytest
from faulting import (
    one_error_line,
    sysid,
    tables,
)
from truths import write_toml

from sysid_core.data.schema import load_dataset
from sysid_core.errors import (
    DeviceError,
    InvalidAnswerError,
    RunFolderError,
)
from sysid_core.plugin.registry import get_registry
from sysid_core.run.config import parse_config
from sysid_core.run.pipeline import TuningRun


def test_timed_out_device_does_not_keep_the_process_alive(tmp_path: Path) -> None:
    cfg = write_toml(
        tmp_path / "c.toml",
        tables(device={"fault": "hang", "on_call": 2, "hang_s": 600}, experiment={"timeout_s": 2}),
    )
    t0 = time.monotonic()
    done = sysid("tune", str(cfg), "--out", str(tmp_path / "run"), "--no-plots", timeout=60)
    assert time.monotonic() - t0 < 30
    assert done.returncode == 1
    assert "did not answer within 2" in one_error_line(done.stderr)
    assert [p.name for p in (tmp_path / "run" / "iter01").glob("*.nc")] == ["exp0.nc"]


def test_abandoned_call_cannot_write_into_the_run(tmp_path: Path) -> None:
    # a first answer in a cold process (imports, caches) may take longer than the 0.3 s timeout
    # under load: it is made here, outside the timed calls
    get_registry().device("faulty-gyro", seed=1).measure([0.0] * 3, np.linspace(4400, 4410, 11))
    cfg = parse_config(
        tables(device={"fault": "slow", "on_call": 2, "hang_s": 1.5}, experiment={"timeout_s": 0.3})
    )
    run = TuningRun(cfg, tmp_path / "run", plots=False)
    with pytest.raises(DeviceError, match=r"did not answer within 0\.3"):
        run.run()
    time.sleep(2.0)  # the abandoned call has now returned its answer
    assert sorted(p.name for p in (tmp_path / "run").rglob("*.nc")) == ["exp0.nc"]
    with pytest.raises(DeviceError, match="timed out earlier"):
        run.device.measure([0.0, 0.0, 0.0], np.linspace(4400, 4410, 11))


@pytest.mark.parametrize(
    ("fault", "on_call", "reason"),
    [
        ("real", 1, "not complex"),
        ("zero", 1, "all zero"),
        ("nan", 1, "non-finite"),
        ("frequencies", 1, "other frequencies than requested"),
        ("shape", 1, "shape"),
        ("labels", 2, "earlier answers had"),
        ("type", 1, "not an xarray.DataArray"),
    ],
)
def test_invalid_answers_are_kept_aside_not_measured(
    tmp_path: Path, fault: str, on_call: int, reason: str
) -> None:
    cfg = parse_config(tables(device={"fault": fault, "on_call": on_call}))
    out = tmp_path / "run"
    with pytest.raises(InvalidAnswerError, match=reason):
        TuningRun(cfg, out, plots=False).run()
    measured = sorted(p.name for p in (out / "iter01").glob("*.nc"))
    assert measured == [f"exp{k}.nc" for k in range(on_call - 1)]
    kept = sorted(p.name for p in (out / "rejected").iterdir())
    assert f"iter01-exp{on_call - 1}-1.txt" in kept
    assert reason in (out / "rejected" / f"iter01-exp{on_call - 1}-1.txt").read_text()


def test_resume_measures_a_rejected_answer_again(tmp_path: Path) -> None:
    once = tmp_path / "fired"
    cfg = parse_config(tables(device={"fault": "real", "on_call": 2, "once_file": str(once)}))
    out = tmp_path / "run"
    with pytest.raises(InvalidAnswerError):
        TuningRun(cfg, out, plots=False).run()
    with pytest.raises(RunFolderError, match="already holds a run"):
        TuningRun(cfg, out, plots=False)
    summary = TuningRun(cfg, out, resume=True, plots=False).run()
    assert summary.iterations == 1 and summary.experiments >= 4
    assert load_dataset(out / "iter01" / "exp1.nc")["response"].dtype.kind == "c"
