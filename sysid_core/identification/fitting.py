"""From a data set and component objects to a fitted model: :func:`fit_structure`.

The fit itself (the objective's conic programs on the scaled problem), the stiffness law's
choice (``"auto"``: a Wald test; a quadratic law the design does not identify falls back to the
linear law), the normalisation of an exact fit's scale, the map back to physical units and the
checks that say when a fit should not be trusted. Names of components are resolved one level
up, in :func:`sysid_core.api.fit`.
"""

from __future__ import annotations

import copy
import dataclasses
import time

import numpy as np
import xarray as xr
from threadpoolctl import threadpool_limits

from sysid_core.conic.program import Solver, sym
from sysid_core.data.schema import measured_mask
from sysid_core.data.validation import check_rank_condition
from sysid_core.errors import RankConditionError, TooFewExperimentsError
from sysid_core.identification.covariance import stiffness_factor
from sysid_core.identification.drift import (
    NO_TIMING,
    Timing,
    estimate_drift,
    has_time_stamps,
    offset_facts,
)
from sysid_core.identification.law import LAW_TEST_LEVEL, law_statistic
from sysid_core.identification.objective import Objective, ObjectiveResult, Progress
from sysid_core.identification.problem import FitProblem
from sysid_core.model.fitted import DEFAULT_INPUTS, DEFAULT_OUTPUTS, FittedModel
from sysid_core.model.structures import ModelStructure

__all__ = [
    "LAW_CONDITION_LIMIT",
    "MASS_NORMALISE_TOL",
    "RESONANCE_RATIO",
    "TREND_LAW",
    "check_fit",
    "fit_structure",
    "model_from_problem",
    "unit_mass",
]

#: An experiment whose largest response is less than this many times its smallest shows no
#: resonance (a narrow window beside the modes, or a disconnected sensor).
RESONANCE_RATIO = 1.5

#: The quadratic law is not identified by a design whose normal matrix, in the plain centred
#: basis ``x, x² − mean(x²)``, has a larger condition number
#: (:meth:`~sysid_core.identification.problem.FitProblem.normal_condition`): the solver's relative
#: accuracy of about 1e-8 then becomes more than 1e-3 of ``L_p`` (the error grows as the square
#: root of the condition). Measured: a two-sided design has 8; one whose two levels of an electrode
#: differ by 1e-4 of the step, 1e8; by 1e-6, 1e12.
LAW_CONDITION_LIMIT = 1e10


#: Why a tracked run's fit over more than an hour, which carries the stiffness trend, keeps the
#: linear law (``linear_trend``). Its answers follow the charging, so its biases move with time
#: and quadratic terms take up what the trend leaves of the drift: measured on slow random gyros
#: in the uncontrolled lab (docs/studies/drift-lab.md, "Long runs"), the quadratic fits' Wald
#: statistic rose over a run (6.5 to 58-94 against 13.3 on a 1.8 kHz gyro) while their slopes of the
#: split in B1 and B2 left the truth's (50 % off; on another a sign turned, and its answers ran
#: away to a 50 mHz split). A fit asked for the trend alone (``fit(data, drift="trend")``) keeps
#: the test: its data may still need the quadratic law.
TREND_LAW = "the fit carries the trend: linear law, the quadratic terms would take up drift"


def fit_structure(
    dataset: xr.Dataset,
    structure: ModelStructure,
    objective: Objective,
    solver: Solver,
    progress: Progress | None = None,
    drift: bool | float = False,
    offsets: bool = False,
    trend: bool = False,
    mass_shape: np.ndarray | None = None,
    point_weights: np.ndarray | None = None,
    linear_trend: bool = False,
) -> tuple[FittedModel, list[str]]:
    """Fit ``structure`` to ``dataset`` with ``objective`` and ``solver``.

    Returns the model and the notes a user should read (one line each): the reasons to distrust
    it (:func:`check_fit`) and a quadratic law that fell back to the linear one. With
    ``structure.stiffness == "auto"`` the law is chosen by :func:`law_statistic`. ``drift``:
    ``True`` estimates a common frequency drift from the time stamps and fits the model of the
    gyro at the latest one (:mod:`sysid_core.identification.drift`; data without time stamps
    are fitted without, with a note); a number is a known rate (relative, per second).
    ``offsets``: a common offset for every earlier epoch of the data's ``epoch`` coordinate, in
    the shape ``mass_shape`` (default: identity)
    (:class:`~sysid_core.identification.problem.FitProblem`); the model is the gyro of the
    latest epoch. ``trend``: a stiffness trend in time, the model is the gyro at the latest time
    stamp (data without time stamps at every point are fitted without). ``point_weights``: a
    weight per measured point (:class:`~sysid_core.identification.problem.FitProblem`).
    ``linear_trend``: with the trend, the ``auto`` law is linear (:data:`TREND_LAW`).
    """
    notes: list[str] = []
    rate = 0.0
    if drift is True:
        if has_time_stamps(dataset):
            rate = estimate_drift(dataset, structure, objective, solver)
        else:
            notes.append("no time stamps at every point: the drift is not modelled")
    elif drift is not False:
        rate = float(drift) if has_time_stamps(dataset) else 0.0
    timing = Timing(rate, offsets, trend and has_time_stamps(dataset), mass_shape, point_weights)
    if getattr(structure, "stiffness", "linear") == "auto":
        model = _fit_auto_law(dataset, structure, objective, solver, progress, timing, linear_trend)
    else:
        model = _fit_one(dataset, structure, objective, solver, progress, timing)
    notes = check_fit(dataset, model) + notes
    law = model.facts.law
    if law is not None and law.fallback:
        notes.append(str(law.note))
    return model, notes


