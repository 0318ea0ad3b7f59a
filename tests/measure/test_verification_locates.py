"""A verification whose window misses the modes locates them as the run's first sweep does.

Truth: the simulated gyro's modal frequencies (``true_modal_frequencies_hz``), which the run
never sees. Random gyro 112 (1.49 kHz, bandwidths 0.045 / 0.075 Hz, 60 dB SNR, frozen bench):
its 61-point locating band steps 1.66 Hz, between which its modes sit, and the band's fit fails.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
from truths import degenerate_config

from sysid_core.measure.evidence import WindowAssessment
from sysid_core.plugin.registry import get_registry
from sysid_core.run.config import parse_config
from sysid_core.run.lean_protocol import LeanProtocol
from sysid_core.run.pipeline import TuningRun
from sysid_core.verdict.judgement import blind


def test_a_failed_band_is_followed_by_windows_around_the_modes_it_placed(tmp_path: Path) -> None:
    """The locating band alone shows no modes; the windows after it do, where the truth is."""
    device = get_registry().device("random-gyro", seed=112, noise=1e-3)
    config = degenerate_config(device, {"seed": 112, "noise": 1e-3}, iterations=4)
    run = TuningRun(parse_config(config), tmp_path / "run", plots=False, device=device)
    protocol = run.protocol
    assert isinstance(protocol, LeanProtocol)
    folder = tmp_path / "run" / "iter01"
    folder.mkdir(parents=True)
    bias = np.asarray(run.space.start_bias, dtype=float)
    windows: list[WindowAssessment] = []
    _, _, evidence = protocol._band(bias, folder)(protocol.locate_plan, windows)

    assert not windows[0].ok  # the band alone: what a verification ended on before
    assert (folder / "verify-band.nc").exists() and (folder / "verify-band-zoom.nc").exists()
    assert evidence.ok and windows[-1] is evidence
    truth = device.true_modal_frequencies_hz(bias)
    # each mode located within a bandwidth of the truth
    np.testing.assert_allclose(np.sort(evidence.frequencies_hz), np.sort(truth), atol=0.08)


def test_two_failed_verifications_in_a_row_stop_the_run() -> None:
    """:func:`blind`: the second failure in a row says so in one line; one alone does not."""
    from types import SimpleNamespace

    failed = SimpleNamespace(status="failed", windows=[SimpleNamespace(failures=lambda: "fit")])
    verified = SimpleNamespace(status="verified", windows=[])
    assert blind(failed, 0) is None  # type: ignore[arg-type]
    why = blind(failed, 1)  # type: ignore[arg-type]
    assert why is not None and "2 verifications in a row showed no modes (fit)" in why
    assert blind(verified, 3) is None  # type: ignore[arg-type]
