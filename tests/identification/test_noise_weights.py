"""Per-point noise variances (``noise_var``) weight the fit: a noisier sweep counts less."""

from __future__ import annotations

import numpy as np
import pytest
import xarray as xr
from truths import PAPER_FREQS, cloverleaf_truth

from sysid_core import fit
from sysid_core.conic.program import sym
from sysid_core.data.schema import (
    concat_experiments,
    experiment_from_measurement,
    make_dataset,
    squared_potentials,
)
from sysid_core.device.simulation import GyroTruth
from sysid_core.identification.problem import FitProblem
from sysid_core.model.fitted import FittedModel
from sysid_core.model.modal import normalised_stiffness, trace_deviation
from sysid_core.model.structures import ModelStructure
from sysid_core.plugin.registry import get_registry
from sysid_core.tuning.confidence import stiffness_vector

TRUTH = cloverleaf_truth()
#: Five experiments (more than the n_e + 1 = 3 the design needs, so that any one can count less).
BIASES = np.array([[0.0, 0.0], [1.0, 0.0], [0.0, 1.0], [1.0, 1.0], [0.5, -0.5]])
#: Noise per entry relative to each experiment's peak: the first sweep is 30 times noisier.
NOISE_RATIO = 30.0
NOISE = np.array([NOISE_RATIO, 1.0, 1.0, 1.0, 1.0]) * 1e-4
#: Degrees of freedom of each variance estimate (a lock-in's 16 complex sub-integrations).
DOF = 30
#: Where the modal frequencies are compared with the truth.
CHECK_BIASES = [[0.0, 0.0], [1.0, 0.0], [0.0, 1.0], [2.04, 4.39], [-3.0, 5.0]]
SEEDS = range(4)


def noisy_data(
    seed: int, variances: bool = True, keep: list[int] | None = None, truth: GyroTruth = TRUTH
) -> xr.Dataset:
    """The experiments of ``BIASES`` with complex noise of standard deviation ``NOISE`` times
    the largest peak and (``variances``) its measured variance per point and channel (the
    true one times chi²(DOF)/DOF)."""
    rng = np.random.default_rng(seed)
    clean = [truth.response(bias, PAPER_FREQS) for bias in BIASES]
    peak = max(float(np.abs(r).max()) for r in clean)
    responses, noise_var = [], []
    for r, level in zip(clean, NOISE, strict=True):
        sigma = level * peak
        n = (
            sigma
            / np.sqrt(2.0)
            * (rng.standard_normal(r.shape) + 1j * rng.standard_normal(r.shape))
        )
        responses.append(r + n)
        noise_var.append(sigma**2 * rng.chisquare(DOF, r.shape) / DOF)
    idx = list(range(len(BIASES))) if keep is None else keep
    return make_dataset(
        [responses[k] for k in idx],
        PAPER_FREQS,
        BIASES[idx],
        list(truth.electrodes),
        truth.structure_potential,
        noise_var=[noise_var[k] for k in idx] if variances else None,
    )


def least_squares(ds: xr.Dataset, objective: str = "least-squares") -> FittedModel:
    """The paper's model (``act``, order 1, linear law) fitted to ``ds``."""
    return fit(ds, "act", 1, objective, bias_terms=0, stiffness="linear")


def paper_structure() -> ModelStructure:
    return get_registry().structure("act", order=1, bias_terms=0, stiffness="linear")


def frequency_error(model: FittedModel) -> float:
    """Largest error of the fitted modal frequencies (Hz) over ``CHECK_BIASES``."""
    return max(
        float(np.abs(model.modal(b).frequencies_hz - TRUTH.modal_frequencies_hz(b)).max())
        for b in CHECK_BIASES
    )


def _split(phi: np.ndarray, w: np.ndarray) -> float:
    """The split (Hz) of the stiffness parameters ``phi`` (``stiffness_vector`` order) at ``w``."""
    k = sym(phi[None, 3:6]) + sum(
        w[p] * sym(phi[None, 6 + 3 * p : 9 + 3 * p]) for p in range(w.size)
    )
    t, d = trace_deviation(normalised_stiffness(sym(phi[None, 0:3]), k))
    r = float(np.hypot(*d[0]))
    return float((np.sqrt(t[0] + r) - np.sqrt(t[0] - r)) / (2 * np.pi))


