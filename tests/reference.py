"""Reference cvxpy formulations of the fit programs, written independently of the assembly.

The toolkit's objectives assemble their conic programs by hand
(:mod:`sysid_core.identification.programs`, from
the linear operator :attr:`FitProblem.G <sysid_core.identification.problem.FitProblem.G>` and the
row builders of
:class:`~sysid_core.identification.problem.FitProblem`). This module writes the same programs the
readable way, with named cvxpy matrix variables and one constraint per data point, directly from
the scaled data of a :class:`~sysid_core.identification.problem.FitProblem`:

.. math::

    \\tilde Z_i = \\tilde D_0 + \\sum_p \\tilde w_{k_i p} \\tilde K_p
        - (\\delta_i/\\varepsilon) M + j\\Omega_i \\tilde C,\\qquad
    \\tilde P(\\nu_i) = \\sum_l \\tilde P_l \\nu_i^l,

    E_i = \\tilde P(\\nu_i) - \\tilde\\psi_i \\tilde Z_i \\ (\\texttt{act})\\quad\\text{or}\\quad
    E_i = \\tilde P(\\nu_i) - \\tilde Z_i \\tilde\\psi_i \\ (\\texttt{sen}),

each multiplied by the point's noise weight :math:`w_i` when the data carry ``noise_var``
(computed here from the data set, not taken from the problem), with
:math:`\\Omega = \\omega/\\omega_0`, :math:`\\delta = \\Omega^2 - 1`,
:math:`\\nu = (\\omega - \\omega_0)/h` and
:math:`\\tilde\\psi = \\psi\\,\\omega_0^2\\varepsilon/s_\\psi` (the constants of
:class:`~sysid_core.identification.problem.Scaling`). Only the scaling constants and the data are
shared with the assembled programs, never ``G``, so comparing the two optima checks the operator,
the LMI embedding and the structural rows at once. Tests use it that way, and the
speed benchmark (``benchmarks/fit_speed.py``) uses it as "the straightforward cvxpy formulation".

The constraints are those of the assembled programs: :math:`M \\succeq I`,
:math:`\\tilde C \\succeq` ``EPS_DAMPING`` :math:`I`, :math:`\\tilde K_p \\preceq 0` and, at every
experiment's bias, :math:`M + \\varepsilon(\\tilde D_0 + \\sum_p \\tilde w_{kp}\\tilde K_p)
\\succeq` ``EPS_STIFFNESS`` :math:`I`.

Two notes from measuring it (cvxpy 1.9, Clarabel 0.11):

* cvxpy accepts the complex Hermitian LMI and embeds it as the real ``[[A, -B], [B, A]] ⪰ 0``;
  that cone has the dual degeneracy described in
  :meth:`FitProblem.minimax_rows <sysid_core.identification.problem.FitProblem.minimax_rows>`, so
  Clarabel sometimes stalls with the dual residual a few times above ``tol_feas`` and ends
  ``AlmostSolved`` (cvxpy: ``"optimal_inaccurate"``) although γ is right to about 1e-8
  (e.g. ``sen`` on 3 x 41 points, ``act`` on 3 x 121). Pass ``tol_feas=1e-7``, or use
  ``form="sigma_max"`` (cvxpy's own ``sigma_max`` atom), which ended ``"optimal"`` in every case
  tried (4 structures and orders at 3 x 15 to 3 x 61 points).
* Compiling is the cost: about 0.3 s plus 20 ms per point on a shared 2-core machine (4 s for
  3 x 41 points against 0.3 s in the solver; 15 s at the paper's 3 x 121), growing a little
  faster than the number of points.
* The least-squares optimum is small in scaled units (1e-5 to 1e-3), so Clarabel's default
  absolute gap tolerance (1e-8) limits its relative accuracy to about 1e-5..1e-6: pass
  ``tol_gap_abs=1e-12, tol_gap_rel=1e-12`` for a reference at 1e-6 or better.

cvxpy is imported inside the functions, so importing :mod:`sysid_core` stays light.
"""

from __future__ import annotations

import time
import warnings
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any, Literal

import numpy as np

from sysid_core.errors import SolverError
from sysid_core.identification.problem import EPS_DAMPING, EPS_STIFFNESS, FitProblem

if TYPE_CHECKING:
    import cvxpy as cp

__all__ = [
    "ReferenceSolution",
    "least_squares_reference",
    "minimax_reference",
    "reference_errors",
    "solve_reference",
]


