"""What a run has measured (``Knowledge``): every sweep kept in order with its epoch, found again
by bias within a DAC step, the sweeps near a bias, the rank condition over them, and the modes
the latest located sweep saw.

Truth: the simulated cloverleaf (frozen bench), whose sweeps at the design of eq. (18) meet the
rank condition (6), while one bias alone does not.
"""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from sysid_cloverleaf import CloverleafGyro

from sysid_core.data import experiment_from_measurement
from sysid_core.measure.evidence import WindowAssessment
from sysid_core.measure.knowledge import LEVEL_SHARE, SAME_V, Knowledge, levels
from sysid_core.measure.sweeps import design_experiments
from sysid_core.tuning.criteria import TuningResult

F = np.linspace(4425.0, 4436.0, 23)
TUNED = ["B1", "B2"]


def sweep(gyro: CloverleafGyro, bias: np.ndarray):
    measured = gyro.measure(bias, F)
    return experiment_from_measurement(measured, bias, gyro.electrodes, 15.58, "cloverleaf")


@pytest.fixture(scope="module")
def design() -> tuple[CloverleafGyro, np.ndarray, list]:
    gyro = CloverleafGyro(seed=1)
    biases = design_experiments(np.zeros(3), [0, 1], 1.0, (-10.0, 10.0), two_sided=True)
    return gyro, biases, [sweep(gyro, b) for b in biases]


def test_every_sweep_is_kept_in_order_with_its_epoch(design) -> None:
    _, biases, sweeps = design
    known = Knowledge(TUNED, 15.58)
    known.add(sweeps[0], None)
    known.begin(2)
    for s in sweeps[1:]:
        known.add(s, None)
    assert len(known) == len(sweeps)
    union = known.union()
    assert list(union["electrode"].values) == TUNED
    assert list(union["epoch"].values) == [1] + [2] * (len(sweeps) - 1)
    np.testing.assert_allclose(union["bias"].values, biases[:, :2], atol=1e-3)


def test_a_bias_is_found_again_within_a_dac_step(design) -> None:
    _, biases, sweeps = design
    known = Knowledge(TUNED, 15.58)
    known.add(sweeps[1], None)
    assert known.has(biases[1]) and known.has(biases[1] + 0.5 * SAME_V)
    assert not known.has(biases[1] + 10 * SAME_V) and not known.has(biases[2])


def test_the_sweeps_near_a_bias_and_their_rank(design) -> None:
    sweeps = design[2]
    known = Knowledge(TUNED, 15.58)
    for s in sweeps:
        known.add(s, None)
    far = np.array([5.0, 5.0, 0.0])
    assert known.near(np.zeros(3), 1.0).sizes["experiment"] == len(sweeps)  # the design's ±1 V
    assert known.near(np.zeros(3), 0.5).sizes["experiment"] == 1  # only the centre
    assert known.near(far, 0.5).sizes["experiment"] == len(sweeps)  # none near: every sweep
    assert known.meets_rank(np.zeros(3), 1.0, "auto")  # two-sided: the quadratic law's rank
    assert not known.meets_rank(np.zeros(3), 0.5, "linear")  # one bias
    assert not known.meets_rank(far, 0.5, "linear")  # nothing near


def test_the_latest_located_modes_are_those_a_sweep_showed() -> None:
    known = Knowledge(TUNED, 15.58)
    gyro = CloverleafGyro(seed=1)
    near = np.array([2.0377, 4.3884, 0.0])  # the README's answer: both modes inside F
    seen = WindowAssessment(
        window_hz=(float(F[0]), float(F[-1])),
        step_hz=0.5,
        band=False,
        frequencies_hz=np.array([4430.04, 4430.046]),
        bandwidth_hz=np.array([0.08, 0.08]),
    )  # no failed check: the evidence shows both modes
    known.add(sweep(gyro, np.zeros(3)), None)
    assert known.latest() is None and known.first_split() is None
    known.add(sweep(gyro, near), seen)
    latest = known.latest()
    assert latest is not None and latest.modes is not None
    np.testing.assert_allclose(latest.bias, near, atol=1e-3)
    np.testing.assert_allclose(latest.modes.frequencies_hz, seen.frequencies_hz)
    wider = dataclasses.replace(seen, frequencies_hz=np.array([4429.0, 4431.0]))
    known.add(sweep(gyro, np.zeros(3)), wider)
    assert known.first_split() == pytest.approx(0.006)  # the first sweep that located them


