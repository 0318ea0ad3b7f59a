"""Degenerate modes need two electrodes: a run given more tunes the pair nearest the goal.

Truth: the cloverleaf's exact model (its three electrodes, linear in the squared potentials),
whose degenerate bias for each pair is known in closed form
(:func:`sysid_core.model.modal.degenerate_bias`); and a simulated random gyro of six electrodes,
whose true split at the end of a run is read from the simulator.
"""

from __future__ import annotations

import dataclasses
import itertools
import json
from pathlib import Path

import numpy as np
import pytest
from sysid_cloverleaf import CloverleafGyro
from truths import degenerate_config

from sysid_core import tune
from sysid_core.device.simulation import GyroTruth
from sysid_core.measure.pairing import least_voltage_pair
from sysid_core.model.modal import degenerate_bias
from sysid_core.plugin.registry import get_registry

ALL = ["B1", "B2", "B3"]
GOOD_LAB = {"temperature_ramp_k_per_h": 0.2, "temperature_walk_k_per_sqrt_h": 0.05}


@pytest.fixture(scope="module")
def truth() -> GyroTruth:
    return CloverleafGyro(noise=0, feedthrough=0, extra_modes=False, dac_bits=0).truth


def _exact(truth: GyroTruth):  # type: ignore[no-untyped-def]
    from tuning.test_tuning import exact_model

    return exact_model(truth, ALL)


def _pair_steps(truth: GyroTruth, limits: tuple[float, float]) -> dict[tuple[int, int], float]:
    """Each pair's exact degenerate bias from 0 V, by the closed form: its largest step."""
    steps = {}
    for a, b in itertools.combinations(range(3), 2):
        v = degenerate_bias(truth.K0, truth.Kp, truth.M, truth.structure_potential, (a, b))
        if np.all(np.isfinite(v)) and np.all((v >= limits[0]) & (v <= limits[1])):
            steps[(a, b)] = float(np.max(np.abs(v)))
    return steps


def test_the_pair_chosen_is_the_nearest_exact_degenerate_bias(truth: GyroTruth) -> None:
    steps = _pair_steps(truth, (-10.0, 10.0))
    assert len(steps) >= 2  # a choice to make
    best = min(steps, key=steps.__getitem__)
    pair = least_voltage_pair(_exact(truth), np.zeros(3), (-10.0, 10.0), truth.structure_potential)
    assert pair is not None
    assert pair.electrodes == (ALL[best[0]], ALL[best[1]])
    assert pair.step_v == pytest.approx(steps[best], rel=1e-9)
    bias = np.zeros(3)
    bias[list(best)] = pair.bias
    f = truth.modal_frequencies_hz(bias)
    assert f[1] - f[0] < 1e-6  # degenerate by the truth itself
    assert "tuning" in pair.describe(ALL) and ALL[best[0]] in pair.describe(ALL)


def test_limits_that_exclude_the_nearest_pair_choose_the_next_or_none(truth: GyroTruth) -> None:
    """The cloverleaf: B2 and B3 reach degenerate modes at (4.351, -1.751) V, B1 and B2 at
    (2.041, 4.388) V, B1 and B3 only 76 V away. Limits of ±4.37 V leave B2 and B3; limits of
    (-1.7, 10) V leave B1 and B2; ±4 V leave none."""
    model, vs = _exact(truth), truth.structure_potential
    assert least_voltage_pair(model, np.zeros(3), (-4.37, 4.37), vs).electrodes == ("B2", "B3")
    assert least_voltage_pair(model, np.zeros(3), (-1.7, 10.0), vs).electrodes == ("B1", "B2")
    assert least_voltage_pair(model, np.zeros(3), (-4.0, 4.0), vs) is None


def test_two_electrodes_leave_nothing_to_choose(truth: GyroTruth) -> None:
    from tuning.test_tuning import exact_model

    two = exact_model(truth, ["B1", "B2"])
    assert least_voltage_pair(two, np.zeros(2), (-10.0, 10.0), truth.structure_potential) is None


def _run(
    tmp_path: Path, pair: bool, iterations: int = 6, resume: bool = False
) -> tuple[Path, dict, object]:
    seed = 588  # six electrodes (and a seventh not offered)
    device = get_registry().device("random-gyro", seed=seed, noise=1e-3)
    config = degenerate_config(device, {"seed": seed, "noise": 1e-3}, iterations=iterations)
    config["tuning"]["electrodes"] = list(device.electrodes[:6])
    config["tuning"]["pair"] = pair
    # 2 mHz: the pair's DAC codes (0.81 mHz by the first model) leave room for the noise
    config["tuning"]["acceptance_hz"] = 0.002
    out = tmp_path / f"pair-{pair}"
    tune(config, out, device=device, plots=False, resume=resume)
    return out, json.loads((out / "summary.json").read_text()), device


