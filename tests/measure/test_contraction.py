"""The local design, when the split falls too slowly or verifying alone would cost more.

Truth: random gyro 108 (18.4 kHz, input dynamics) on the bench of a good lab (0.2 K/h ramp,
0.05 K/√h walk, a clock), tuned from 0 V with its own structure, judged by the simulated gyro's
true split at the end. Without the rule its verified splits fell 2643, 249, 43 and 19 mHz in four
iterations, each verification agreeing with the model of all sweeps fitted with it, and the run
ended at 18 mHz; it measured no local design.
"""

from __future__ import annotations

import itertools
from pathlib import Path
from typing import Any

import numpy as np
from hypothesis import given
from hypothesis import strategies as st
from truths import degenerate_config

from sysid_core import tune
from sysid_core.clock.runclock import stamps
from sysid_core.data.schema import load_dataset
from sysid_core.measure.contraction import (
    Costs,
    design_or_not,
    too_slow,
    unresolved,
    verifications_needed,
)
from sysid_core.measure.fitter import TREND_SPAN_S
from sysid_core.plugin.registry import get_registry

splits = st.floats(1e-5, 10.0)


def good_lab(seed: int, ramp_k_per_h: float, **bench: object) -> tuple[Any, dict[str, Any]]:
    """Random gyro ``seed`` on a good lab's bench with a clock; the device and its options."""
    drift = {"temperature_ramp_k_per_h": ramp_k_per_h, "temperature_walk_k_per_sqrt_h": 0.05}
    bench = {"clock": True, "seed": seed, **drift, **bench}
    return get_registry().device("random-gyro", seed=seed, bench=bench), {"seed": seed}


def test_nothing_to_judge_without_two_splits_iterations_left_or_a_split_over() -> None:
    assert too_slow(None, 0.25, 2, 0.002) is None
    assert too_slow(2.6, 0.25, 0, 0.002) is None  # the run ends anyway
    assert too_slow(2.6, 0.0015, 2, 0.002) is None  # already under the acceptance


def test_the_rate_decides() -> None:
    # 2643 -> 249 mHz: 249 (249/2643)^2 = 2.2 mHz after two more, over 2 mHz
    why = too_slow(2.643, 0.249, 2, 0.002)
    assert why is not None and "2.21 mHz" in why and "2 iteration(s)" in why
    # 2643 -> 65 mHz: 0.04 mHz after two more
    assert too_slow(2.643, 0.065, 2, 0.002) is None
    # a split that grew never reaches it
    assert too_slow(0.010, 0.020, 3, 0.002) is not None


def test_a_window_that_does_not_resolve_its_split_from_the_acceptance_gives_no_rate() -> None:
    # 0.93 -> 1.13 mHz, acceptance 1 mHz: "did not fall", unless the latest window's 95 %
    # interval (0.21-2.06 mHz) reaches down to the acceptance: then the rate is the noise's
    assert too_slow(0.00093, 0.00113, 5, 0.001) is not None
    assert too_slow(0.00093, 0.00113, 5, 0.001, low_hz=0.00021) is None
    assert too_slow(0.00093, 0.00113, 5, 0.001, low_hz=0.0) is None
    assert too_slow(0.00093, 0.00113, 5, 0.001, low_hz=0.001) is None  # reaches it exactly
    # a window resolved over the acceptance reads the rate as before
    assert too_slow(0.010, 0.020, 3, 0.002, low_hz=0.015) is not None
    line = unresolved(0.00071, 0.00208, 0.002, 0.00045)
    assert line is not None and "0.71 to 2.08 mHz" in line and "down to 0.45 mHz" in line
    assert unresolved(0.00071, 0.0019, 0.002, 0.0) is None  # under the acceptance: nothing to say
    assert unresolved(0.010, 0.020, 0.002, 0.015) is None  # resolved
    assert (
        unresolved(None, 0.020, 0.002, 0.0) is None and unresolved(0.01, 0.02, 0.002, None) is None
    )


