"""The ``visa`` device with an analyzer that measures both outputs in one sweep (``receivers``),
and a lock-in that measures several frequencies per acquisition (``tones``).

The simulated instruments run in this process (:class:`sysid_visa.sim.InstrumentSim` on free
ports) so that their sweep counters can be read; the device talks to them over real sockets
with PyVISA (pyvisa-py).
"""

from __future__ import annotations

import re
import subprocess
import sys
import tomllib
from collections.abc import Iterator, Sequence
from pathlib import Path
from typing import Any

import numpy as np
import pytest
import xarray as xr
from installing import environment
from sysid_visa.device import VisaDevice
from sysid_visa.profiles import SHIPPED, AnalyzerProfile, load_profile
from sysid_visa.sim import InstrumentSim
from test_visa import EXPERIMENT, TUNING, Sim, free_port, visa_device

from sysid_core.errors import ConfigError
from sysid_core.plugin.registry import get_registry
from sysid_core.run.config import parse_config
from sysid_core.run.pipeline import TuningRun
from sysid_core.run.summary import RunSummary

FREQS = np.linspace(4400.0, 4410.0, 9)
BIAS = [1.0, 2.0, 0.0]
#: Relative precision of the simulated analyzer's numbers (13 significant digits).
SENT = 1e-11


class LoggingSim(InstrumentSim):
    """The simulated instruments, keeping every line the analyzer received."""

    def __init__(self, *args: Any, **kwargs: Any) -> None:
        super().__init__(*args, **kwargs)
        self.lines: list[str] = []

    def _analyzer(self, line: str) -> str | None:
        self.lines.append(line)
        return super()._analyzer(line)


class CountingVisa(VisaDevice):
    """The visa device, counting its measurements."""

    def __init__(self, **options: Any) -> None:
        super().__init__(**options)
        self.measurements = 0

    def measure(self, bias: Sequence[float], frequencies_hz: np.ndarray) -> xr.DataArray:
        self.measurements += 1
        return super().measure(bias, frequencies_hz)


def cloverleaf(tones: int = 1) -> Any:
    bench = {"bench": {"tones": tones}} if tones > 1 else {}
    return get_registry().device("cloverleaf", seed=1, **bench)


def options(ports: tuple[int, int], **more: Any) -> dict[str, Any]:
    return {k: v for k, v in visa_device(ports, **more).items() if k != "name"}


@pytest.fixture
def started() -> Iterator[list[InstrumentSim]]:
    """Simulators started by a test (``started.append(sim.start())``), stopped after it."""
    sims: list[InstrumentSim] = []
    yield sims
    for sim in sims:
        sim.stop()


def measure_once(
    started: list[InstrumentSim], profile: str, tones: int = 1, **more: Any
) -> tuple[xr.DataArray, LoggingSim, VisaDevice]:
    """One measurement at BIAS, FREQS through fresh simulated instruments (cloverleaf, seed 1)."""
    sim = LoggingSim(cloverleaf(tones), 0, 0)
    started.append(sim.start())
    dev = get_registry().device("visa", **options(sim.ports, analyzer_profile=profile, **more))
    assert isinstance(dev, VisaDevice)
    try:
        data = dev.measure(BIAS, FREQS)
    finally:
        dev.close()
    return data, sim, dev


@pytest.fixture(scope="module")
def reference(tmp_path_factory: pytest.TempPathFactory) -> RunSummary:
    """The tuning of the built-in cloverleaf (seed 1)."""
    cfg = parse_config(
        {"device": {"name": "cloverleaf", "seed": 1}, "tuning": TUNING, "experiment": EXPERIMENT}
    )
    return TuningRun(cfg, tmp_path_factory.mktemp("built-in"), plots=False).run()


# ------------------------------------------------------------------ sweeps per measurement
@pytest.mark.parametrize(("profile", "sweeps"), [("keysight-ena", 2), ("keysight-ena-1rx", 4)])
def test_a_tuning_sweeps_once_per_input_with_two_receivers_and_ends_where_the_built_in_does(
    started: list[InstrumentSim],
    reference: RunSummary,
    tmp_path: Path,
    profile: str,
    sweeps: int,
) -> None:
    sim = InstrumentSim(cloverleaf(), 0, 0)
    started.append(sim.start())
    config = visa_device(sim.ports, analyzer_profile=profile)
    dev = CountingVisa(**{k: v for k, v in config.items() if k != "name"})
    cfg = parse_config({"device": config, "tuning": TUNING, "experiment": EXPERIMENT})
    try:
        summary = TuningRun(cfg, tmp_path / "run", plots=False, device=dev).run()
    finally:
        dev.close()
    assert summary.converged
    assert dev.measurements >= 3
    assert sim.triggers == sweeps * dev.measurements
    assert dev.points_per_frequency == sweeps
    assert summary.points == sweeps * reference.points
    np.testing.assert_allclose(summary.bias, reference.bias, rtol=0, atol=1e-3)