def test_without_located_modes_a_window_is_centred_on_the_answer() -> None:
    known = Knowledge(TUNED, 15.58)
    predicted = TuningResult(
        bias=np.zeros(3),
        w=np.zeros(2),
        frequencies_hz=np.array([4430.0, 4430.0]),
        split_hz=0.0,
        criterion="degenerate",
        value=0.0,
    )
    centre, sigma = known.centre(np.zeros(3), [0, 1], predicted, None, 10.0, 60.0)  # type: ignore[arg-type]
    assert centre == predicted.frequency_hz and sigma == 0.0  # no region: no uncertainty said


def _known_at(gyro: CloverleafGyro, biases) -> Knowledge:
    known = Knowledge(TUNED, 15.58)
    for b in biases:
        known.add(sweep(gyro, np.asarray(b, dtype=float)), None)
    return known


def _step_design(bias: np.ndarray) -> np.ndarray:
    return design_experiments(bias, [0, 1], 0.25, (-10.0, 10.0), two_sided=True)


def test_a_local_design_measures_only_what_the_sweeps_near_the_bias_lack() -> None:
    gyro = CloverleafGyro(seed=1)
    old = _step_design(np.array([1.0, 1.0, 0.0]))  # the previous local design, ±0.25 V
    new = np.array([1.3, 1.3, 0.0])  # the next answer, verified there
    known = _known_at(gyro, [*old, new])
    # near (within 0.375 V): the old centre, its upward steps and the verification: rank 4 of 5
    assert not known.meets_rank(new, 0.375, "auto")
    design = _step_design(new)
    todo = known.completing(new, 0.375, "auto", design, [0, 1])
    assert todo == [1]  # one sweep (B1 up) completes the rank, not the four of the design
    known.add(sweep(gyro, design[1]), None)
    assert known.meets_rank(new, 0.375, "auto")
    # a move beyond the radius keeps nothing near but the verification: the whole design
    far = np.array([2.5, 2.5, 0.0])
    known = _known_at(gyro, [*old, far])
    assert known.completing(far, 0.375, "auto", _step_design(far), [0, 1]) == [1, 2, 3, 4]
    # sweeps that already meet the rank ask for nothing
    known = _known_at(gyro, old)
    assert known.completing(old[0], 0.375, "auto", old, [0, 1]) == []


def test_the_reach_of_the_nearest_sweeps_that_meet_the_rank() -> None:
    gyro = CloverleafGyro(seed=1)
    old = _step_design(np.array([1.0, 1.0, 0.0]))  # the previous local design, ±0.25 V
    new = np.array([1.5, 1.4, 0.0])  # the next answer, verified there: out of 0.375 V
    known = _known_at(gyro, [*old, new])
    assert not known.meets_rank(new, 0.375, "auto")
    # distances (largest |Δv|): the up-steps 0.4 and 0.5, the centre 0.5, B2's down-step 0.65,
    # B1's 0.75; the quadratic law's five levels are met at B2's down-step
    assert known.rank_reach(new, "auto") == pytest.approx(0.65)
    assert known.meets_rank(new, known.rank_reach(new, "auto") or 0.0, "auto")
    assert known.rank_reach(new, "linear") == pytest.approx(0.5)  # three biases not on a line
    # B2 never stepped: no radius meets the rank
    along = np.array([1.5, 1.0, 0.0])
    assert _known_at(gyro, [old[0], old[1], along]).rank_reach(along, "linear") is None


@settings(max_examples=25, deadline=None)
@given(
    move=st.tuples(st.floats(-1.0, 1.0, allow_nan=False), st.floats(-1.0, 1.0, allow_nan=False)),
    law=st.sampled_from(["auto", "linear"]),
)
def test_no_smaller_radius_meets_the_rank_than_the_reach(move, law) -> None:
    """Property: the sweeps within the reach meet (6), those strictly inside it do not."""
    gyro = CloverleafGyro(seed=1)
    new = np.array([1.0 + move[0], 1.0 + move[1], 0.0])
    known = _known_at(gyro, [*_step_design(np.array([1.0, 1.0, 0.0])), new])
    reach = known.rank_reach(new, law)
    assert reach is not None and known.meets_rank(new, reach, law)
    assert not known.meets_rank(new, reach - 2 * SAME_V, law)