@dataclass
class ReferenceSolution:
    """What :func:`solve_reference` returns, whatever cvxpy's status.

    Attributes
    ----------
    value : float
        Optimal value: γ (minimax) or the mean squared Frobenius norm (least squares), scaled
        units; NaN when cvxpy has none.
    theta : ndarray or None
        The variables in the layout of ``problem.layout``; ``None`` when cvxpy has no values.
    status : str
        cvxpy's status (``"optimal"``, ``"optimal_inaccurate"``, ...).
    build_time, compile_time, solver_time : float
        Seconds spent writing the cvxpy problem, compiling it (cvxpy's reductions and the
        solver interface) and in the solver itself (as cvxpy reports it).
    info : dict
        Sizes and the cvxpy solver statistics.
    """

    value: float
    theta: np.ndarray | None
    status: str
    build_time: float
    compile_time: float
    solver_time: float
    info: dict[str, object] = field(default_factory=dict)

    @property
    def total_time(self) -> float:
        """Build, compile and solve, in seconds."""
        return self.build_time + self.compile_time + self.solver_time


@dataclass
class _Unknowns:
    """The named cvxpy variables of the scaled model."""

    M: cp.Variable
    C: cp.Variable
    D: cp.Variable
    K: list[cp.Variable]
    P: list[cp.Variable]


def _unknowns(problem: FitProblem) -> _Unknowns:
    """Symmetric real ``M``, ``C~``, ``D~0``, ``K~_p`` and complex ``P~_l`` (all 2x2)."""
    import cvxpy as cp

    def sym(name: str) -> cp.Variable:
        return cp.Variable((2, 2), symmetric=True, name=name)

    return _Unknowns(
        M=sym("M"),
        C=sym("C"),
        D=sym("D0"),
        K=[sym(f"K{p + 1}") for p in range(len(problem.electrodes))],
        P=[
            cp.Variable((2, 2), complex=True, name=f"P{deg}")
            for deg in range(problem.structure.order + 1)
        ],
    )


def _structural_constraints(problem: FitProblem, u: _Unknowns) -> list[cp.Constraint]:
    """``M ⪰ I``, ``C~ ⪰ EPS_DAMPING I``, ``K~_p ⪯ 0``, ``K(w_k) ⪰ EPS_STIFFNESS`` (scaled)."""
    eye = np.eye(2)
    eps = problem.scaling.eps
    cons = [u.M >> eye, u.C >> EPS_DAMPING * eye]
    cons += [k << 0 for k in u.K]
    for wk in problem.scaled_w():
        stiffness = u.D + sum((wk[p] * k for p, k in enumerate(u.K)), start=0 * u.D)
        cons.append(u.M + eps * stiffness >> EPS_STIFFNESS * eye)
    return cons


def _scaled_data(problem: FitProblem) -> dict[str, np.ndarray]:
    """Per-point constants: ``Omega``, ``delta/eps``, ``nu``, ``psi~`` and ``w~``."""
    s = problem.scaling
    big_omega = problem.omega / s.omega0
    return {
        "Omega": big_omega,
        "delta_eps": (big_omega**2 - 1) / s.eps,
        "nu": (problem.omega - s.omega0) / s.nu_half,
        "psi": problem.psi * (s.omega0**2 * s.eps / s.psi_scale),
        "w": problem.scaled_w()[problem.experiment],  # (N, n_e): w~ of each point's experiment
    }


def _noise_weights(problem: FitProblem) -> np.ndarray | None:
    """Each point's weight ``v^{-1/2}`` normalised to mean square 1, ``v`` the mean of its
    sweep's ``noise_var`` over the measured points and channels; None without a positive
    variance at every point, or when the sweeps' variances differ by a factor of at most 1.5
    (docs/fitting.md, "Noise weights")."""
    from sysid_core.data.schema import measured_mask

    ds = problem.dataset
    if "noise_var" not in ds:
        return None
    mask = measured_mask(ds)
    table = np.asarray(ds["noise_var"].values, dtype=float)
    per_point = [table[k][mask[k]].mean(axis=(1, 2)) for k in range(mask.shape[0])]
    if not all(np.all(np.isfinite(p) & (p > 0)) for p in per_point):
        return None
    pooled = np.array([p.mean() for p in per_point])
    if pooled.max() <= 1.5 * pooled.min():
        return None
    v = np.concatenate([np.full(p.size, q) for p, q in zip(per_point, pooled, strict=True)])
    w = 1.0 / np.sqrt(v)
    return w / np.sqrt(np.mean(w**2))


