"""The quadratic stiffness law (``[model] stiffness = "quadratic"``): K(w) = K0 + Σ K_p w_p +
Σ L_p w_p², fitted from a two-sided design, tuned by repeated linearization.

Truths: a model of the class itself (exact recovery, exact tuning) and random gyros whose bias
law is not v² (the law's use: the second iteration under 2 mHz).
"""

from __future__ import annotations

import dataclasses
from pathlib import Path

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from sysid_random_gyro import RandomGyro

from sysid_core import errors, fit, load_model, tune
from sysid_core.data.schema import make_dataset
from sysid_core.data.validation import check_rank_condition
from sysid_core.identification.law import split_part
from sysid_core.measure.sweeps import design_experiments
from sysid_core.model.fitted import FittedModel
from sysid_core.plugin.registry import get_registry
from sysid_core.tuning.confidence import confidence_region
from sysid_core.tuning.criteria import BiasSpace, frequencies_from_w, solve_criterion
from tests.truths import (
    PAPER_BIASES,
    PAPER_FREQS,
    V_GYRO,
    ModelTruth,
    cloverleaf_truth,
    simulate,
)

#: A random gyro (6 electrodes, 19.3 kHz, native split 11 Hz) that the linear law leaves at
#: 165 mHz after two iterations (runs/study-random-degenerate) and the quadratic under 2 mHz.
SEED = 9
TWO_SIDED = design_experiments(np.zeros(2), [0, 1], 1.0, (-10.0, 10.0), two_sided=True)


@pytest.fixture(scope="module")
def truth_model() -> FittedModel:
    """A model of the class: the cloverleaf's fitted linear model plus L_p that change each
    electrode's stiffness by about 4 % per 10 V (a gap that closes with the bias)."""
    base = fit(simulate(cloverleaf_truth(), PAPER_BIASES, PAPER_FREQS), bias_terms=0, order=1)
    w_c = (V_GYRO - 0.0) ** 2
    return dataclasses.replace(base, Lp=-0.04 * base.Kp / (w_c * 0.3), stiffness_factor=None)


def _space(n: int = 2) -> BiasSpace:
    names = [f"B{p + 1}" for p in range(n)]
    return BiasSpace(names, names, np.zeros(n), (-10.0, 10.0), V_GYRO)


def _degenerate():
    reg = get_registry()
    return reg.criterion("degenerate", solver=reg.solver("clarabel"))


def test_two_sided_design_and_its_rank_condition() -> None:
    np.testing.assert_allclose(TWO_SIDED, [[0, 0], [1, 0], [-1, 0], [0, 1], [0, -1]])
    check_rank_condition(TWO_SIDED, V_GYRO, quadratic=True)
    with pytest.raises(errors.TooFewExperimentsError, match=r"L1\.\.L2"):
        check_rank_condition(PAPER_BIASES, V_GYRO, quadratic=True)
    one_level = np.array([[0, 0], [1, 0], [1, 0.0], [0, 1], [0, 1]])
    with pytest.raises(errors.RankConditionError, match="two-sided"):
        check_rank_condition(one_level, V_GYRO, quadratic=True)
    # at a limit the electrode takes two steps on the side that fits
    edge = design_experiments(np.array([9.5, 0.0]), [0], 1.0, (-10.0, 10.0), two_sided=True)
    np.testing.assert_allclose(edge[:, 0], [9.5, 8.5, 7.5])
    with pytest.raises(errors.ConfigError, match="two-sided"):
        design_experiments(np.zeros(1), [0], 11.0, (-10.0, 10.0), two_sided=True)


#: Relative accuracy of a conic solve at the solver's default tolerances (Clarabel: gap and
#: feasibility 1e-8).
SOLVER_TOL = 1e-8


def recovery_tol(model: FittedModel) -> float:
    """How close an exact fit's parameters must be to the truth, relative to their size.

    A relative error ``SOLVER_TOL`` in the equation errors becomes at most
    ``sqrt(κ)·SOLVER_TOL`` in the unknowns, κ the normal matrix's condition (``meta``); with the
    orthogonal basis κ is about 15 here, and a factor 100 covers the map back to physical units
    (a sum of O(1) terms) and the data's own rounding. The quadratic law's old basis had
    κ ≈ 9e3 and recovered ``L_p`` 1.48 times too large with one OpenBLAS kernel.
    """
    return 100 * SOLVER_TOL * float(np.sqrt(model.meta["normal_condition"]))