def _fit_one(
    dataset: xr.Dataset,
    structure: ModelStructure,
    objective: Objective,
    solver: Solver,
    progress: Progress | None,
    timing: Timing = NO_TIMING,
) -> FittedModel:
    """Fit ``structure`` to ``dataset``, with the linear law if the quadratic one is not identified.

    A quadratic law the design does not identify (see :data:`LAW_CONDITION_LIMIT`) falls back to
    the linear law, saying so in ``progress`` and in ``meta["law_test"]`` (a note of
    :func:`fit_structure`).
    """
    t0 = time.perf_counter()
    facts: dict[str, object] = {}
    with threadpool_limits(limits=1, user_api="blas"):
        problem = FitProblem(dataset, structure, *timing.problem_args())
        if problem.layout.quadratic:
            law_condition = problem.normal_condition(law_basis=True)
            facts["law_condition"] = law_condition
            if not law_condition <= LAW_CONDITION_LIMIT:
                linear = copy.copy(structure)
                linear.stiffness = "linear"
                problem = FitProblem(dataset, linear, *timing.problem_args())
                facts.update(
                    stiffness_law="linear",
                    law_fallback=True,
                    law_test=(
                        f"quadratic law not identified by this design (normal matrix condition "
                        f"{law_condition:.3g} > {LAW_CONDITION_LIMIT:.0e}): fitted the linear "
                        "law; step each electrode to two levels clearly apart"
                    ),
                )
                if progress is not None:
                    progress(str(facts["law_test"]))
        facts["normal_condition"] = problem.normal_condition()
        result = objective.fit(problem, solver, progress)
    elapsed = time.perf_counter() - t0
    result, mass_factor = unit_mass(problem, result)
    if mass_factor is not None:
        facts["mass_normalised"] = mass_factor
    if problem.drift_rate:
        facts.update(
            drift_rate_per_h=problem.drift_rate * 3600.0,
            drift_reference_time_s=problem.reference_time_s,
        )
    facts.update(offset_facts(problem, result.theta))
    return model_from_problem(problem, result, solver=solver.name, fit_time_s=elapsed, **facts)


def _fit_auto_law(
    dataset: xr.Dataset,
    structure: ModelStructure,
    objective: Objective,
    solver: Solver,
    progress: Progress | None,
    timing: Timing = NO_TIMING,
    linear_trend: bool = False,
) -> FittedModel:
    """``stiffness = "auto"``: the quadratic law where the data show it, else the linear one.

    With a design that identifies it (two-sided), the quadratic law is fitted and kept if the
    Wald test of its terms (:func:`law_statistic`; on data with time stamps, of their part that
    splits the modes) rejects them being 0 at
    :data:`LAW_TEST_LEVEL`; otherwise (or without a covariance, or with a one-sided design) the
    linear law is fitted to the same data. ``model.meta["stiffness_law"]`` says which, with the
    statistic and the threshold. With ``linear_trend`` and the trend, linear (:data:`TREND_LAW`).
    """
    import scipy.stats

    linear, quadratic = copy.copy(structure), copy.copy(structure)
    linear.stiffness, quadratic.stiffness = "linear", "quadratic"
    if linear_trend and timing.trend:
        model = _fit_one(dataset, linear, objective, solver, progress, timing)
        model.meta.update(stiffness_law="linear", law_test=TREND_LAW)
        return model
    bias = np.asarray(dataset["bias"].values, dtype=float)
    vg = float(dataset.attrs["structure_potential"])
    try:
        if bias.shape[1] == 0:
            raise TooFewExperimentsError("no bias electrodes: nothing depends on w")
        check_rank_condition(bias, vg, quadratic=True)
    except (RankConditionError, TooFewExperimentsError):
        model = _fit_one(dataset, linear, objective, solver, progress, timing)
        model.meta.update(stiffness_law="linear", law_test="design does not identify L_p")
        return model
    quad = _fit_one(dataset, quadratic, objective, solver, progress, timing)
    if quad.facts.law is not None and quad.facts.law.fallback:
        return quad
    # on a bench with a clock the part of L_p that moves both modes together holds the drift
    split_only = has_time_stamps(dataset)
    found = law_statistic(quad, split_only=split_only)
    if found is not None:
        stat, dof = found
        threshold = float(scipy.stats.chi2.ppf(LAW_TEST_LEVEL, dof))
        facts: dict[str, object] = {
            "law_statistic": stat,
            "law_threshold": threshold,
            "law_tested": "split" if split_only else "all",
        }
        if stat > threshold:
            quad.meta.update(stiffness_law="quadratic", **facts)
            return quad
    else:
        facts = {"law_test": "no covariance (minimax): the linear law is kept"}
    model = _fit_one(dataset, linear, objective, solver, progress, timing)
    model.meta.update(stiffness_law="linear", **facts)
    return model