def _check_side(problem: FitProblem) -> str:
    """``"output"`` (``act``) or ``"input"`` (``sen``); other structures are not supported."""
    side = problem.structure.side
    if side not in ("output", "input"):
        raise ValueError(f"reference formulation knows sides 'output' and 'input', not {side!r}")
    return side


def _stacked_errors(problem: FitProblem, u: _Unknowns) -> cp.Expression:
    """All equation errors as one expression: ``(2N, 2)`` for ``act``, ``(2, 2N)`` for ``sen``.

    For ``act`` the 2x2 row blocks of ``sum_l V_l P~_l - sum_X Psi_X X`` are the ``E_i``, with
    ``V_l`` the stacked ``nu_i^l I`` and ``Psi_X`` the stacked ``c_X(i) psi~_i`` (``c_X`` the
    coefficient of the variable ``X`` in ``Z~_i``); for ``sen`` the column blocks of the
    transposed arrangement. Measured: the per-point LMIs compile about 1.5 times faster as
    slices of this expression than with each ``E_i`` written out from the variables, and a
    least-squares objective over ``N`` per-point terms exceeds cvxpy's expression-size limit.
    """
    side = _check_side(problem)
    d = _scaled_data(problem)
    psi = d["psi"]
    # Z~_i = D~0 + sum_p w~_ip K~_p - (delta_i/eps) M + j Omega_i C~ as (coefficient, variable)
    z_terms = [(np.ones(problem.n_points), u.D), (-d["delta_eps"], u.M), (1j * d["Omega"], u.C)]
    z_terms += [(d["w"][:, p], k) for p, k in enumerate(u.K)]
    eye = np.eye(2)
    if side == "output":  # E_i = P~(nu_i) - psi~_i Z~_i, stacked vertically
        poly = [np.kron((d["nu"] ** deg)[:, None], eye) @ p for deg, p in enumerate(u.P)]
        prod = [(c[:, None, None] * psi).reshape(-1, 2) @ x for c, x in z_terms]
    else:  # E_i = P~(nu_i) - Z~_i psi~_i, stacked horizontally
        poly = [p @ np.kron((d["nu"] ** deg)[None, :], eye) for deg, p in enumerate(u.P)]
        prod = [x @ np.concatenate(list(c[:, None, None] * psi), axis=1) for c, x in z_terms]
    errors = sum(poly[1:], start=poly[0]) - sum(prod[1:], start=prod[0])
    w = _noise_weights(problem)
    if w is None:
        return errors
    per_row = np.repeat(w, 2)  # each point's two rows (act) or columns (sen)
    scale = per_row[:, None] * np.ones((1, 2)) if side == "output" else np.ones((2, 1)) * per_row
    import cvxpy as cp

    return cp.multiply(scale, errors)


def _block(problem: FitProblem, stacked: cp.Expression, i: int) -> cp.Expression:
    """The 2x2 equation error of point ``i`` from :func:`_stacked_errors`."""
    if problem.structure.side == "output":
        return stacked[2 * i : 2 * i + 2, :]
    return stacked[:, 2 * i : 2 * i + 2]


def _theta(problem: FitProblem, u: _Unknowns) -> np.ndarray:
    """The variables' values in the order of
    :class:`~sysid_core.identification.problem.ParameterLayout`."""
    lay = problem.layout
    theta = np.zeros(lay.n)

    def svec(v: cp.Variable) -> np.ndarray:
        x = np.asarray(v.value, dtype=float)
        return np.array([x[0, 0], x[0, 1], x[1, 1]])

    theta[lay.M] = svec(u.M)
    theta[lay.C] = svec(u.C)
    theta[lay.D] = svec(u.D)
    for p, k in enumerate(u.K):
        theta[lay.K(p)] = svec(k)
    for deg, p in enumerate(u.P):
        x = np.asarray(p.value, dtype=complex).ravel()  # row-major: 11, 12, 21, 22
        theta[lay.poly(deg)] = np.concatenate([x.real, x.imag])
    return theta


def _assign(problem: FitProblem, u: _Unknowns, theta: np.ndarray) -> None:
    """Set the variables' values from ``theta`` (the inverse of :func:`_theta`)."""
    lay = problem.layout
    theta = np.asarray(theta, dtype=float)
    if theta.shape != (lay.n,):
        raise ValueError(f"theta has shape {theta.shape}; expected ({lay.n},)")

    def sym(v: np.ndarray) -> np.ndarray:
        return np.array([[v[0], v[1]], [v[1], v[2]]])

    u.M.value = sym(theta[lay.M])
    u.C.value = sym(theta[lay.C])
    u.D.value = sym(theta[lay.D])
    for p, k in enumerate(u.K):
        k.value = sym(theta[lay.K(p)])
    for deg, p in enumerate(u.P):
        x = theta[lay.poly(deg)]
        p.value = (x[:4] + 1j * x[4:]).reshape(2, 2)