def _close(got: np.ndarray, want: np.ndarray, rel: float) -> None:
    np.testing.assert_allclose(got, want, rtol=0, atol=rel * np.abs(want).max())


def test_fit_recovers_the_quadratic_law_and_tunes_it_exactly(truth_model) -> None:
    ds = simulate(ModelTruth(truth_model), TWO_SIDED, PAPER_FREQS)
    model = fit(ds, order=1, bias_terms=0, stiffness="quadratic")
    assert model.Lp is not None and model.structure.stiffness == "quadratic"
    assert model.meta["n_parameters"] == 31 + 6
    assert model.meta["normal_condition"] < 100 and model.meta["law_condition"] < 100
    tol = recovery_tol(model)
    assert tol < 1e-5
    _close(model.Lp, truth_model.Lp, tol)
    _close(model.Kp, truth_model.Kp, tol)
    _close(model.K0, truth_model.K0, tol)
    _close(model.M, truth_model.M, tol)
    exact, _ = solve_criterion(_degenerate(), truth_model, _space())
    f = frequencies_from_w(truth_model, exact.w)
    assert f[1] - f[0] < 1e-7  # the linearizations settle on the quadratic model's answer
    answer, local = solve_criterion(_degenerate(), model, _space())
    np.testing.assert_allclose(answer.bias, exact.bias, atol=1e-6)
    assert local.Lp is None and np.allclose(
        local.stiffness_w(answer.w), model.stiffness_w(answer.w)
    )
    # the linear law on the same data misses the answer by far more
    linear = fit(ds, order=1, bias_terms=0, stiffness="linear")
    wrong = _degenerate().solve(linear, _space())
    assert np.max(np.abs(wrong.bias - exact.bias)) > 100 * np.max(np.abs(answer.bias - exact.bias))


@pytest.mark.parametrize("objective", ["least-squares", "minimax"])
def test_quadratic_fit_is_stable_under_rounding_level_perturbations(truth_model, objective) -> None:
    """Data perturbed at the 1e-12 relative level (what another BLAS kernel's rounding does)
    give the same ``K_p``, ``L_p`` to 1e-6."""
    ds = simulate(ModelTruth(truth_model), TWO_SIDED, PAPER_FREQS)
    model = fit(ds, order=1, bias_terms=0, stiffness="quadratic", objective=objective)
    rng = np.random.default_rng(12)
    for _ in range(3):
        shaken = ds.copy(deep=True)
        r = shaken["response"].values
        shaken["response"].values = r * (
            1 + 1e-12 * (rng.standard_normal(r.shape) + 1j * rng.standard_normal(r.shape))
        )
        again = fit(shaken, order=1, bias_terms=0, stiffness="quadratic", objective=objective)
        assert again.Lp is not None and model.Lp is not None
        _close(again.Lp, model.Lp, 1e-6)
        _close(again.Kp, model.Kp, 1e-6)


def test_exact_fit_has_unit_mass_whatever_the_solver_stops_at(truth_model) -> None:
    """The scale of an exact fit is a ray of optima (M ⪰ I is an inequality): the fit is
    normalised to λ_min(M) = 1, so the truth (M = I) is recovered, not a multiple of it."""
    ds = simulate(ModelTruth(truth_model), TWO_SIDED, PAPER_FREQS)
    model = fit(ds, order=1, bias_terms=0, stiffness="quadratic", objective="minimax")
    assert np.linalg.eigvalsh(model.M).min() == pytest.approx(1.0, abs=1e-9)
    _close(model.Kp, truth_model.Kp, recovery_tol(model))


