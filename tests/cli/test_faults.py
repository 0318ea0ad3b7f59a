"""Fault catalogue: every bad input and fault found by QA behaves as the toolkit promises.

Exit status 0 only on success, 2 for usage errors, 130 on Ctrl-C (with how to resume), 1 with one
line ``sysid: error: ...`` otherwise; no hang; nothing the user has is lost; everything checked
before the first measurement; no claim of a tuning without evidence. Where the exit status or
the process matters, the real CLI runs in a subprocess. The faulty device is a plugin package
(``tests/plugins/sysid-faulty-device``) installed the way a third party's is.
"""

from __future__ import annotations

import json
import os
import signal
import stat
import subprocess
import sys
import time
import warnings
from pathlib import Path
from typing import Any

import numpy as np
import pytest
import xarray as xr
from installing import environment, start_sysid
from truths import write_toml

from sysid_core.api import fit
from sysid_core.cli import main
from sysid_core.data.schema import load_dataset, save_dataset
from sysid_core.errors import (
    DataError,
    DeviceError,
    FitWarning,
    InvalidAnswerError,
    RunFolderError,
    UnreachableTuningError,
)
from sysid_core.plugin.interfaces import Goal
from sysid_core.plugin.registry import get_registry
from sysid_core.run.config import parse_config
from sysid_core.run.pipeline import TuningRun

EXAMPLE_DATA = Path(__file__).resolve().parents[2] / "examples" / "cloverleaf-3exp.nc"
FAST = {"resolution_hz": 1.0, "verify_resolution_hz": 0.02}
TUNE = {"criterion": "degenerate", "electrodes": ["B1", "B2"], "start_bias": [0.0, 0.0, 0.0]}


@pytest.fixture(scope="module", autouse=True)
def _faulty(faulty_plugin: Path) -> None:
    """Every test here may use the faulty-gyro device."""


def tables(
    device: dict[str, Any] | None = None,
    tuning: dict[str, Any] | None = None,
    experiment: dict[str, Any] | None = None,
    **more: dict[str, Any],
) -> dict[str, dict[str, Any]]:
    return {
        "device": {"name": "faulty-gyro", "seed": 1, **(device or {})},
        "tuning": {**TUNE, "max_iterations": 1, **(tuning or {})},
        "experiment": {**FAST, **(experiment or {})},
        **more,
    }


def sysid(*args: str, timeout: float = 120, **kw: Any) -> subprocess.CompletedProcess[str]:
    return subprocess.run(
        [sys.executable, "-m", "sysid_core.cli", *args],
        capture_output=True,
        text=True,
        timeout=timeout,
        env=environment(),
        check=False,
        **kw,
    )


def one_error_line(stderr: str) -> str:
    lines = [x for x in stderr.strip().splitlines() if x.strip()]
    assert "Traceback" not in stderr, stderr
    assert lines and lines[-1].startswith("sysid: error: "), stderr
    return lines[-1]


def start(args: list[str], **kw: Any) -> subprocess.Popen[str]:
    return start_sysid(*args, **kw)  # SIGINT reaches it even if this runs in the background


def wait_for(path: Path, proc: subprocess.Popen[str], timeout: float = 60) -> None:
    t0 = time.monotonic()
    while not path.exists():
        if proc.poll() is not None:
            pytest.fail(f"the process ended early: {proc.communicate()}")
        if time.monotonic() - t0 > timeout:
            proc.kill()
            pytest.fail(f"{path} did not appear within {timeout} s")
        time.sleep(0.05)