def test_one_and_two_receivers_measure_the_same_data_in_four_and_two_sweeps(
    started: list[InstrumentSim],
) -> None:
    two, sim2, dev2 = measure_once(started, "keysight-ena")
    one, sim1, dev1 = measure_once(started, "keysight-ena-1rx")
    assert (sim2.triggers, sim1.triggers) == (2, 4)
    assert (dev2.points_per_frequency, dev1.points_per_frequency) == (2, 4)
    np.testing.assert_array_equal(two.values, one.values)
    # and both are the built-in device's own measurement (its first one, at the applied bias;
    # sent with 13 significant digits)
    built_in = cloverleaf().measure(two.attrs["applied_bias"], FREQS)
    np.testing.assert_allclose(two.values, built_in.values, rtol=SENT, atol=0)
    # every pair in its place: y_i/u_j read from trace i+1 of the sweep that drives u_j
    assert not np.array_equal(two.values[:, 0, 0], two.values[:, 1, 0])
    # the stamps average the sweeps made: increasing, one per point
    stamps = two.coords["time_s"].values
    assert stamps.shape == FREQS.shape and np.all(np.diff(stamps) > 0)


def test_the_ena_profile_defines_two_traces_and_reads_each_after_one_sweep(
    started: list[InstrumentSim],
) -> None:
    _, sim, _ = measure_once(started, "keysight-ena")
    lines = [x for x in sim.lines if x != "SYST:ERR?"]
    assert ":CALC1:PAR:COUN 2" in lines[: lines.index("*IDN?") + 8]
    after = lines[[x.startswith(":SENS1:SEGM:DATA ") for x in lines].index(True) + 1 :]
    one_sweep = [":TRIG:SING", "*OPC?", ":CALC1:PAR1:SEL", ":CALC1:DATA:SDAT?"]
    one_sweep += [":CALC1:PAR2:SEL", ":CALC1:DATA:SDAT?"]
    assert after == [
        *[":CALC1:PAR1:DEF S31", ":CALC1:PAR2:DEF S41", *one_sweep],
        *[":CALC1:PAR1:DEF S32", ":CALC1:PAR2:DEF S42", *one_sweep],
    ]


def test_points_per_frequency_and_tones_come_from_the_profile_and_the_options(
    tmp_path: Path,
) -> None:
    registry = get_registry()
    two = registry.device("visa", **options((1, 2)))
    one = registry.device("visa", **options((1, 2), analyzer_profile="keysight-ena-1rx"))
    assert isinstance(two, VisaDevice) and isinstance(one, VisaDevice)
    assert (two.receivers, two.points_per_frequency, two.tones) == (2, 2, 1)
    assert (one.receivers, one.points_per_frequency, one.tones) == (1, 4, 1)
    lock_in = tmp_path / "lock-in.toml"
    lock_in.write_text(
        (SHIPPED / "keysight-ena.toml").read_text().replace("tones = 1 ", "tones = 6 ")
    )
    mine = registry.device("visa", **options((1, 2), analyzer_profile=str(lock_in)))
    assert getattr(mine, "tones", None) == 6
    told = registry.device("visa", **options((1, 2), analyzer_profile=str(lock_in), tones=3))
    assert getattr(told, "tones", None) == 3
    with pytest.raises(ConfigError, match=r"option 'tones' of device 'visa' must be"):
        registry.device("visa", **options((1, 2), tones=0))


# ------------------------------------------------------------------ profiles
def _ena(edit: str, new: str) -> str:
    text = (SHIPPED / "keysight-ena.toml").read_text()
    assert edit in text
    return text.replace(edit, new)


REFUSED = [
    pytest.param(
        _ena("{trace}:DEF", "1:DEF"),
        r"profile: receivers = 2: a select command must use \{trace\}",
        id="select-without-trace",
    ),
    pytest.param(
        _ena('activate = [":CALC1:PAR{trace}:SEL"]\n', ""),
        r"profile: receivers = 2: read or an activate command must use \{trace\}",
        id="no-activate",
    ),
    pytest.param(
        _ena('activate = [":CALC1:PAR{trace}:SEL"]', 'activate = [":CALC1:PAR{trac}:SEL"]'),
        r"command activate = .* uses \{trac\}; its fields: input, output, parameter, trace$",
        id="activate-unknown-field",
    ),
    pytest.param(
        _ena('trigger = [":TRIG:SING"]', 'trigger = [":TRIG:SING {parameter}"]'),
        r"command trigger = .* uses \{parameter\}; its fields: input \(one sweep per input",
        id="trigger-per-pair",
    ),
    pytest.param(
        _ena('read = ":CALC1:DATA:SDAT?"', 'read = ":CALC{channel}:DATA:SDAT?"'),
        r"command read = .* uses \{channel\}",
        id="read-unknown-field",
    ),
    pytest.param(
        _ena("receivers = 2 ", "receivers = 3 "),
        r"receivers: must be 1 or 2, got 3 \(the outputs one sweep measures\)$",
        id="three-receivers",
    ),
    pytest.param(
        _ena("receivers = 2 ", "receivers = true "),
        r"receivers: must be 1 or 2, got True",
        id="receivers-bool",
    ),
    pytest.param(
        _ena("tones = 1 ", "tones = 0 "),
        r"tones: must be an integer >= 1, got 0 \(the frequencies one acquisition measures\)$",
        id="no-tones",
    ),
    pytest.param(
        _ena("receivers = 2 ", "receivers = 1 "),
        r"command select = .* uses \{trace\}; its fields: input, output, parameter "
        r"\(\{trace\} needs receivers = 2\)$",
        id="one-receiver-with-traces",
    ),
    pytest.param(
        (SHIPPED / "keysight-ena-1rx.toml")
        .read_text()
        .replace("read =", 'activate = [":CALC1:PAR1:SEL"]\nread ='),
        r"commands.activate is for receivers = 2",
        id="one-receiver-with-activate",
    ),
    pytest.param(
        _ena("receivers = 2 ", "receiver = 2 "),
        r": receiver: unknown key$",
        id="misspelt-key",
    ),
]