def test_a_design_that_does_not_identify_the_law_falls_back_to_linear(truth_model) -> None:
    """Two levels of B1 1e-6 of a step apart: the orthogonal basis would still solve, but
    ``L_1`` is not identified (condition ~1e12 in the plain basis): the linear law is fitted,
    with a FitWarning, a progress line and ``meta`` that say why."""
    design = TWO_SIDED.copy()
    design[2, 0] = 1.0 + 1e-6
    ds = simulate(ModelTruth(truth_model), design, PAPER_FREQS, noise_peak=1e-4, seed=1)
    lines: list[str] = []
    with pytest.warns(errors.FitWarning, match="not identified"):
        model = fit(ds, order=1, bias_terms=0, stiffness="quadratic", progress=lines.append)
    assert model.Lp is None and model.structure.stiffness == "linear"
    assert model.meta["stiffness_law"] == "linear" and model.meta["law_condition"] > 1e10
    assert any("not identified" in line for line in lines)
    with pytest.warns(errors.FitWarning, match="not identified"):
        auto = fit(ds, order=1, bias_terms=0, stiffness="auto")
    assert auto.meta["stiffness_law"] == "linear" and "not identified" in auto.meta["law_test"]


@settings(max_examples=30, deadline=None)
@given(
    st.lists(st.floats(50.0, 400.0), min_size=2, max_size=2),
    st.floats(0.1, 1.0),
    st.sampled_from([-1.0, 1.0]),
)
def test_linearization_is_the_tangent(truth_model, w0, size, sign) -> None:
    """Value and slope of the linearized stiffness agree with the quadratic one at ``w0``."""
    w0 = np.array(w0)
    local = truth_model.linearized(w0)
    np.testing.assert_allclose(local.stiffness_w(w0), truth_model.stiffness_w(w0), rtol=1e-12)
    # steps of at least 0.1 V²: smaller ones only measure the rounding of K (about 1e9 (rad/s)²)
    dw = sign * size
    h = np.array([dw, -0.5 * dw])
    slope_true = (truth_model.stiffness_w(w0 + h) - truth_model.stiffness_w(w0 - h)) / 2
    np.testing.assert_allclose(
        local.stiffness_w(w0 + h) - local.stiffness_w(w0), slope_true, rtol=1e-6, atol=1e-9
    )


def test_quadratic_model_round_trip_and_region(tmp_path: Path, truth_model) -> None:
    ds = simulate(ModelTruth(truth_model), TWO_SIDED, PAPER_FREQS, noise_peak=1e-4, seed=2)
    model = fit(ds, order=1, bias_terms=0, stiffness="quadratic")
    assert model.stiffness_factor is not None and model.stiffness_factor.shape[0] == 6 + 12
    again = load_model(model.save(tmp_path / "q.model.nc"))
    assert again.structure.stiffness == "quadratic"
    np.testing.assert_array_equal(again.Lp, model.Lp)
    answer, local = solve_criterion(_degenerate(), again, _space())
    region = confidence_region(local, answer, _space())
    assert region is not None
    exact, _ = solve_criterion(_degenerate(), truth_model, _space())
    lo, hi = region.bias_ci[:, 0], region.bias_ci[:, 1]
    assert np.all(lo <= exact.bias) and np.all(exact.bias <= hi)
    assert np.max(hi - lo) < 0.05


def test_random_gyro_second_iteration_under_2_mhz(tmp_path: Path) -> None:
    """The bias law is not v²: two iterations of the quadratic law tune it under 2 mHz."""
    gyro = RandomGyro(seed=SEED)
    config = {
        "device": {"name": "random-gyro", "seed": SEED},
        "model": {"structure": gyro.structure, "stiffness": "quadratic"},
        "tuning": {
            "criterion": "degenerate",
            "electrodes": ["B1", "B2"],
            "start_bias": [0.0] * len(gyro.electrodes),
            "max_iterations": 2,
            "acceptance_hz": 1e-12,
        },
        # the full protocol: each iteration identifies from its own (two-sided) design
        "experiment": {"protocol": "full", "resolution_hz": 1.0, "verify_resolution_hz": 0.02},
    }
    result = tune(config, tmp_path / "run", plots=False)
    assert len(result.history) == 2
    assert len(result.history[0].experiments) == 5  # two-sided by default with this law
    assert gyro.true_split_hz(result.bias) < 0.002