# ------------------------------------------------------------- 1. no claim without evidence
def test_target_out_of_reach_is_not_claimed_and_the_modes_are_located(tmp_path: Path) -> None:
    """QA's case: target 4390 Hz claimed "converged", true modes 20.8 Hz apart."""
    cfg = parse_config(
        {
            "device": {"name": "cloverleaf", "seed": 1},
            "tuning": {
                "criterion": "target",
                "target_hz": 4390.0,
                "max_iterations": 2,
                "acceptance_hz": 0.05,
            },
            "experiment": FAST,
        }
    )
    run = TuningRun(cfg, tmp_path / "run", plots=False)
    with pytest.raises(UnreachableTuningError, match="4390"):
        run.run()
    summary = json.loads((tmp_path / "run" / "summary.json").read_text())
    assert summary["converged"] is False
    first = summary["history"][0]
    truth = run.device.device.true_modal_frequencies_hz(first["verified_bias"])
    assert np.ptp(truth) > 15  # far from a tuning
    assert first["verification"] == "located"  # only a whole-band sweep found the modes
    np.testing.assert_allclose(first["measured_frequencies_hz"], truth, atol=0.1)
    assert first["evidence"][-1]["band"] and first["evidence"][-1]["ok"]


@pytest.mark.parametrize("criterion", ["degenerate", "min-max-bias"])
def test_modes_far_from_the_prediction_are_never_a_false_success(
    tmp_path: Path, criterion: str
) -> None:
    """A bias law far from v**2: the first prediction misses; every claim is checked."""
    tuning = {"criterion": criterion, "max_iterations": 3, "acceptance_hz": 0.01}
    if criterion == "min-max-bias":
        tuning["electrodes"] = ["B1", "B2", "B3"]
    cfg = parse_config(tables(device={"warp": 0.06}, tuning=tuning))
    run = TuningRun(cfg, tmp_path / "run", plots=False)
    summary = run.run()
    gyro = run.device.device
    first = gyro.true_modal_frequencies_hz(summary.history[0].verified_bias)
    assert np.ptp(first) > 0.05  # the first iteration really missed (truth)
    for rec in summary.history:
        true = gyro.true_modal_frequencies_hz(rec.verified_bias)
        if rec.verification == "verified":
            np.testing.assert_allclose(rec.measured_frequencies_hz, true, atol=3e-3)
    if summary.converged:
        final = gyro.true_modal_frequencies_hz(summary.bias)
        assert np.ptp(final) <= 0.01 + 3e-3
    assert summary.converged == (
        summary.history[-1].verification == "verified"
        and summary.split_hz is not None
        and summary.split_hz <= 0.01
    )


def test_window_without_modes_is_not_evidence() -> None:
    """The single-bias fit of a window 10 Hz from both modes invents two modes inside it."""
    from sysid_cloverleaf import CloverleafGyro

    from sysid_core.data.schema import experiment_from_measurement
    from sysid_core.measure.evidence import assess_window

    gyro = CloverleafGyro(seed=1)

    def assess(bias: list[float], lo: float, hi: float, n: int, band: bool = False):
        f = np.linspace(lo, hi, n)
        v_gyro = gyro.structure_potential
        ds = experiment_from_measurement(gyro.measure(bias, f), bias, list(gyro.electrodes), v_gyro)
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", FitWarning)  # not the subject here
            model = fit(ds.isel(electrode=[]), "act", 1)
        return assess_window(ds, model, band=band)

    far = [-10.0, -10.0, -10.0]  # true modes 4392.6 / 4413.4 Hz
    assert not assess(far, 4403.4, 4404.4, 101).ok
    assert not assess(far, 4392.0, 4393.2, 121).ok  # one mode inside, the other 21 Hz away
    band = assess(far, 4385.0, 4445.0, 121, band=True)
    assert band.ok
    np.testing.assert_allclose(band.frequencies_hz, gyro.true_modal_frequencies_hz(far), atol=0.1)
    tuned = assess([2.0405, 4.3874, 0.0], 4429.5, 4430.5, 101)
    assert tuned.ok, tuned.failures()


def test_target_counts_only_with_its_frequency_error(tmp_path: Path) -> None:
    goals = _target_goals([4430.004, 4430.005], target=4430.0, tolerance=1e-3)
    assert [g.name for g in goals] == ["split", "frequency error"]
    assert goals[0].met and not goals[1].met
    cfg = parse_config(
        {
            "device": {"name": "cloverleaf", "seed": 1},
            "tuning": {
                "criterion": "target",
                "target_hz": 4430.0,
                "max_iterations": 1,
                "tolerance_hz": 1e-4,
                "acceptance_hz": 0.5,
            },
            "experiment": FAST,
        }
    )
    summary = TuningRun(cfg, tmp_path / "run", plots=False).run()
    assert summary.verified and summary.split_hz < 0.5
    assert not summary.converged
    assert "frequency error" in summary.status and "goals not met" in summary.status