def reference_errors(problem: FitProblem, theta: np.ndarray) -> np.ndarray:
    """Equation errors at ``theta`` evaluated through the reference cvxpy expressions.

    Independent of ``problem.G``: comparing with
    :meth:`FitProblem.errors <sysid_core.identification.problem.FitProblem.errors>` checks the
    assembled operator directly, without solving anything.

    Parameters
    ----------
    problem : FitProblem
        The scaled data and model structure.
    theta : ndarray
        Scaled unknowns in the layout of ``problem.layout``.

    Returns
    -------
    ndarray
        Complex, shape ``(N, 2, 2)``, scaled units.
    """
    u = _unknowns(problem)
    stacked = _stacked_errors(problem, u)
    _assign(problem, u, theta)
    value = np.asarray(stacked.value, dtype=complex)
    if problem.structure.side == "output":  # (2N, 2): row blocks
        return value.reshape(problem.n_points, 2, 2)
    return value.reshape(2, problem.n_points, 2).transpose(1, 0, 2)  # (2, 2N): column blocks


def _build(problem: FitProblem, objective: str, form: str) -> tuple[cp.Problem, _Unknowns]:
    """The cvxpy problem of ``objective`` (``"minimax"`` or ``"least-squares"``)."""
    import cvxpy as cp

    u = _unknowns(problem)
    cons = _structural_constraints(problem, u)
    stacked = _stacked_errors(problem, u)
    if objective == "minimax":
        if form not in ("lmi", "sigma_max"):
            raise ValueError(f"form must be 'lmi' or 'sigma_max', not {form!r}")
        gamma = cp.Variable(name="gamma")
        eye = np.eye(2)
        for i in range(problem.n_points):
            e = _block(problem, stacked, i)
            if form == "lmi":  # σ̄(E) ≤ γ  ⟺  [[γI, E^H], [E, γI]] ⪰ 0 (complex Hermitian)
                cons.append(cp.bmat([[gamma * eye, e.H], [e, gamma * eye]]) >> 0)
            else:
                cons.append(cp.sigma_max(e) <= gamma)
        return cp.Problem(cp.Minimize(gamma), cons), u
    if objective == "least-squares":
        # Σ_i ||E_i||_F² is the sum of the squared moduli of all entries of the stacked errors.
        # Real and imaginary parts are taken explicitly: cvxpy 1.9 rewrites sum_squares of a
        # complex matrix entry by entry, and the tree then grows with N (as does a sum of N
        # per-point terms), which makes compiling slow and trips cvxpy's size warning.
        sq = cp.sum_squares(cp.real(stacked)) + cp.sum_squares(cp.imag(stacked))
        return cp.Problem(cp.Minimize(sq / problem.n_points), cons), u
    raise ValueError(f"objective must be 'minimax' or 'least-squares', not {objective!r}")


def solve_reference(
    problem: FitProblem,
    objective: Literal["minimax", "least-squares"] = "minimax",
    solver: str = "CLARABEL",
    *,
    form: Literal["lmi", "sigma_max"] = "lmi",
    **solver_kwargs: Any,
) -> ReferenceSolution:
    """Write and solve a reference program with cvxpy; report the status instead of raising.

    Parameters
    ----------
    problem : FitProblem
        The scaled data and model structure (``act`` or ``sen``, any order).
    objective : {"minimax", "least-squares"}
        Which program (see :func:`minimax_reference`, :func:`least_squares_reference`).
    solver : str
        A cvxpy solver name (default ``"CLARABEL"``).
    form : {"lmi", "sigma_max"}
        How the minimax constraint σ̄(E_i) ≤ γ is written: the complex Hermitian LMI
        ``[[γI, E_i^H], [E_i, γI]] ⪰ 0`` (default) or ``cp.sigma_max(E_i) <= γ``.
    **solver_kwargs
        Passed to :meth:`cvxpy.Problem.solve` (solver settings such as ``tol_feas``).

    Returns
    -------
    ReferenceSolution
        Value, ``theta``, cvxpy's status and the time spent in each phase.

    Raises
    ------
    SolverError
        Only if cvxpy itself raises (the solver crashed or is not installed).
    """
    import cvxpy as cp

    t0 = time.perf_counter()
    prob, u = _build(problem, objective, form)
    t1 = time.perf_counter()
    with warnings.catch_warnings():
        # The status is reported instead of cvxpy's "Solution may be inaccurate" warning.
        warnings.filterwarnings("ignore", "Solution may be inaccurate", UserWarning)
        try:
            prob.solve(solver=solver, **solver_kwargs)
        except cp.error.SolverError as exc:
            raise SolverError(
                f"cvxpy reference {objective} failed with {solver}: {exc}", status="error"
            ) from exc
    t2 = time.perf_counter()
    stats = prob.solver_stats
    solver_time = float(stats.solve_time) if stats and stats.solve_time is not None else 0.0
    has_values = u.M.value is not None
    return ReferenceSolution(
        value=float(prob.value) if has_values and prob.value is not None else float("nan"),
        theta=_theta(problem, u) if has_values else None,
        status=str(prob.status),
        build_time=t1 - t0,
        compile_time=max(t2 - t1 - solver_time, 0.0),
        solver_time=solver_time,
        info={
            "objective": objective,
            "form": form if objective == "minimax" else None,
            "solver": solver,
            "n_points": problem.n_points,
            "n_constraints": len(prob.constraints),
            "iterations": stats.num_iters if stats else None,
        },
    )