def check_fit(dataset: xr.Dataset, model: FittedModel) -> list[str]:
    """Reasons to distrust a fit of ``dataset``: data without resonance, modes outside the data.

    Returns one message per finding (empty when nothing is suspicious):

    * an experiment whose largest response is less than :data:`RESONANCE_RATIO` times its
      smallest (constant data, or a window with no mode in it);
    * a fitted modal frequency, at an experiment's bias, outside that experiment's measured
      frequencies (the model extrapolates: its modes are guesses).
    """
    found: list[str] = []
    mask = measured_mask(dataset)
    f = np.asarray(dataset["frequency"].values, dtype=float)
    bias = np.asarray(dataset["bias"].values, dtype=float)
    flat = []
    for k in range(mask.shape[0]):
        s = np.linalg.norm(np.asarray(dataset["response"].values[k])[mask[k]], 2, axis=(-2, -1))
        if s.max() < RESONANCE_RATIO * max(s.min(), 1e-300):
            flat.append(k)
    if flat:
        found.append(
            f"experiment(s) {flat} show no resonance (largest response less than "
            f"{RESONANCE_RATIO:g} times the smallest): the fitted modes are not supported by "
            "the data; measure over the band where the modes are"
        )
    outside = []
    for k in range(mask.shape[0]):
        lo, hi = f[mask[k]].min(), f[mask[k]].max()
        try:
            modes = model.modal(bias[k]).frequencies_hz
        except ValueError:  # no oscillating modes at this bias: as bad as outside
            outside.append(f"experiment {k}: no oscillating modes")
            continue
        if modes.min() < lo or modes.max() > hi:
            outside.append(
                f"experiment {k}: {modes[0]:.4g} / {modes[1]:.4g} Hz outside {lo:.6g}-{hi:.6g} Hz"
            )
    if outside:
        found.append(
            "fitted modes lie outside the measured frequencies ("
            + "; ".join(outside)
            + "): the model extrapolates; measure over a band that contains both modes"
        )
    return found


#: A scaled solution whose ``λ_min(M)`` exceeds 1 by more than this is normalised.
MASS_NORMALISE_TOL = 1e-9


def unit_mass(problem: FitProblem, result: ObjectiveResult) -> tuple[ObjectiveResult, float | None]:
    """``result`` scaled so that ``λ_min(M) = 1`` when it is larger, and the factor applied.

    The equation error is linear in the unknowns, so ``α·theta`` fits exactly as well as
    ``theta`` up to the factor ``α``: the constraint ``M ⪰ I`` fixes the scale only as an
    inequality. A noisy fit's optimum has ``λ_min(M) = 1``; an exact one (noiseless data in the
    model class) is a whole ray of optima, and the solver may stop anywhere on it (measured: 1.48
    times the truth with one OpenBLAS kernel, the truth with another). Dividing every unknown
    by ``λ = λ_min(M) > 1`` keeps ``M ⪰ I`` and ``K_p ⪯ 0``, divides every equation error (and
    so γ) by ``λ`` and the covariance by ``λ²``.
    """
    lay = problem.layout
    lam = float(np.linalg.eigvalsh(sym(result.theta[lay.M])).min())
    if not np.isfinite(lam) or lam <= 1.0 + MASS_NORMALISE_TOL:
        return result, None
    return (
        dataclasses.replace(
            result,
            theta=result.theta / lam,
            gamma=result.gamma / lam,
            max_residual=result.max_residual / lam,
            covariance=None if result.covariance is None else result.covariance / lam**2,
        ),
        lam,
    )


