"""A pair's second design steps go toward the answer that its scouts' law places.

Truth: the simulated cloverleaf, whose stiffness is exactly linear in ``w = (v - v_gyro)²``, so
the degenerate bias of each pair is known in closed form (B1 and B2: 2.041, 4.388 V; B2 and B3:
4.351, -1.751 V)
(:func:`sysid_core.model.modal.degenerate_bias`), and its true split at any bias is read from the
simulator.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from measure.test_lean import MAIN_JOB, Recording
from sysid_cloverleaf import CloverleafGyro

from sysid_core.measure.pairing import pair_bias
from sysid_core.measure.sweeps import design_experiments, second_side
from sysid_core.model.modal import degenerate_bias
from sysid_core.run.config import parse_config
from sysid_core.run.pipeline import TuningRun


def test_a_second_step_goes_to_an_answer_beyond_the_span_and_stays_inside_it() -> None:
    start = np.array([0.0, 0.5, 0.0])
    design = design_experiments(start, [0, 1], 1.0, (-10.0, 10.0), two_sided=True)
    placed = second_side(design, [0, 1], np.array([-4.0, 1.2]), 1.0)
    np.testing.assert_array_equal(placed[[0, 1, 3]], design[[0, 1, 3]])  # start, first steps
    np.testing.assert_array_equal(placed[2], [-4.0, 0.5, 0.0])  # B1's answer is 4 V away
    np.testing.assert_array_equal(placed[4], design[4])  # B2's lies 0.7 V away: inside
    np.testing.assert_array_equal(second_side(design, [0, 1], None, 1.0), design)
    # an answer whose interval reaches into the span is not known to lie beyond it: it stays
    region = np.array([[-6.0, -0.5], [0.9, 1.3]])
    np.testing.assert_array_equal(
        second_side(design, [0, 1], np.array([-4.0, 1.2]), 1.0, region), design
    )
    region = np.array([[-6.0, -2.0], [-3.0, 9.0]])
    placed = second_side(design, [0, 1], np.array([-4.0, 3.0]), 1.0, region)
    np.testing.assert_array_equal(placed[2], [-4.0, 0.5, 0.0])
    np.testing.assert_array_equal(placed[4], design[4])
    one_sided = design_experiments(start, [0, 1], 1.0, (-10.0, 10.0))
    np.testing.assert_array_equal(
        second_side(one_sided, [0, 1], np.array([5.0, 5.0]), 1.0), one_sided
    )


@settings(max_examples=60, deadline=None)
@given(
    start=st.lists(st.floats(-8.0, 8.0), min_size=2, max_size=2),
    answer=st.lists(st.floats(-10.0, 10.0), min_size=2, max_size=2),
    width=st.lists(st.floats(0.0, 5.0), min_size=2, max_size=2),
    step=st.floats(0.1, 2.0),
)
def test_only_second_steps_move_and_only_to_the_answer(
    start: list[float], answer: list[float], width: list[float], step: float
) -> None:
    """Every row but the second steps is the design's; a second step is the design's or the
    answer, the answer exactly when its whole interval lies more than a step from the start."""
    design = design_experiments(np.array(start), [0, 1], step, (-10.0, 10.0), two_sided=True)
    region = np.column_stack([np.subtract(answer, width), np.add(answer, width)])
    placed = second_side(design, [0, 1], np.array(answer), step, region)
    np.testing.assert_array_equal(placed[[0, 1, 3]], design[[0, 1, 3]])
    for k, row in ((0, 2), (1, 4)):
        other = 1 - k
        assert placed[row, other] == design[row, other]
        low, high = region[k] - start[k]
        beyond = low > step * (1 + 1e-9) or high < -step * (1 + 1e-9)  # on one side, whole
        assert placed[row, k] == (answer[k] if beyond else design[row, k])


def test_the_pair_bias_of_an_exact_law_is_the_closed_form() -> None:
    from tuning.test_tuning import exact_model

    truth = CloverleafGyro(noise=0, feedthrough=0, extra_modes=False, dac_bits=0).truth
    model = exact_model(truth, ["B1", "B2"])
    v = pair_bias(model, np.zeros(2), (-10.0, 10.0), truth.structure_potential)
    exact = degenerate_bias(truth.K0, truth.Kp, truth.M, truth.structure_potential, (0, 1))
    assert v is not None
    np.testing.assert_allclose(v, exact[:2], rtol=1e-9)
    f = truth.modal_frequencies_hz(np.array([*v, 0.0]))
    assert f[1] - f[0] < 1e-6  # degenerate by the truth itself
    # limits that exclude B2's root leave no answer; more than two electrodes have no pair bias
    assert pair_bias(model, np.zeros(2), (-4.0, 4.0), truth.structure_potential) is None
    three = exact_model(truth, ["B1", "B2", "B3"])
    assert pair_bias(three, np.zeros(3), (-10.0, 10.0), truth.structure_potential) is None


def test_a_pairs_second_steps_go_to_the_answer_of_its_scouts(tmp_path: Path) -> None:
    """The cloverleaf given B1, B2 and B3: the scouts step each up by 1 V, their law chooses B2
    and B3 (the truth's degenerate bias 4.351, -1.751 V) and places the answer; each second step
    goes there, within the scouts' error, where the design stepped down by 1 V before. The
    first answer's true split over five noise draws: 0.16-1.64 mHz (0.91-2.96 mHz with the steps
    down; four runs of five then took a second iteration, one of five now)."""
    job = {**MAIN_JOB, "tuning": {**MAIN_JOB["tuning"], "electrodes": ["B1", "B2", "B3"]}}
    dev, lines = Recording(seed=1), []
    run = TuningRun(parse_config(job), tmp_path, device=dev, plots=False, progress=lines.append)
    summary = run.run()
    bias = [b for b, _ in dev.calls]
    said = [line for line in lines if "second design steps at the scouts' answer" in line]
    assert said and "B2 at 4.3" in said[0] and "B3 at -1.7" in said[0], lines
    assert bias[1:4] == [(1.0, 0.0, 0.0), (0.0, 1.0, 0.0), (0.0, 0.0, 1.0)]  # the scouts
    assert summary.tuned == ["B2", "B3"]
    exact = [4.351, -1.751]
    assert bias[4][0] == bias[4][2] == 0.0 and bias[4][1] == pytest.approx(exact[0], abs=0.1)
    assert bias[5][0] == bias[5][1] == 0.0 and bias[5][2] == pytest.approx(exact[1], abs=0.1)
    first = summary.history[0]
    assert dev.true_split_hz(first.verified_bias) < 3e-3


def test_a_run_given_two_electrodes_keeps_the_order_of_eq_18(tmp_path: Path) -> None:
    """Each electrode up, then down: measuring both first steps first would part an electrode's
    two steps in time, and the drift between them lengthened every run where only that order
    changed (the study)."""
    dev = Recording(seed=1)
    TuningRun(parse_config(MAIN_JOB), tmp_path, device=dev, plots=False).run()
    bias = [b[:2] for b, _ in dev.calls[1:5]]
    assert bias == [(1.0, 0.0), (-1.0, 0.0), (0.0, 1.0), (0.0, -1.0)]