@pytest.mark.parametrize(("text", "message"), REFUSED)
def test_a_profile_whose_trace_commands_are_missing_or_wrong_is_refused_in_one_line(
    tmp_path: Path, text: str, message: str
) -> None:
    path = tmp_path / "mine.toml"
    path.write_text(text)
    with pytest.raises(ConfigError) as caught:
        get_registry().device("visa", **options((1, 2), analyzer_profile=str(path)))
    assert "\n" not in str(caught.value)
    assert str(caught.value).startswith(f"analyzer profile {path}: ")
    assert re.search(message, str(caught.value)), str(caught.value)


def test_the_shipped_analyzer_profiles_load_and_state_their_receivers() -> None:
    ena = load_profile("keysight-ena", "analyzer")
    one = load_profile("keysight-ena-1rx", "analyzer")
    assert isinstance(ena, AnalyzerProfile) and isinstance(one, AnalyzerProfile)
    assert (ena.receivers, ena.tones, one.receivers, one.tones) == (2, 1, 1, 1)
    # a profile that does not state them (as every profile before these keys): one of each
    text = (SHIPPED / "keysight-ena-1rx.toml").read_text()
    old = re.sub(r"(?m)^(receivers|tones) = .*\n", "", text)
    assert "receivers =" not in old and "tones =" not in old
    default = AnalyzerProfile.model_validate(tomllib.loads(old))
    assert (default.receivers, default.tones) == (1, 1)


# ------------------------------------------------------------------ a lock-in: tones
def test_a_lock_in_measures_tones_frequencies_per_acquisition(
    started: list[InstrumentSim],
) -> None:
    sim = LoggingSim(cloverleaf(4), 0, 0, dwell_ms=20.0)
    started.append(sim.start())
    dev = get_registry().device("visa", **options(sim.ports, tones=4))
    try:
        data = dev.measure(BIAS, FREQS)
    finally:
        dev.close()
    assert sim.tones == 4 and getattr(dev, "tones", None) == 4
    assert sim.triggers == 2 and sim.acquisitions == 2 * 3  # 9 points: 4 + 4 + 1
    # the points of one acquisition share its time stamp; acquisitions follow each other
    stamps = data.coords["time_s"].values
    groups = [stamps[0:4], stamps[4:8], stamps[8:9]]
    assert all(np.all(g == g[0]) for g in groups)
    assert groups[0][0] < groups[1][0] < groups[2][0]
    # the data are the device's measurement with four tones per acquisition (√k the noise)
    lock_in = cloverleaf(4).measure(data.attrs["applied_bias"], FREQS)
    np.testing.assert_allclose(data.values, lock_in.values, rtol=SENT, atol=0)
    one_tone = cloverleaf().measure(data.attrs["applied_bias"], FREQS)
    assert not np.allclose(data.values, one_tone.values, rtol=1e-6, atol=0)


def test_instrument_sim_tones_builds_a_lock_in_backed_by_a_bench_with_those_tones() -> None:
    import pyvisa

    ports = (free_port(), free_port())
    sim = Sim(ports, "--tones", "4")
    try:
        rm = pyvisa.ResourceManager("@py")
        inst = rm.open_resource(f"TCPIP::127.0.0.1::{ports[0]}::SOCKET")
        inst.read_termination = inst.write_termination = "\n"
        try:
            ident = inst.query("*IDN?").strip()
        finally:
            inst.close()
            rm.close()
        assert ident == "sysid-sim,lock-in-like analyzer (4 tones),0,1.0"
        dev = get_registry().device("visa", **options(ports, tones=4))
        try:
            data = dev.measure(BIAS, FREQS)
        finally:
            dev.close()
    finally:
        sim.stop()
    lock_in = cloverleaf(4).measure(data.attrs["applied_bias"], FREQS)
    np.testing.assert_allclose(data.values, lock_in.values, rtol=SENT, atol=0)


def test_instrument_sim_refuses_no_tones() -> None:
    proc = subprocess.run(
        [sys.executable, "-m", "sysid_core.cli", "instrument-sim", "--tones", "0"],
        capture_output=True,
        text=True,
        env=environment(),
        timeout=60,
    )
    assert proc.returncode == 2
    assert "--tones" in proc.stderr
