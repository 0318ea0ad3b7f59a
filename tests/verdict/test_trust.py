"""The trust region of the linearised step (:func:`sysid_core.verdict.trust.trust_radius`)."""

from __future__ import annotations

from types import SimpleNamespace
from typing import cast

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st
from truths import PAPER_BIASES, PAPER_FREQS, V_GYRO, cloverleaf_truth, simulate

from sysid_core import fit
from sysid_core.model.fitted import FittedModel
from sysid_core.plugin.registry import get_registry
from sysid_core.tuning.criteria import BiasSpace, solve_criterion
from sysid_core.verdict.trust import AGREED, DISAGREED, GROW, trust_radius, untrusted_step

START = 0.25
ACCEPTANCE = 1e-3


def _step(radius: float, length: float, before: float, predicted: float) -> dict[str, float]:
    return {
        "radius_v": radius,
        "length_v": length,
        "from_split_hz": before,
        "predicted_split_hz": predicted,
    }


@pytest.mark.parametrize(
    ("last", "measured", "expected"),
    [
        (None, None, START),  # no linearised step yet: the local design's step
        (_step(0.5, 0.5, 1.0, 0.5), 0.52, 1.0),  # fell as predicted, to the edge: twice as far
        (_step(0.5, 0.5, 1.0, 0.5), 1.0 - AGREED * 0.5, 1.0),  # exactly three quarters
        (_step(0.5, 0.2, 1.0, 0.5), 0.5, 0.5),  # as predicted, short of the edge: the same
        (_step(0.5, 0.5, 1.0, 0.5), 0.75, 0.5),  # half the predicted fall: the same
        (_step(1.0, 1.0, 1.0, 0.5), 0.95, START),  # a tenth of it: back to the local step
        (_step(1.0, 1.0, 1.0, 0.5), 1.0 - DISAGREED * 0.5 + 1e-9, START),  # just under a quarter
        (_step(1.0, 1.0, 1.0, 0.5), 1.2, START),  # it rose
        (_step(1.0, 1.0, 1.0, 0.5), None, START),  # not verified
        (_step(1.0, 1.0, 1.0, 1.1), 0.5, START),  # its model promised no fall
        (_step(0.25, 0.24, 1.0, 0.5), 0.5, GROW * 0.25),  # a DAC code short of the edge
        (_step(0.0625, 0.0625, 1.0, 0.0), 0.0, START),  # grown from under the local step
    ],
)
def test_the_radius_follows_how_well_the_model_predicted_the_last_step(
    last: dict[str, float] | None, measured: float | None, expected: float
) -> None:
    """The textbook update: grow after a step to the edge that fell as predicted, back to the
    local design's step after one that did not."""
    assert trust_radius(last, measured, START) == pytest.approx(expected)


@given(
    radius=st.floats(0.01, 5.0),
    share=st.floats(0.0, 1.0),
    before=st.floats(1e-4, 10.0),
    predicted_share=st.floats(0.0, 1.5),
    measured_share=st.floats(0.0, 2.0),
)
def test_the_radius_stays_between_the_local_step_and_twice_the_last(
    radius: float, share: float, before: float, predicted_share: float, measured_share: float
) -> None:
    """Whatever the last step did, the next radius is no shorter than the local design's step
    and no longer than twice the last radius (or the local step, if longer)."""
    last = _step(radius, share * radius, before, predicted_share * before)
    found = trust_radius(last, measured_share * before, START)
    assert START <= found <= GROW * max(radius, START)


def _steps(model: FittedModel, far: np.ndarray, bias: np.ndarray, grow: bool) -> tuple[int, float]:
    """Linearised steps from ``bias`` until ``model`` (also the truth) is under the acceptance."""
    last, measured = None, None
    for n in range(60):
        split = model.split_hz(bias[:2])
        if split <= ACCEPTANCE:
            return n, split
        radius = trust_radius(last, measured, START) if grow else START
        stepped = untrusted_step(
            model, far, (split, bias), [0, 1], ACCEPTANCE, radius, 10.0, None, True
        )
        assert stepped is not None  # the far answer stays beyond the linearised step
        length = float(np.max(np.abs(stepped[:2] - bias[:2])))
        last = _step(radius, length, split, model.split_hz(stepped[:2]))
        measured, bias = model.split_hz(stepped[:2]), stepped
    return 60, model.split_hz(bias[:2])


@pytest.mark.parametrize("offset", [(-3.0, 2.0), (3.0, -3.0), (-4.0, -4.0)])
def test_a_model_that_predicts_its_steps_well_crosses_volts_in_a_few(
    offset: tuple[float, float],
) -> None:
    """The fitted cloverleaf, 3-4 V from its degenerate bias, its answer another root (the
    mirror of the near one across the structure's potential): steps of at most the local
    design's 0.25 V need at least one per quarter volt; a radius that doubles while the model
    predicts each step's split (here it is also the truth) needs about log2(distance / 0.25) of
    them and then the last corrections."""
    model = fit(simulate(cloverleaf_truth(), PAPER_BIASES, PAPER_FREQS))
    space = BiasSpace(["B1", "B2", "B3"], ["B1", "B2"], np.zeros(3), (-10.0, 10.0), V_GYRO)
    reg = get_registry()
    criterion = reg.criterion("degenerate", solver=reg.solver("clarabel"))
    root = solve_criterion(criterion, model, space)[0].bias
    far = np.array([2 * V_GYRO - root[0], root[1], 0.0])
    start = root + np.array([*offset, 0.0])
    distance = float(np.max(np.abs(offset)))
    fixed, _ = _steps(model, far, start.copy(), grow=False)
    grown, split = _steps(model, far, start.copy(), grow=True)
    assert fixed >= distance / START
    assert split <= ACCEPTANCE
    assert grown <= np.ceil(np.log2(distance / START + 1)) + 3 < fixed


def _valley(b: np.ndarray) -> np.ndarray:
    """A stiffness at 4.4 kHz whose split falls along ``b1 + b2`` to a least value of about
    6 mHz (the off-diagonal part no bias reaches) on the line ``b1 + b2 = 3`` V."""
    w0, x = (2 * np.pi * 4400.0) ** 2, 3.5e4 * (b[0] + b[1] - 3.0)
    return w0 * np.eye(2) + np.array([[x, 200.0], [200.0, -x]])


def test_a_linearised_law_with_no_way_down_takes_no_step() -> None:
    """Where the split is least but not zero (a law that cannot make the modes degenerate
    there), the linearised step is nothing and keeps the split where it is. A run that took it
    would verify that split again and again (seen on a bench written outside the toolkit: 223
    mHz for 300 iterations); an answer far from there is no correction the step could make,
    and stands. From a bias where the law does fall, the step stays the linearised one, no
    longer than the radius."""
    model = cast(FittedModel, SimpleNamespace(M=np.eye(2), stiffness=_valley))
    at = np.array([1.0, 2.0, 0.0])
    answer = np.array([4.0, 2.0, 0.0])
    latest = (6e-3, at)
    assert (
        untrusted_step(model, answer, latest, [0, 1], ACCEPTANCE, START, 10.0, local=True) is None
    )
    away = np.array([0.0, 2.0, 0.0])
    stepped = untrusted_step(
        model, answer, (0.1, away), [0, 1], ACCEPTANCE, START, 10.0, local=True
    )
    assert stepped is not None
    assert np.max(np.abs(stepped - away)) == pytest.approx(START)