def _target_goals(freqs: list[float], target: float, tolerance: float) -> list[Goal]:
    crit = get_registry().criterion(
        "target", target_hz=target, tolerance_hz=tolerance, solver=get_registry().solver("clarabel")
    )
    return crit.goals(np.array(freqs), acceptance_hz=0.01)


# ---------------------------------------------------------------------- 2. exit codes
@pytest.mark.parametrize(
    ("args", "expect"),
    [
        (["fit"], "Missing argument"),
        (["fit", "x.nc", "--order", "abc"], "--order"),
        (["frobnicate"], "No such command"),
    ],
)
def test_usage_errors_exit_2_with_usage(args: list[str], expect: str) -> None:
    done = sysid(*args)
    assert done.returncode == 2, done.stderr
    assert "Usage:" in done.stderr and expect in done.stderr
    assert "internal error" not in done.stderr and "Traceback" not in done.stderr


def test_version_and_success_exit_0() -> None:
    done = sysid("--version")
    assert done.returncode == 0 and done.stdout.startswith("sysid ")


def test_ctrl_c_exits_130_with_how_to_resume_and_resume_works(tmp_path: Path) -> None:
    once = tmp_path / "fault-fired"
    cfg = write_toml(
        tmp_path / "c.toml",
        tables(device={"fault": "slow", "on_call": 2, "hang_s": 60, "once_file": str(once)}),
    )
    out = tmp_path / "run"
    proc = start(["tune", str(cfg), "--out", str(out), "--no-plots"])
    wait_for(out / "iter01" / "exp0.nc", proc)
    wait_for(once, proc)  # now inside the slow measurement
    proc.send_signal(signal.SIGINT)
    try:  # generous: on a loaded machine the interpreter may take a while to get scheduled
        _, err = proc.communicate(timeout=90)
    finally:
        if proc.poll() is None:  # never leak the process into later tests
            proc.kill()
            proc.communicate()
    assert proc.returncode == 130, err
    last = err.strip().splitlines()[-1]
    assert last.startswith("sysid: interrupted") and "--resume" in last, err
    assert "Traceback" not in err
    done = sysid("tune", str(cfg), "--out", str(out), "--no-plots", "--resume")
    last = done.stderr.strip().splitlines()[-1]
    assert done.returncode == 0 or "error: NOT converged" in last, done.stderr  # it finished
    assert "measured earlier" in done.stderr
    assert json.loads((out / "summary.json").read_text())["iterations"] == 1


@pytest.mark.parametrize("delay_s", [0.3, 0.8])
def test_ctrl_c_while_the_program_starts_is_one_line_not_a_traceback(delay_s: float) -> None:
    """The ``sysid`` script interrupted during its imports (numpy, xarray, the plugins): one
    line, the interrupt's exit status, no traceback (sysid_core._launch)."""
    from installing import default_sigint

    script = Path(sys.executable).parent / "sysid"
    if not script.exists():
        pytest.skip("no sysid script next to this interpreter")
    proc = subprocess.Popen(
        [str(script), "--help"],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
        env=environment(),
        preexec_fn=default_sigint,
    )
    time.sleep(delay_s)
    proc.send_signal(signal.SIGINT)
    _, err = proc.communicate(timeout=60)
    if proc.returncode == 0:
        pytest.skip("the program had started before the interrupt (a fast machine)")
    assert proc.returncode in (130, -signal.SIGINT), err
    assert "Traceback" not in err and err.strip().splitlines() == [
        "sysid: interrupted while starting; nothing was done"
    ], err


def test_a_failure_is_one_line_and_exit_1(tmp_path: Path) -> None:
    cfg = write_toml(tmp_path / "c.toml", tables(device={"fault": "raise", "on_call": 2}))
    done = sysid("tune", str(cfg), "--out", str(tmp_path / "run"), "--no-plots")
    assert done.returncode == 1
    line = one_error_line(done.stderr)
    assert "lost the connection to the analyzer" in line