def split_sigma(model: FittedModel, bias: list[float]) -> float:
    """Standard deviation of the split at ``bias`` (Hz) by the fit's own covariance (first
    order, the Jacobian by central differences)."""
    assert model.stiffness_factor is not None
    phi = stiffness_vector(model)
    w = squared_potentials(model.structure_potential, bias)
    assert abs(_split(phi, w) - model.split_hz(bias)) < 1e-9
    jac = np.zeros(phi.size)
    for i in range(phi.size):
        h = 1e-7 * max(abs(float(phi[i])), float(np.abs(phi).max()) * 1e-6)
        up, down = phi.copy(), phi.copy()
        up[i] += h
        down[i] -= h
        jac[i] = (_split(up, w) - _split(down, w)) / (2 * h)
    return float(np.linalg.norm(jac @ model.stiffness_factor))


# ----------------------------------------------------------------------------- the weights
def test_a_noisier_sweep_counts_less_in_the_problem() -> None:
    """Each point's rows are scaled by 1/√(its sweep's pooled variance), normalised to mean
    square 1."""
    ds = noisy_data(0)
    problem = FitProblem(ds, paper_structure())
    plain = FitProblem(ds.drop_vars("noise_var"), paper_structure())
    assert plain.weights is None and plain.noise_variance is None
    assert problem.weights is not None and problem.noise_variance is not None
    pooled = ds["noise_var"].values.mean(axis=(1, 2, 3))  # one per sweep (all points measured)
    v = np.repeat(pooled, ds.sizes["frequency"])  # experiment-major, like the points
    np.testing.assert_allclose(problem.noise_variance, v, rtol=1e-12)
    np.testing.assert_allclose(problem.weights, v**-0.5 / np.sqrt(np.mean(1 / v)), rtol=1e-12)
    assert np.mean(problem.weights**2) == pytest.approx(1.0, rel=1e-12)
    np.testing.assert_allclose(problem.G, plain.G * problem.weights[:, None, None], rtol=1e-15)
    # the noisy sweep's points weigh a thirtieth of the others' (each sweep's pooled estimate
    # is within a few per cent of its truth)
    by_experiment = [np.median(problem.weights[problem.experiment == k]) for k in range(5)]
    ratio = np.array(by_experiment[1:]) / by_experiment[0]
    np.testing.assert_allclose(ratio, NOISE_RATIO, rtol=0.1)


def test_scaling_every_variance_changes_nothing() -> None:
    """Only relative variances matter: the weights are normalised."""
    ds = noisy_data(1)
    scaled = ds.assign(noise_var=ds["noise_var"] * 1e6)
    structure = paper_structure()
    a, b = FitProblem(ds, structure), FitProblem(scaled, structure)
    assert a.weights is not None and b.weights is not None
    np.testing.assert_allclose(a.weights, b.weights, rtol=1e-12)


# --------------------------------------------------------------------- (a) the proof
def test_the_weighted_fit_trusts_the_quiet_sweeps() -> None:
    """One sweep 30 times noisier than the others, and its noise_var says so: the weighted fit is
    as good as the quiet sweeps allow; the unweighted one (same data, no noise_var) is not.

    The margins come from the noise: the unweighted fit's errors scale with the noisy sweep's
    level, the weighted fit's with the quiet sweeps' (a factor up to 30 apart); the test asks
    for a sixth of that. The split error is compared with the standard deviation that the
    quiet sweeps alone give (their fit's covariance).
    """
    weighted_err, unweighted_err = [], []
    bias = [0.0, 0.0]
    true_split = TRUTH.split_hz(bias)
    for seed in SEEDS:
        weighted = least_squares(noisy_data(seed))
        unweighted = least_squares(noisy_data(seed, variances=False))
        quiet = least_squares(noisy_data(seed, keep=[1, 2, 3, 4]))
        assert weighted.meta["noise_weights"] is True
        assert unweighted.meta["noise_weights"] is False
        weighted_err.append(frequency_error(weighted))
        unweighted_err.append(frequency_error(unweighted))
        sigma = split_sigma(quiet, bias)
        # within a few sigma of what the quiet sweeps allow
        assert abs(weighted.split_hz(bias) - true_split) < 4.0 * sigma
        # and the weighted fit's own confidence says so too: it is the quiet sweeps' (its
        # covariance comes from the weighted problem), the unweighted one's far wider
        own = split_sigma(weighted, bias)
        assert 0.75 * sigma < own < 1.33 * sigma
        assert split_sigma(unweighted, bias) > NOISE_RATIO / 3 * own
    rms_weighted = float(np.sqrt(np.mean(np.square(weighted_err))))
    rms_unweighted = float(np.sqrt(np.mean(np.square(unweighted_err))))
    assert rms_unweighted > NOISE_RATIO / 6 * rms_weighted, (rms_weighted, rms_unweighted)