def model_from_problem(problem: FitProblem, result: ObjectiveResult, **meta: object) -> FittedModel:
    """Map an objective's scaled solution of ``problem`` back to physical units.

    The inverse of the scaling of :mod:`.problem`. The model's channel names are the
    data set's ``output`` and ``input`` coordinates; ``meta`` is added to the model's ``meta``
    (e.g. the solver's name and the fit time), after the fit's own facts, among them
    ``noise_weights`` (whether the points were weighted by their noise variance, see
    :class:`~sysid_core.identification.problem.FitProblem`). The map is linear in
    ``result.theta``; a fit normalises the scale first (:func:`unit_mass`).
    """
    self = problem
    coords = self.dataset.coords
    outputs: np.ndarray | tuple[str, str] = (
        coords["output"].values if "output" in coords else DEFAULT_OUTPUTS
    )
    inputs: np.ndarray | tuple[str, str] = (
        coords["input"].values if "input" in coords else DEFAULT_INPUTS
    )
    s, lay, th = self.scaling, self.layout, result.theta
    m = sym(th[lay.M])
    c = s.omega0 * s.eps * sym(th[lay.C])
    # Z's stiffness is ω0²(M + ε(D~ + Σ w~_p K~_p + Σ φ_p L~_p)) with w~_p and φ_p polynomials
    # in w_p (Scaling.w_polynomials): collect the coefficients of 1, w_p and w_p².
    kappa = s.omega0**2 * s.eps
    lin, quad = s.w_polynomials()
    k_tilde = [sym(th[lay.K(p)]) for p in range(lay.n_electrodes)]
    l_tilde = [sym(th[lay.L(p)]) for p in range(lay.n_electrodes)] if lay.quadratic else []
    k0 = s.omega0**2 * (m + s.eps * sym(th[lay.D]))
    kp = np.zeros((lay.n_electrodes, 2, 2))
    for p in range(lay.n_electrodes):
        k0 = k0 + kappa * lin[p, 0] * k_tilde[p]
        kp[p] = kappa * lin[p, 1] * k_tilde[p]
    lp = None
    if lay.quadratic:
        assert quad is not None
        lp = np.zeros((lay.n_electrodes, 2, 2))
        for p in range(lay.n_electrodes):
            k0 = k0 + kappa * quad[p, 0] * l_tilde[p]
            kp[p] += kappa * quad[p, 1] * l_tilde[p]
            lp[p] = kappa * quad[p, 2] * l_tilde[p]

    def coefficient(sl: slice) -> np.ndarray:
        return s.psi_scale * (th[sl][:4] + 1j * th[sl][4:]).reshape(2, 2)

    poly = np.array([coefficient(lay.poly(d)) for d in range(lay.order + 1)])
    # P~_{l,p} multiplies w~_p = (w_p - w_c,p) / s_p: per V², and the offset moves into P_l.
    poly_w = np.array(
        [
            [coefficient(lay.poly_w(d, p)) / s.w_scale[p] for p in range(lay.n_electrodes)]
            for d in range(lay.bias_terms)
        ],
        dtype=complex,
    ).reshape(lay.bias_terms, lay.n_electrodes, 2, 2)
    for d in range(lay.bias_terms):
        poly[d] -= np.tensordot(s.w_center, poly_w[d], axes=1)
    factor = None if result.covariance is None else stiffness_factor(problem, result.covariance)
    return FittedModel(
        structure=self.structure,
        M=m,
        C=c,
        K0=k0,
        Kp=kp,
        poly=poly,
        poly_w=poly_w,
        omega_center=s.omega0,
        omega_half=s.nu_half,
        electrodes=self.electrodes,
        structure_potential=self.structure_potential,
        gamma=result.gamma * s.psi_scale,
        max_residual=result.max_residual * s.psi_scale,
        outputs=[str(name) for name in outputs],
        inputs=[str(name) for name in inputs],
        meta={
            "objective": result.objective,
            "certified": result.certified,
            "solves": result.solves,
            "working_set": result.working_set,
            "solver_iterations": result.iterations,
            "n_points": self.n_points,
            "n_experiments": self.n_experiments,
            "n_parameters": self.n_parameters,
            "device": str(self.dataset.attrs.get("device", "unknown")),
            "band_hz": [float(self.frequency_hz.min()), float(self.frequency_hz.max())],
            "fit_bias": self.bias.tolist(),
            "noise_weights": self.weights is not None,
            **meta,
        },
        stiffness_factor=factor,
        Lp=lp,
    )