@given(last=splits, split=splits, low=st.floats(0.0, 10.0), left=st.integers(1, 6))
def test_a_resolved_window_decides_as_without_its_interval(
    last: float, split: float, low: float, left: int
) -> None:
    acceptance, costs = 0.002, Costs(10.0, 40.0)
    told = too_slow(last, split, left, acceptance, costs, low_hz=low)
    if low > acceptance:
        assert told == too_slow(last, split, left, acceptance, costs)
    else:
        assert told is None


def test_verifications_needed_at_the_rate_seen() -> None:
    assert verifications_needed(2.643, 0.0015, 0.002) == 0  # already under
    # 249 mHz at 249/2643 per verification: 23.5, 2.2, then 0.21 mHz
    assert verifications_needed(2.643, 0.249, 0.002) == 3
    assert verifications_needed(0.010, 0.020, 0.002) == float("inf")


def test_the_costs_decide_when_the_iterations_allow_either_way() -> None:
    # three verifications of 10 s against a design of 40 s and one verification: verify
    assert too_slow(2.643, 0.249, 10, 0.002, Costs(10.0, 40.0)) is None
    # against a design of 10 s: the design and one verification cost 20 s, the three 30 s
    why = too_slow(2.643, 0.249, 10, 0.002, Costs(10.0, 10.0))
    assert why is not None and "the 3 verifications it needs would cost 1.5 times" in why
    # a fast fall (a good model) is never paid a design: one more verification does it
    assert too_slow(2.643, 0.0065, 10, 0.002, Costs(10.0, 0.0)) is None