def test_without_pair_every_electrode_is_tuned(tmp_path: Path) -> None:
    _, summary, _ = _run(tmp_path, False, iterations=1)
    assert len(summary["tuned"]) == 6
    assert len(summary["history"][0]["experiments"]) == 13  # two-sided: 2 n + 1


def test_a_run_given_six_electrodes_tunes_a_pair_and_reaches_the_goal(tmp_path: Path) -> None:
    out, summary, device = _run(tmp_path, True)
    assert len(summary["tuned"]) == 2 and set(summary["tuned"]) < set(summary["electrodes"])
    # three electrodes stepped offer a pair inside the limits: B4-B6 are not stepped
    assert sorted(p.name for p in out.glob("iter01/exp-B*.nc")) == [
        f"exp-{e}.nc"
        for e in device.electrodes[:3]  # type: ignore[attr-defined]
    ]
    held = [k for k, e in enumerate(summary["electrodes"]) if e not in summary["tuned"]]
    assert np.allclose(np.asarray(summary["bias"])[held], 0.0)  # the others stay where they were
    f = device.true_modal_frequencies_hz(np.asarray(summary["bias"]))  # type: ignore[attr-defined]
    assert summary["converged"] and f[1] - f[0] <= 0.002
    # the pair's first design: the centre and each electrode of the pair up and down
    first = summary["history"][0]["experiments"]
    assert len(first) == 5
    # --resume reads every sweep back, chooses the same pair and ends where the run ended
    _, again, _ = _run(tmp_path, True, resume=True)
    assert (again["tuned"], again["bias"], again["points"]) == (
        summary["tuned"],
        summary["bias"],
        summary["points"],
    )


def test_a_pair_that_cannot_meet_the_goal_gives_way_to_the_next_pair(tmp_path: Path) -> None:
    """The cloverleaf with a bias law that softens B3 (``beta_3 = -0.03 / V^2``): by the first
    sweeps' law (±1 V) B2 and B3 meet the goal nearest, but the truth gives that pair no
    degenerate bias inside ±10 V (its best split is 0.89 Hz). B1 and B2 have one, at
    (2.041, 4.388) V with B3 at 0 V, where B3's law does not act (the closed form). The pair's
    model finds the goal out of reach; the run offers every electrode again, the law of every
    sweep chooses B1 and B2 (B2 and B3 are not chosen again), and the run ends there instead of
    ending with that error or tuning all three."""
    device = CloverleafGyro(noise=1e-4, feedthrough=0, extra_modes=False, dac_bits=0)
    device.truth = dataclasses.replace(device.truth, bias_law=np.array([0.0, 0.0, -0.03]))
    config = {
        "device": {"name": "cloverleaf"},
        "model": {"structure": "act"},
        "tuning": {
            "criterion": "degenerate",
            "electrodes": ALL,
            "start_bias": [0.0] * 3,
            "acceptance_hz": 0.001,
            "max_iterations": 8,
            "pair": True,
        },
    }
    lines: list[str] = []
    summary = tune(config, tmp_path / "run", device=device, plots=False, progress=lines.append)
    first = json.loads((tmp_path / "run" / "iter01" / "tuning.json").read_text())
    assert "electrodes B2, B3" in first["unreachable"]  # the pair's verdict, not concluded
    assert any("choosing again among the other pairs" in line for line in lines)
    assert summary.tuned == ["B1", "B2"]
    assert summary.bias[2] == 0.0  # B3 stays where it was
    f = device.truth.modal_frequencies_hz(device.applied_bias(np.asarray(summary.bias)))
    assert summary.converged and f[1] - f[0] <= 2 * 0.001
    # a resume replays the same choices: B2 and B3, then B1 and B2
    again = tune(config, tmp_path / "run", device=device, plots=False, resume=True)
    assert (again.tuned, again.bias, again.points) == (summary.tuned, summary.bias, summary.points)


def test_a_pair_whose_dac_codes_miss_the_acceptance_gives_way_to_every_electrode(
    tmp_path: Path,
) -> None:
    """Random gyro 639 (five electrodes, a good lab's clock and drift, 8 tones, a 16-bit DAC):
    a pair meets degenerate modes, but at one of its answers its DAC's best code is predicted to
    leave more than the 1 mHz acceptance (a run tuning a pair alone used to hover at such a code
    for 67 iterations and stop at the DAC's floor, 2.2 mHz). Every electrode's codes are a finer
    lattice: the run tunes all five from the next iteration on and ends within the
    acceptance."""
    seed = 639
    bench = {"clock": True, "seed": seed, "tones": 8, **GOOD_LAB}
    device = get_registry().device("random-gyro", seed=seed, bench=bench)
    config = degenerate_config(device, {"seed": seed, "bench": bench}, iterations=60)
    config["tuning"].update(electrodes=list(device.electrodes), pair=True, acceptance_hz=0.001)
    summary = tune(config, tmp_path / "run", device=device, plots=False)
    tunings = [
        json.loads(p.read_text()) for p in sorted((tmp_path / "run").glob("iter*/tuning.json"))
    ]
    assert len(list((tmp_path / "run" / "iter01").glob("exp-B*.nc"))) >= 2  # a pair was chosen
    short = next(
        i
        for i, t in enumerate(tunings)
        if t.get("dac_code", {}).get("predicted_split_hz_chosen", 0.0) > 0.001
    )
    assert "unreachable" not in tunings[short]
    assert np.count_nonzero(tunings[short]["bias"]) == 2  # the pair's answer
    assert summary.tuned == list(device.electrodes)
    later = tunings[short + 1]  # every electrode's model
    assert later["dac_code"]["predicted_split_hz_chosen"] < 0.5 * 0.001  # a finer lattice
    f = device.true_modal_frequencies_hz(np.asarray(summary.bias))
    assert summary.converged and f[1] - f[0] <= 0.001