@settings(max_examples=25, deadline=None)
@given(
    move=st.tuples(st.floats(-0.6, 0.6, allow_nan=False), st.floats(-0.6, 0.6, allow_nan=False)),
    law=st.sampled_from(["auto", "linear"]),
    apart=st.sampled_from([SAME_V, LEVEL_SHARE * 0.25]),
)
def test_what_completing_asks_for_meets_the_rank_with_no_more_sweeps(move, law, apart) -> None:
    """Property: measuring the rows it names makes the sweeps near the bias meet (6), and they
    are never more than the design's own steps; with levels a DAC step or half the design's
    step wide (what a local design passes)."""
    gyro = CloverleafGyro(seed=1)
    old = _step_design(np.array([1.0, 1.0, 0.0]))
    new = np.array([1.0 + move[0], 1.0 + move[1], 0.0])
    known = _known_at(gyro, [*old, new])
    design = _step_design(new)
    todo = known.completing(new, 0.375, law, design, [0, 1], apart)
    assert len(todo) <= len(design) - 1 and 0 not in todo  # the centre is known
    for j in todo:
        known.add(sweep(gyro, design[j]), None)
    assert known.meets_rank(new, 0.375, law, apart)


def test_requests_closer_than_a_dac_step_are_one_level() -> None:
    """Requested biases 6e-8 V apart are one DAC level: they raise no rank (hypothesis found
    a move of (0.4375, 6e-8) V for which the named rows left the applied biases short of (6))."""
    gyro = CloverleafGyro(seed=1)
    old = _step_design(np.array([1.0, 1.0, 0.0]))
    new = np.array([1.4375, 1.0 + 5.96e-8, 0.0])
    known = _known_at(gyro, [*old, new])
    design = _step_design(new)
    todo = known.completing(new, 0.375, "auto", design, [0, 1])
    assert todo == [1, 3, 4]  # one more on B1 (the old design gives the other), both on B2
    for j in todo:
        known.add(sweep(gyro, design[j]), None)
    assert known.meets_rank(new, 0.375, "auto")


def test_windows_at_codes_a_few_millivolts_apart_are_one_level_of_a_local_design() -> None:
    """Six windows within 5 mV of an answer meet the quadratic law's rank (6) in exact
    arithmetic (the rank's columns are scaled to their own spread); they tell the law's slope
    nothing a design of ±0.25 V would not tell 2500 times better in variance. As levels half a
    design step wide they are one bias, and the local design measures its four steps."""
    gyro = CloverleafGyro(seed=1)
    new = np.array([1.3, 1.3, 0.0])
    codes = 1e-3 * np.array([[0, 0], [1.5, 0.3], [3.0, 2.1], [0.6, 4.2], [4.5, 1.2], [2.4, 4.8]])
    known = _known_at(gyro, [new + np.r_[c, 0.0] for c in codes])
    assert known.meets_rank(new, 0.375, "auto")  # every window a level of its own
    apart = LEVEL_SHARE * 0.25
    assert not known.meets_rank(new, 0.375, "auto", apart)
    assert known.completing(new, 0.375, "auto", _step_design(new), [0, 1], apart) == [1, 2, 3, 4]


@settings(max_examples=50, deadline=None)
@given(
    values=st.lists(
        st.tuples(st.floats(-10, 10, allow_nan=False), st.floats(-10, 10, allow_nan=False)),
        min_size=1,
        max_size=12,
    ),
    apart=st.floats(1e-4, 2.0),
)
def test_levels_move_no_bias_further_than_a_level_and_keep_levels_apart(values, apart) -> None:
    """Property: each bias moves by at most ``apart`` within its electrode; the rows keep their
    order; two values more than ``2 apart`` apart stay two levels, and values within a level
    become one."""
    rows = np.array(values, dtype=float)
    out = levels(rows, apart)
    assert out.shape == rows.shape
    assert np.all(np.abs(out - rows) <= apart * (1 + 1e-9) + 1e-12)
    for p in range(rows.shape[1]):
        for i in range(len(rows)):
            for j in range(len(rows)):
                if abs(rows[i, p] - rows[j, p]) > 2 * apart:
                    assert out[i, p] != out[j, p]
    assert np.ptp(levels(np.array([[0.0], [0.4 * apart], [0.9 * apart]]), apart)) == 0.0