def test_auto_keeps_the_law_the_data_show(truth_model) -> None:
    """``stiffness = "auto"``: a v² truth (the cloverleaf's) stays linear (the 99 % Wald test
    rejects a true linear law 1 time in 100: at most 1 of 20 seeds here), the quadratic truth
    is found every time; a one-sided design cannot show L_p and stays linear."""
    linear_truth = cloverleaf_truth()
    kept = []
    for seed in range(20):
        ds = simulate(linear_truth, TWO_SIDED, PAPER_FREQS, noise_peak=1e-4, seed=seed)
        kept.append(fit(ds, stiffness="auto").meta["stiffness_law"])
    assert kept.count("quadratic") <= 1
    for seed in range(5):
        ds = simulate(ModelTruth(truth_model), TWO_SIDED, PAPER_FREQS, noise_peak=1e-4, seed=seed)
        model = fit(ds, order=1, bias_terms=0, stiffness="auto")
        assert model.meta["stiffness_law"] == "quadratic" and model.Lp is not None
        assert model.meta["law_statistic"] > model.meta["law_threshold"]
    one_sided = simulate(linear_truth, PAPER_BIASES, PAPER_FREQS, noise_peak=1e-4)
    model = fit(one_sided, stiffness="auto")
    assert model.meta["stiffness_law"] == "linear" and model.Lp is None
    assert "does not identify" in model.meta["law_test"]


class _Warming:
    """``simulate``'s truth protocol for a gyro whose frequencies all rise by ``ppm[k]`` parts
    per million in its k-th sweep: a bench warming during a design, both modes together."""

    def __init__(self, truth, ppm: list[float]) -> None:
        self.truth, self.ppm, self.k = truth, ppm, 0
        self.electrodes = truth.electrodes
        self.structure_potential = truth.structure_potential

    def response(self, bias: np.ndarray, freqs: np.ndarray) -> np.ndarray:
        scale = 1.0 + self.ppm[self.k] * 1e-6
        self.k += 1
        return self.truth.response(bias, np.asarray(freqs) / scale)


def test_a_drift_of_both_modes_is_not_a_quadratic_law() -> None:
    """Both modes moving 2.2 mHz a sweep during a two-sided design (0.5 ppm at 4.4 kHz: a good
    lab's temperature over a design) leave a v² gyro's law linear. A test of every entry of
    ``L_p`` took that common move for a quadratic law: statistics of 3000-10000 against a 99 %
    threshold of 16.8, every seed; the test of the part that splits the modes, which data with
    time stamps get, stays at the noise's 0-4 against 13.3."""
    design = design_experiments(np.array([4.0, -6.0]), [0, 1], 1.0, (-10.0, 10.0), True)
    laws = []
    for seed in range(10):
        warming = _Warming(cloverleaf_truth(), [0.0, 0.5, 1.0, 1.5, 2.0])
        ds = simulate(warming, design, PAPER_FREQS, noise_peak=1e-4, seed=seed)
        # a sweep every 3 minutes, a point every 1.5 s: data with time stamps
        ds = make_dataset(
            [ds["response"].values[k] for k in range(len(design))],
            PAPER_FREQS,
            design,
            list(ds["electrode"].values),
            V_GYRO,
            times_s=[180.0 * k + 1.5 * np.arange(PAPER_FREQS.size) for k in range(len(design))],
        )
        model = fit(ds, stiffness="auto")
        assert model.meta["law_tested"] == "split"
        laws.append(model.meta["stiffness_law"])
    assert laws.count("quadratic") <= 1
    # the same data without time stamps: every entry is tested, and the drift shows
    frozen = simulate(_Warming(cloverleaf_truth(), [0.0, 0.5, 1.0, 1.5, 2.0]), design, PAPER_FREQS)
    model = fit(frozen, stiffness="auto")
    assert model.meta["law_tested"] == "all" and model.meta["stiffness_law"] == "quadratic"


@settings(max_examples=50, deadline=None)
@given(st.floats(0.5, 2.0), st.floats(0.5, 2.0), st.floats(-0.4, 0.4), st.floats(-5.0, 5.0))
def test_the_split_part_ignores_a_term_shaped_like_the_mass(
    m11: float, m22: float, corr: float, scale: float
) -> None:
    """A stiffness term ``c M`` moves both modes by the same factor: no split part. A term
    that stiffens one axis has one."""
    m12 = corr * np.sqrt(m11 * m22)
    part = split_part(np.array([[m11, m12], [m12, m22]]))
    np.testing.assert_allclose(part @ (scale * np.array([m11, m12, m22])), 0.0, atol=1e-12)
    assert np.linalg.norm(part @ np.array([1.0, 0.0, 0.0])) > 0.1 / max(m11, m22)
