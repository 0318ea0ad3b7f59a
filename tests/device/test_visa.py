"""The ``visa`` device through ``sysid instrument-sim``: real sockets, real PyVISA (pyvisa-py)."""

from __future__ import annotations

import json
import re
import signal
import socket
import subprocess
import sys
import time
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from installing import environment, start_sysid

from sysid_core.errors import ConfigError, DeviceError
from sysid_core.plugin.registry import get_registry
from sysid_core.run.config import parse_config
from sysid_core.run.pipeline import TuningRun

TUNING = {
    "criterion": "degenerate",
    "electrodes": ["B1", "B2"],
    "start_bias": [0.0, 0.0, 0.0],
    "max_iterations": 4,
}
EXPERIMENT = {"band_hz": [4385.0, 4445.0]}
DAC_STEP = 20.0 / 2**16  # the simulated cloverleaf's 16-bit DAC over ±10 V


def free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return int(s.getsockname()[1])


class Sim:
    """``sysid instrument-sim`` in a subprocess, on the given ports."""

    def __init__(self, ports: tuple[int, int], *args: str) -> None:
        self.ports = ports
        self.proc = subprocess.Popen(
            [
                sys.executable,
                "-m",
                "sysid_core.cli",
                "instrument-sim",
                "--device",
                "cloverleaf",
                "--seed",
                "1",
                "--analyzer-port",
                str(ports[0]),
                "--source-port",
                str(ports[1]),
                *args,
            ],
            stdout=subprocess.PIPE,
            stderr=subprocess.STDOUT,
            text=True,
            env=environment(),
        )
        assert self.proc.stdout is not None
        line = self.proc.stdout.readline()
        assert line.startswith("listening"), line + self.proc.stdout.read()

    def kill(self) -> None:
        self.proc.kill()
        self.proc.communicate(timeout=10)

    def stop(self) -> None:
        if self.proc.poll() is None:
            self.proc.send_signal(signal.SIGTERM)
        self.proc.communicate(timeout=10)


@pytest.fixture
def sim() -> Iterator[Sim]:
    s = Sim((free_port(), free_port()))
    yield s
    s.stop()


def visa_device(ports: tuple[int, int], **more: Any) -> dict[str, Any]:
    return {
        "name": "visa",
        "analyzer": f"TCPIP::127.0.0.1::{ports[0]}::SOCKET",
        "source": f"TCPIP::127.0.0.1::{ports[1]}::SOCKET",
        "electrodes": ["B1", "B2", "B3"],
        "bias_limits": [-10.0, 10.0],
        "structure_potential": 15.58,
        "band_hz": [4385.0, 4445.0],
        "bias_resolution": DAC_STEP,
        **more,
    }


def source_state(port: int) -> tuple[list[float], list[bool]]:
    """The simulated source's read-back voltages and output states, asked over PyVISA."""
    import pyvisa

    rm = pyvisa.ResourceManager("@py")
    inst = rm.open_resource(f"TCPIP::127.0.0.1::{port}::SOCKET")
    inst.read_termination = inst.write_termination = "\n"
    try:
        volts = [float(inst.query(f"MEAS:VOLT? (@{ch})")) for ch in (1, 2, 3)]
        on = [inst.query(f"OUTP? (@{ch})").strip() == "1" for ch in (1, 2, 3)]
    finally:
        inst.close()
        rm.close()
    return volts, on


def write_config(path: Path, device: dict[str, Any]) -> Path:
    lines = ["[device]"]
    for k, v in device.items():
        lines.append(f"{k} = {json.dumps(v)}")
    lines += ["[tuning]"] + [f"{k} = {json.dumps(v)}" for k, v in TUNING.items()]
    lines += ["[experiment]"] + [f"{k} = {json.dumps(v)}" for k, v in EXPERIMENT.items()]
    path.write_text("\n".join(lines) + "\n")
    return path


def sysid(*args: str) -> subprocess.Popen[str]:
    return start_sysid(*args)


def wait_for_files(folder: Path, n: int, timeout: float = 60.0) -> None:
    t0 = time.monotonic()
    while len(list(folder.rglob("exp*.nc"))) < n:
        assert time.monotonic() - t0 < timeout, "the run measured nothing"
        time.sleep(0.05)


# ------------------------------------------------------------------ a whole tuning
def test_tuning_through_the_instruments_ends_where_the_built_in_device_does(
    sim: Sim, tmp_path: Path
) -> None:
    reference = TuningRun(
        parse_config(
            {
                "device": {"name": "cloverleaf", "seed": 1},
                "tuning": TUNING,
                "experiment": EXPERIMENT,
            }
        ),
        tmp_path / "built-in",
        plots=False,
    ).run()
    cfg = parse_config(
        {"device": visa_device(sim.ports), "tuning": TUNING, "experiment": EXPERIMENT}
    )
    summary = TuningRun(cfg, tmp_path / "visa", plots=False).run()
    assert summary.converged
    np.testing.assert_allclose(summary.bias, reference.bias, rtol=0, atol=1e-3)
    assert summary.points == 2 * reference.points  # every frequency once per input (2 receivers)
    # the run ended: the source was ramped to 0 V and switched off
    volts, on = source_state(sim.ports[1])
    assert volts == [0.0, 0.0, 0.0] and on == [False, False, False]