def test_costs_of_a_verification_and_a_design() -> None:
    def cost(points: int, change: bool) -> float:
        return -(-points // 8) * 2.0 + (3.0 if change else 0.0)

    costs = Costs.of(cost, [16, 40], 4)
    assert costs == Costs(2 * 2.0 + 3.0 + 5 * 2.0, 4 * (2 * 2.0 + 3.0))
    assert Costs.of(None, [16], 4) is None and Costs.of(cost, [], 4) is None


@given(
    last=splits,
    split=splits,
    verify=st.floats(0.1, 100.0),
    design=st.floats(0.0, 1000.0),
    more=st.floats(1.0, 10.0),
)
def test_a_dearer_design_never_pays_where_a_cheaper_one_did_not(
    last: float, split: float, verify: float, design: float, more: float
) -> None:
    if too_slow(last, split, 20, 0.002, Costs(verify, design * more)) is not None:
        assert too_slow(last, split, 20, 0.002, Costs(verify, design)) is not None


@given(last=splits, split=splits, more=st.floats(1.0, 10.0), left=st.integers(1, 6))
def test_a_larger_split_or_a_smaller_last_one_is_never_judged_faster(
    last: float, split: float, more: float, left: int
) -> None:
    acceptance = 0.002
    if too_slow(last, split, left, acceptance) is not None:
        assert too_slow(last, split * more, left, acceptance) is not None
        assert too_slow(last / more, split, left, acceptance) is not None


def test_a_slow_fall_measures_the_local_design_and_ends_under_the_acceptance(
    tmp_path: Path,
) -> None:
    device, options = good_lab(108, -0.2)
    # found with the whole locating sweep first: with the probe (the default on a bench with a
    # clock) the first answers of gyro 108 fall fast enough
    config = degenerate_config(device, options, 4, experiment={"probe": False})
    lines: list[str] = []
    result = tune(config, tmp_path / "run", plots=False, device=device, progress=lines.append)
    assert any("the verified split fell from" in line for line in lines), "\n".join(lines)
    assert any("local design" in line or "sweeps near the bias" in line for line in lines)
    f = device.true_modal_frequencies_hz(result.bias)
    assert f[1] - f[0] <= 0.002


def test_a_fast_fall_verifies_the_next_answer_without_a_design(tmp_path: Path) -> None:
    """Random gyro 212 on a good lab's clock with 8 tones: the first answer takes the split from
    about 11 Hz at 0 V to 65 mHz (a rate under 1 %), so one more verification is expected to do
    what the local design (four sweeps, then a verification) would: the run measures none."""
    device, options = good_lab(212, 0.2, tones=8)
    config = degenerate_config(device, options, 6, 0.001, experiment={"bias_step": 3.0})
    lines: list[str] = []
    result = tune(config, tmp_path / "run", plots=False, device=device, progress=lines.append)
    assert any(line.startswith("iteration 2: fitting all") for line in lines), "\n".join(lines)
    assert not list((tmp_path / "run" / "iter02").glob("exp*.nc"))  # its verification only
    assert not any("local design" in line for line in lines)
    f = device.true_modal_frequencies_hz(result.bias)
    assert result.converged and f[1] - f[0] <= 2 * 0.001


def test_the_first_answer_does_not_set_the_rate(tmp_path: Path) -> None:
    """Random gyro 431 (1.22 kHz, 8 tones, a good lab's clock), first design ±3 V: its first
    answer lands 5 V away and leaves 1 Hz, a rate that asked for the local design when it was
    read from the split at 0 V (then 420 points). The model of all sweeps holds that window, and
    its answers fall 1 Hz -> 0.17 Hz -> 12 mHz -> under 0.1 mHz without a local design."""
    device, options = good_lab(431, 0.2, tones=8)
    config = degenerate_config(device, options, 6, 0.001, experiment={"bias_step": 3.0})
    lines: list[str] = []
    result = tune(config, tmp_path / "run", plots=False, device=device, progress=lines.append)
    assert any(line.startswith("iteration 2: fitting all") for line in lines), "\n".join(lines)
    assert not any("sweeps near the bias" in line for line in lines)
    assert not list((tmp_path / "run").glob("iter0[2-9]/exp*.nc"))  # verifications only
    f = device.true_modal_frequencies_hz(result.bias)
    assert result.converged and f[1] - f[0] <= 0.001


def test_sweeps_an_hour_old_are_fitted_while_the_split_falls(tmp_path: Path) -> None:
    """Random gyro 431 (1.22 kHz, one tone, a good lab's clock), first design ±3 V: its sweeps
    span over an hour of bench clock by its fourth iteration, and its verified splits fall 304
    -> 4.1 -> 1.7 mHz meanwhile. A rule that sent a tracked run to the local design once its
    sweeps spanned an hour measured two here (314 dwells and 199 minutes instead of 162 and 103,
    with 11-point scouts); the run fits every sweep while its verified split falls, goes local
    only when it stops falling (1.72 -> 1.82 mHz with 8-point scouts), and reaches 1 mHz."""
    device, options = good_lab(431, 0.2)
    config = degenerate_config(device, options, 8, 0.001, experiment={"bias_step": 3.0})
    lines: list[str] = []
    result = tune(config, tmp_path / "run", plots=False, device=device, progress=lines.append)
    said = "\n".join(lines)
    # an iteration that fits all the sweeps although they span over an hour
    spans = [line.split(":")[0] for line in lines if ": the sweeps span" in line]
    assert any(f"{it}: fitting all" in said for it in spans), said
    run = tmp_path / "run"
    sweeps = [load_dataset(p) for p in run.glob("iter*/*.nc") if "model" not in p.name]
    assert np.ptp(np.concatenate([stamps(sweep) for sweep in sweeps])) > TREND_SPAN_S
    # a local design only where the split stopped falling or fell too slowly, never for the
    # sweeps' age
    local = [line for line in lines if "fitting the sweeps near the bias from now on" in line]
    assert all("did not fall" in line or "at that rate" in line for line in local), said
    f = device.true_modal_frequencies_hz(result.bias)
    assert result.converged and f[1] - f[0] <= 0.001


def test_a_fast_fall_after_a_local_design_verifies_the_answer_of_the_sweeps_it_has(
    tmp_path: Path,
) -> None:
    """Random gyro 806 (8 tones, a good lab's clock, first design ±1 V, four electrodes, B1 and
    B2 tuned): its first two answers fall 5.93 -> 2.73 Hz, so slowly that iteration 3 measures
    the local design; its answer takes the split to 3.73 mHz. A new local design there would be
    four more sweeps; at the rate its splits fall the verifications are expected to cost less.
    The run fits the nearest sweeps that meet the rank condition instead at iteration 4 (0.052
    mHz measured) and converges (0.13 mHz true): no design after the third iteration. (Gyros 796,
    819, 834, 940 and 884 showed it before the pair was chosen among the first three electrodes
    stepped, before the probe took every fourth locating point, before scouts stepped as a noisy
    bench's probe did, before a pair's second steps went to its scouts' answer, and before a
    design's sweeps around predicted modes took the scouts' floor.)"""
    device, options = good_lab(806, 0.2, tones=8)
    config = degenerate_config(device, options, 300, 0.001, experiment={"bias_step": 1.0})
    config["tuning"] |= {"electrodes": list(device.electrodes[:6]), "pair": True}
    lines: list[str] = []
    result = tune(config, tmp_path / "run", plots=False, device=device, progress=lines.append)
    text = "\n".join(lines)
    chords = [line for line in lines if "of the local design they lack" in line]
    assert [line.split(":")[0] for line in chords[:1]] == ["iteration 4"], text
    assert list((tmp_path / "run").glob("iter03/exp*.nc")), text  # the local design
    assert not list((tmp_path / "run").glob("iter0[4-9]/exp*.nc")), text
    f = device.true_modal_frequencies_hz(result.bias)
    assert result.converged and f[1] - f[0] <= 2 * 0.001


def test_a_split_risen_inside_its_windows_noise_is_verified_again_without_a_design(
    tmp_path: Path,
) -> None:
    """Random gyro 943 (22.9 kHz, a pair of its six electrodes tuned, 60 dB, one tone, a good
    lab's clock, acceptance 2 mHz): its windows measure the split to ±2-3 mHz at 95 %. Read as
    a rate, a split "risen" from 0.71 to 2.08 mHz (interval 0.45-3.91 mHz) asked for the local
    design: four sweeps, and 234 dwells to converge. Unresolved from the acceptance, the rise
    gives no rate; the run verifies the next answers and converges after 174 dwells."""
    drift = {"temperature_ramp_k_per_h": 0.2, "temperature_walk_k_per_sqrt_h": 0.05}
    options = {"seed": 943, "noise": 1e-3}
    bench = {"clock": True, "seed": 943, **drift}
    device = get_registry().device("random-gyro", **options, bench=bench)
    config = degenerate_config(device, options, 0)
    config["tuning"] |= {"electrodes": list(device.electrodes), "max_iterations": None}
    lines: list[str] = []
    result = tune(config, tmp_path / "run", plots=False, device=device, progress=lines.append)
    history = [h for h in result.history if h.measured_split_ci_hz is not None]
    rises = [
        (a, b)
        for a, b in itertools.pairwise(history)
        if b.measured_split_hz > max(a.measured_split_hz, 0.002)
        and b.measured_split_ci_hz[0] <= 0.002  # type: ignore[index]
    ]
    assert rises, "\n".join(lines)  # the case: a rise the window does not resolve
    assert not any("did not fall" in line for line in lines), "\n".join(lines)
    assert any(
        "no rate to read, no local design; verifying the next answer" in line for line in lines
    )
    later = [d for d in sorted((tmp_path / "run").glob("iter*")) if d.name != "iter01"]
    assert later and not any(list(d.glob("exp*.nc")) for d in later)  # windows only
    f = device.true_modal_frequencies_hz(result.bias)
    assert result.converged and f[1] - f[0] <= 0.002


def test_design_or_not_gives_the_reason_or_the_line_never_both() -> None:
    """0.93 → 1.13 mHz, acceptance 1 mHz: a rise asks for the design where its window resolves
    it (95 % from 1.05 mHz) and gives the no-rate line where it does not (from 0.2 mHz)."""
    why, note = design_or_not(0.00093, 0.00113, 5, 0.001, None, 0.00105)
    assert why is not None and "did not fall" in why and note is None
    why, note = design_or_not(0.00093, 0.00113, 5, 0.001, None, 0.0002)
    assert why is None and note is not None and "no rate to read" in note
    # a fast fall asks for nothing, resolved or not
    assert design_or_not(0.050, 0.0011, 5, 0.001, None, 0.0002) == (None, None)