def _require_optimal(sol: ReferenceSolution) -> tuple[float, np.ndarray]:
    """``(value, theta)``, or :class:`SolverError` unless cvxpy's status is ``"optimal"``."""
    import cvxpy as cp

    if sol.status != cp.OPTIMAL or sol.theta is None:
        raise SolverError(
            f"cvxpy reference {sol.info['objective']} ended with status {sol.status!r} "
            f"({sol.info['solver']}), not 'optimal'",
            status=sol.status,
        )
    return sol.value, sol.theta


def minimax_reference(
    problem: FitProblem,
    solver: str = "CLARABEL",
    *,
    form: Literal["lmi", "sigma_max"] = "lmi",
    **solver_kwargs: Any,
) -> tuple[float, np.ndarray]:
    """Solve the minimax program (8)/(10) on every data point with cvxpy.

    ``min γ`` subject to σ̄(E_i) ≤ γ at every point, written as the complex Hermitian LMI
    ``[[γI, E_i^H], [E_i, γI]] ⪰ 0`` (one 4x4 constraint per point; or ``cp.sigma_max(E_i) <= γ``
    with ``form="sigma_max"``), and the structural constraints of the module docstring.

    Parameters
    ----------
    problem : FitProblem
        The scaled data and model structure (``act`` or ``sen``, any order).
    solver : str
        A cvxpy solver name (default ``"CLARABEL"``).
    form : {"lmi", "sigma_max"}
        How σ̄(E_i) ≤ γ is written (see :func:`solve_reference`).
    **solver_kwargs
        Passed to :meth:`cvxpy.Problem.solve`.

    Returns
    -------
    gamma : float
        The optimal γ in scaled units (compare with ``ObjectiveResult.gamma``).
    theta : ndarray
        An optimal point in the layout of ``problem.layout`` (minimax optima need not be unique).

    Raises
    ------
    SolverError
        If cvxpy's status is not ``"optimal"`` (``"optimal_inaccurate"`` included).

    Examples
    --------
    >>> gamma, theta = minimax_reference(FitProblem(dataset, structure))  # doctest: +SKIP
    >>> problem.residuals(theta).max() <= gamma * (1 + 1e-6)  # doctest: +SKIP
    True
    """
    return _require_optimal(solve_reference(problem, "minimax", solver, form=form, **solver_kwargs))


def least_squares_reference(
    problem: FitProblem, solver: str = "CLARABEL", **solver_kwargs: Any
) -> tuple[float, np.ndarray]:
    """Solve the constrained least-squares program with cvxpy.

    ``min (1/N) Σ_i ||E_i||_F²`` over all ``N`` data points, subject to the structural
    constraints of the module docstring.

    Parameters
    ----------
    problem : FitProblem
        The scaled data and model structure.
    solver : str
        A cvxpy solver name (default ``"CLARABEL"``).
    **solver_kwargs
        Passed to :meth:`cvxpy.Problem.solve`.

    Returns
    -------
    mean_square : float
        The optimal mean squared Frobenius norm in scaled units (compare with
        ``theta @ problem.gram @ theta``).
    theta : ndarray
        The minimiser in the layout of ``problem.layout``.

    Raises
    ------
    SolverError
        If cvxpy's status is not ``"optimal"``.
    """
    return _require_optimal(solve_reference(problem, "least-squares", solver, **solver_kwargs))