# ------------------------------------------------------------------ safety
def test_a_source_that_reads_back_wrong_stops_the_run_naming_the_electrode(
    tmp_path: Path,
) -> None:
    ports = (free_port(), free_port())
    sim = Sim(ports, "--readback-error", "2:0.05")
    try:
        cfg = parse_config(
            {"device": visa_device(ports), "tuning": TUNING, "experiment": EXPERIMENT}
        )
        with pytest.raises(
            DeviceError, match=r"electrode B2 reads back .* the outputs were set safe"
        ):
            TuningRun(cfg, tmp_path / "run", plots=False).run()
        volts, on = source_state(ports[1])
        assert on == [False, False, False]
        assert volts[0] == volts[2] == 0.0
    finally:
        sim.stop()


def test_bias_outside_the_limits_is_never_sent(sim: Sim) -> None:
    dev = get_registry().device(
        "visa", **{k: v for k, v in visa_device(sim.ports).items() if k != "name"}
    )
    with pytest.raises(Exception, match="outside"):
        dev.measure([11.0, 0.0, 0.0], np.array([4400.0, 4410.0]))
    volts, on = source_state(sim.ports[1])
    assert on == [False, False, False] and volts == [0.0, 0.0, 0.0]


def test_a_lost_simulator_is_one_line_then_resume_completes(tmp_path: Path) -> None:
    ports = (free_port(), free_port())
    cfg = write_config(tmp_path / "visa.toml", visa_device(ports))
    out = tmp_path / "run"
    first = Sim(ports, "--dwell-ms", "5")
    run = sysid("tune", str(cfg), "--out", str(out), "--no-plots")
    try:
        wait_for_files(out, 2)
        first.kill()
        _, err = run.communicate(timeout=120)
    finally:
        run.kill()
    assert run.returncode == 1
    errors = [line for line in err.strip().splitlines() if line.startswith("sysid: error:")]
    assert len(errors) == 1 and err.strip().endswith(errors[0]) and "Traceback" not in err
    assert errors[0].startswith("sysid: error: visa: the ") and "--resume" in errors[0], err
    again = Sim(ports)
    try:
        resumed = sysid("tune", str(cfg), "--out", str(out), "--no-plots", "--resume", "--json")
        stdout, err = resumed.communicate(timeout=180)
    finally:
        again.stop()
    assert resumed.returncode == 0, err
    assert json.loads(stdout.strip().splitlines()[-1])["converged"] is True


def test_ctrl_c_leaves_the_source_at_the_safe_value(tmp_path: Path) -> None:
    ports = (free_port(), free_port())
    sim = Sim(ports, "--dwell-ms", "5")
    try:
        cfg = write_config(tmp_path / "visa.toml", visa_device(ports))
        out = tmp_path / "run"
        run = sysid("tune", str(cfg), "--out", str(out), "--no-plots")
        wait_for_files(out, 2)
        run.send_signal(signal.SIGINT)
        _, err = run.communicate(timeout=60)
        assert run.returncode == 130, err
        assert "--resume" in err
        volts, on = source_state(ports[1])
        assert on == [False, False, False] and volts == [0.0, 0.0, 0.0]
    finally:
        sim.stop()


# ------------------------------------------------------------------ profiles
def test_profiles_are_checked_when_the_device_is_made(tmp_path: Path) -> None:
    bad = tmp_path / "mine.toml"
    bad.write_text(
        'kind = "source"\nname = "mine"\n[commands]\nset = "VOLT {volt},(@{channel})"\n'
        'measure = "MEAS:VOLT? (@{channel})"\noutput_on = "OUTP ON"\noutput_off = "OUTP OFF"\n'
    )
    options = {k: v for k, v in visa_device((1, 2)).items() if k != "name"}
    with pytest.raises(
        ConfigError, match=r"command set = .* uses \{volt\}; its fields: channel, volts"
    ):
        get_registry().device("visa", **options, source_profile=str(bad))
    with pytest.raises(ConfigError, match=r"no analyzer profile .nope.*keysight-ena"):
        get_registry().device("visa", **options, analyzer_profile="nope")
    good = tmp_path / "good.toml"
    good.write_text(bad.read_text().replace("{volt}", "{volts}"))
    dev = get_registry().device("visa", **options, source_profile=str(good))
    assert dev.sprof.name == "mine"


def test_the_simulator_refuses_a_port_in_use() -> None:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        s.listen()
        busy = s.getsockname()[1]
        proc = subprocess.run(
            [
                sys.executable,
                "-m",
                "sysid_core.cli",
                "instrument-sim",
                "--analyzer-port",
                str(busy),
            ],
            capture_output=True,
            text=True,
            env=environment(),
            timeout=60,
        )
    assert proc.returncode == 1
    assert re.fullmatch(r"sysid: error: cannot listen on .*choose other ports\n", proc.stderr)


def test_an_instrument_error_is_a_one_line_device_error(sim: Sim, tmp_path: Path) -> None:
    """The analyzer does not know a parameter: its SYST:ERR? message stops the run."""
    from sysid_visa.profiles import SHIPPED

    mine = tmp_path / "mine.toml"
    mine.write_text((SHIPPED / "keysight-ena.toml").read_text().replace('"S42"', '"S99"'))
    cfg = parse_config(
        {
            "device": visa_device(sim.ports, analyzer_profile=str(mine)),
            "tuning": TUNING,
            "experiment": EXPERIMENT,
        }
    )
    with pytest.raises(
        DeviceError, match=r"the analyzer reports '-224,\"Illegal parameter value\"'"
    ):
        TuningRun(cfg, tmp_path / "run", plots=False).run()
    volts, on = source_state(sim.ports[1])
    assert on == [False, False, False] and volts == [0.0, 0.0, 0.0]  # closed: made safe
