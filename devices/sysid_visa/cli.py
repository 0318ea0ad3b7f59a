"""``sysid instrument-sim``: a simulated analyzer and bias source for the ``visa`` device.

Added to the ``sysid`` program by this package's ``sysid_cli_commands`` hook (the core imports no
plugin).
"""

from __future__ import annotations

from typing import Annotated

import typer


def instrument_sim_cmd(
    device: Annotated[
        str, typer.Option("--device", help="An installed simulated device (e.g. cloverleaf).")
    ] = "cloverleaf",
    seed: Annotated[int | None, typer.Option("--seed", help="The device's seed.")] = None,
    analyzer_port: Annotated[
        int, typer.Option("--analyzer-port", help="TCP port of the analyzer on 127.0.0.1.")
    ] = 5025,
    source_port: Annotated[
        int, typer.Option("--source-port", help="TCP port of the bias source on 127.0.0.1.")
    ] = 5026,
    dwell_ms: Annotated[
        float,
        typer.Option(
            "--dwell-ms",
            help="Time per acquisition of each sweep (ms): per frequency point, or per N of "
            "them with --tones N.",
        ),
    ] = 0.0,
    readback_error: Annotated[
        str | None,
        typer.Option(
            "--readback-error",
            help="A fault to test with: CHANNEL:VOLTS added to what that channel reads back.",
        ),
    ] = None,
    tones: Annotated[
        int,
        typer.Option(
            "--tones",
            min=1,
            help="Frequencies per acquisition: N > 1 makes the analyzer a lock-in with N "
            "demodulators, each acquisition measuring N consecutive frequencies (the device "
            "measures with its bench setting tones = N).",
        ),
    ] = 1,
) -> None:
    """Serve a simulated analyzer and bias source (SCPI over TCP) until Ctrl-C or SIGTERM.

    They speak the visa device's shipped profiles (keysight-ena, keysight-ena-1rx,
    keysight-n6700); the analyzer answers with the simulated device's response at the voltages
    the source outputs. Prints one line starting with "listening" once both ports accept.
    With --tones N, give the visa device the option tones = N.
    """
    from sysid_core.errors import ConfigError
    from sysid_core.plugin.registry import get_registry
    from sysid_visa.sim import InstrumentSim, main_loop

    fault = None
    if readback_error is not None:
        try:
            ch, volts = readback_error.split(":")
            fault = (int(ch), float(volts))
        except ValueError:
            raise ConfigError(
                f"--readback-error must be CHANNEL:VOLTS (e.g. 2:0.05), got {readback_error!r}"
            ) from None
    options: dict[str, object] = {} if seed is None else {"seed": seed}
    if tones > 1:
        options["bench"] = {"tones": tones}
    try:
        dev = get_registry().device(device, **options)
    except TypeError as exc:  # a bench device, whose options (dir, resources...) are missing
        raise ConfigError(
            f"device {device!r} cannot back the simulated instruments ({exc}); name a simulated "
            "device such as cloverleaf or random-gyro"
        ) from None
    if not hasattr(dev, "true_modal_frequencies_hz"):
        raise ConfigError(
            f"device {device!r} is not a simulated device; name one such as cloverleaf or "
            "random-gyro"
        )
    try:
        sim = InstrumentSim(dev, analyzer_port, source_port, dwell_ms, fault, tones=tones)
    except OSError as exc:
        raise ConfigError(
            f"cannot listen on 127.0.0.1:{analyzer_port} / {source_port}: {exc.strerror}; "
            "choose other ports"
        ) from None
    main_loop(sim, lambda m: print(m, flush=True))