# --------------------------------------------------------------------------- 3. no hang
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


# ----------------------------------------------------------------- 4. nothing is lost
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


# ------------------------------------------------- 5. checked before the first measurement
@pytest.mark.parametrize(
    ("change", "message"),
    [
        ({"experiment": {"band_hz": [4445.0, 4385.0]}}, "[experiment] band_hz"),
        ({"experiment": {"resolution_hz": 1e-6}}, "max_points"),
        ({"experiment": {"band_hz": [1.0, 2.0], "resolution_hz": 0.05}}, "does not overlap"),
        ({"experiment": {"band_hz": [4400.0, 4400.2], "resolution_hz": 0.5}}, "at least 11"),
        ({"solver": {"name": "clarabel", "max_iter": "x"}}, "option 'max_iter' of solver"),
        ({"solver": {"name": "scs", "max_iters": 2.5}}, "option 'max_iters' of solver 'scs'"),
        ({"objective": {"name": "minimax", "tie_tol": "x"}}, "option 'tie_tol' of objective"),
        ({"model": {"objective": "minimax"}}, "[model] objective has moved to [objective] name"),
        (
            {"tuning": {"options": {"bias_tol": -1.0}, "criterion": "min-max-bias"}},
            "option 'bias_tol' of tuning criterion 'min-max-bias' must be a finite number > 0",
        ),
        ({"device": {"structure_potential": "abc"}}, "'structure_potential'"),
        ({"device": {"broken": "electrodes"}}, "'electrodes' must be a non-empty"),
        ({"device": {"broken": "limits"}}, "'bias_limits' must be two finite numbers"),
        ({"tuning": {"start_bias": [0.0, 20.0, 0.0]}}, "outside the device's limits"),
        (
            {"tuning": {"target_hz": 4430.0, "criterion": "target", "tolerance_hz": -1}},
            "tolerance_hz",
        ),
    ],
)
def test_bad_settings_fail_before_measuring_and_leave_nothing(
    tmp_path: Path, change: dict[str, dict[str, Any]], message: str
) -> None:
    t = tables(device={"fault": "raise"})  # a measurement would fail differently
    for table, values in change.items():
        t[table] = {**t.get(table, {}), **values}
    cfg = write_toml(tmp_path / "c.toml", t)
    out = tmp_path / "run"
    done = sysid("tune", str(cfg), "--out", str(out), "--no-plots")
    assert done.returncode == 1
    line = one_error_line(done.stderr)
    assert message in line, line
    assert "lost the connection" not in line
    assert not out.exists()


def test_binary_config_is_named(tmp_path: Path) -> None:
    cfg = tmp_path / "c.toml"
    cfg.write_bytes(bytes(range(256)))
    done = sysid("tune", str(cfg))
    assert done.returncode == 1
    assert f"{cfg} is not a text file" in one_error_line(done.stderr)


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


# ------------------------------------------------------------------ 6. nonsense fits
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


def test_python_api_type_errors() -> None:
    ds = load_dataset(EXAMPLE_DATA)
    with pytest.raises(TypeError, match="structure must be a name"):
        fit(ds, 123)  # type: ignore[arg-type]
    with pytest.raises(TypeError, match=r"xarray\.Dataset"):
        fit("examples/cloverleaf-3exp.nc")  # type: ignore[arg-type]


# ---------------------------------------------------------------- 9. pipes and logs
def test_piped_output_is_not_cut() -> None:
    done = sysid("plugins")
    assert done.returncode == 0
    assert "…" not in done.stdout
    listed = json.loads(sysid("plugins", "--json").stdout)["components"]
    rows = done.stdout.splitlines()
    for c in listed:
        wanted = (f" {c['kind']} ", f" {c['name']} ", c["distribution"], c["description"])
        assert any(all(w in row for w in wanted) for row in rows), (c, done.stdout)


# ------------------------------------------------------------------------------- docs
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