def test_the_weights_follow_what_the_noise_says() -> None:
    """Variances that lie (the quiet sweeps said noisy, the noisy one quiet) make the fit worse
    than no weights: the fit goes the way the stated noise says, not the data's own scatter."""
    ds = noisy_data(2)
    lying = ds.copy()
    var = ds["noise_var"].values.copy()
    var[0], var[1:] = var[0] / NOISE_RATIO**2, var[1:] * NOISE_RATIO**2
    lying["noise_var"] = (ds["noise_var"].dims, var)
    honest = frequency_error(least_squares(ds))
    none = frequency_error(least_squares(ds.drop_vars("noise_var")))
    lied = frequency_error(least_squares(lying))
    assert honest < none < lied


# ------------------------------------------------------------- (b) equal noise: no change
@pytest.mark.parametrize("objective", ["least-squares", "minimax"])
def test_equal_variances_fit_exactly_as_without(objective: str) -> None:
    ds = noisy_data(3, variances=False)
    equal = ds.assign(noise_var=(ds["response"].dims, np.full(ds["response"].shape, 2.5e-9)))
    a, b = least_squares(ds, objective), least_squares(equal, objective)
    assert not a.meta["noise_weights"] and not b.meta["noise_weights"]
    assert b.gamma == pytest.approx(a.gamma, rel=1e-12, abs=0)
    for name in ("M", "C", "K0", "Kp", "poly"):
        np.testing.assert_allclose(getattr(b, name), getattr(a, name), rtol=1e-12, atol=0)
    if objective == "least-squares":
        assert a.stiffness_factor is not None and b.stiffness_factor is not None
        np.testing.assert_allclose(b.stiffness_factor, a.stiffness_factor, rtol=1e-12, atol=0)


def test_a_point_of_unknown_noise_leaves_the_fit_unweighted() -> None:
    """The weights need a variance at every point: one NaN (unknown) and none is used."""
    ds = noisy_data(0)
    var = ds["noise_var"].values.copy()
    var[2, 40, 1, 0] = np.nan
    partial = ds.assign(noise_var=(ds["noise_var"].dims, var))
    structure = paper_structure()
    problem, plain = (
        FitProblem(partial, structure),
        FitProblem(ds.drop_vars("noise_var"), structure),
    )
    assert problem.weights is None and problem.noise_variance is None
    np.testing.assert_array_equal(problem.G, plain.G)


def test_a_simulated_run_is_weighted_and_its_variances_are_right() -> None:
    """The simulated cloverleaf's measured noise_var reaches the fit: the model says it was
    weighted, and a sweep 30 times noisier weighs a thirtieth."""
    quiet = get_registry().create("device", "cloverleaf", seed=4, noise=1e-4)
    loud = get_registry().create("device", "cloverleaf", seed=5, noise=1e-4 * NOISE_RATIO)
    parts = []
    for k, bias in enumerate(([0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [1.0, 1.0, 0.0])):
        device = loud if k == 0 else quiet
        parts.append(
            experiment_from_measurement(
                device.measure(bias, PAPER_FREQS),
                bias,
                device.electrodes,
                device.structure_potential,
            )
        )
    ds = concat_experiments(parts).sel(electrode=["B1", "B2"])
    assert "noise_var" in ds
    model = least_squares(ds)
    assert model.meta["noise_weights"] is True
    problem = FitProblem(ds, model.structure)
    assert problem.weights is not None
    loud_w = problem.weights[problem.experiment == 0]
    quiet_w = problem.weights[problem.experiment != 0]
    assert np.median(quiet_w) / np.median(loud_w) == pytest.approx(NOISE_RATIO, rel=0.1)