def test_three_stepped_electrodes_with_a_pair_inside_the_limits_end_the_stepping(
    truth: GyroTruth,
) -> None:
    """The cloverleaf's exact law and a fourth electrode, B4, acting as B1 does at half its
    strength. Once B1-B3 are stepped, B2 and B3 reach degenerate modes 4.87 V from 0 V, inside
    limits of ±10 V, so B4 is not stepped; inside ±4 V no pair of the three reaches them and B4
    is stepped too. Two stepped electrodes leave no pair to choose."""
    from tuning.test_tuning import exact_model

    from sysid_core.measure.pairing import choose_pair, pair_of_stepped
    from sysid_core.tuning.criteria import BiasSpace

    four = [*ALL, "B4"]
    truth4 = dataclasses.replace(
        truth, Kp=np.concatenate([truth.Kp, 0.5 * truth.Kp[:1]]), electrodes=tuple(four)
    )
    wide = BiasSpace(four, four, np.zeros(4), (-10.0, 10.0), truth.structure_potential)
    narrow = dataclasses.replace(wide, limits=(-4.0, 4.0))
    three = exact_model(truth4, ALL)
    assert pair_of_stepped(three, np.zeros(3), narrow, ["B4"]) is None
    found = pair_of_stepped(three, np.zeros(3), wide, ["B4"])
    assert found is not None and found.electrodes == ("B2", "B3") and found.unstepped == ("B4",)
    assert found.step_v == pytest.approx(4.87, abs=0.01)
    assert "B4 not stepped" in found.describe(four)
    assert pair_of_stepped(exact_model(truth4, ALL[:2]), np.zeros(2), wide, ["B3"]) is None
    for space, stepped in ((wide, ALL), (narrow, four)):
        measured: list[str] = []
        choose_pair(
            four,
            np.eye(4),
            lambda row, name, seen=measured: seen.append(name),  # type: ignore[misc]
            lambda names: exact_model(truth4, names),
            np.zeros(4),
            space,
        )
        assert measured == stepped


def test_electrodes_never_stepped_are_stepped_once_the_pair_gives_way(tmp_path: Path) -> None:
    """Random gyro 673 (four electrodes, 29.5 kHz, a good lab's clock, one tone, the first
    design's step 3 V): a pair reaches degenerate modes inside the limits once three electrodes
    are stepped, so B4 is not; the pair's DAC codes near its answer are then predicted to leave
    more than the acceptance, and it gives way to every electrode. B4 is stepped once where the
    run is, the fit of every sweep holds all four laws, and the run ends within the acceptance
    (it used to stop with the rank condition's error: the electrodes never stepped never varied;
    gyro 666 showed it before the grids were chosen by information per second, and gyro 683,
    whose pair gave way to a goal out of reach, until the probe took every fourth locating
    point)."""
    seed = 673
    bench = {"clock": True, "seed": seed, "tones": 1, **GOOD_LAB}
    device = get_registry().device("random-gyro", seed=seed, bench=bench)
    config = degenerate_config(device, {"seed": seed, "bench": bench}, iterations=60)
    config["tuning"].update(electrodes=list(device.electrodes), pair=True, acceptance_hz=0.001)
    config["experiment"] = {"bias_step": 3.0}
    config["model"] = {"structure": device.structure}
    summary = tune(config, tmp_path / "run", device=device, plots=False)
    first = sorted(p.name for p in (tmp_path / "run" / "iter01").glob("exp-B[0-9].nc"))
    assert first == ["exp-B1.nc", "exp-B2.nc", "exp-B3.nc"]
    later = sorted(p.name for p in (tmp_path / "run").glob("iter0[2-9]/exp-B[0-9].nc"))
    assert later == ["exp-B4.nc"]
    assert summary.tuned == list(device.electrodes)
    f = device.true_modal_frequencies_hz(np.asarray(summary.bias))
    assert summary.converged and f[1] - f[0] <= 0.001
