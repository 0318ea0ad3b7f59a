"""The ``minimax`` objective: the paper's program (8)/(10), solved on a working set of points."""

from __future__ import annotations

from typing import Annotated

import numpy as np
from annotated_types import Ge, Gt

from sysid_core.conic.program import Solver, SolveStatus
from sysid_core.errors import ConfigError, FitError, SolverError
from sysid_core.identification.objective import Objective, ObjectiveResult, Progress
from sysid_core.identification.problem import FitProblem
from sysid_core.identification.programs import (
    least_squares_program,
    minimax_program,
    tie_break_program,
)

__all__ = ["Minimax"]

#: Residuals below this (scaled units, where the feedthrough polynomial is O(1)) are exact fits to
#: solver precision: the certificate allows it as an absolute slack, and the tie-break is skipped.
_FLOOR = 1e-8


def _select(r: np.ndarray, bound: float, exclude: np.ndarray, batch: int, experiment: np.ndarray):
    """Points to add: violators of ``bound``, local maxima of ``r`` within an experiment first."""
    viol = np.flatnonzero((r > bound) & ~exclude)
    if viol.size == 0:
        return viol
    same_left = np.r_[False, experiment[1:] == experiment[:-1]]
    same_right = np.r_[experiment[:-1] == experiment[1:], False]
    left = np.where(same_left, np.r_[-np.inf, r[:-1]], -np.inf)
    right = np.where(same_right, np.r_[r[1:], -np.inf], -np.inf)
    peak = (r >= left) & (r >= right)
    order = viol[np.lexsort((-r[viol], ~peak[viol]))]  # peaks first, then by violation
    return order[:batch]


class Minimax(Objective):
    """``min γ`` s.t. σ̄(E_{k,q}) ≤ γ at every data point (eq. 8 for ``act``, 10 for ``sen``).

    Deterministic: minimax optima are often not unique, in directions that move the tuning
    answer. So after finding the optimal γ*, the objective returns, among the parameters with
    σ̄(E) ≤ γ*(1 + ``tie_tol``) at every point, the one with the smallest sum of squared
    equation errors (a strictly convex tie-break, hence a unique answer whichever solver or
    working set found γ*).

    Fast at scale: only a few points are active at the optimum. Both stages are solved on a
    working set of points that starts from the largest least-squares residuals and grows by the
    most-violated points (local maxima along frequency first) until every point satisfies its
    bound within ``cert_tol``; the answer is thus certified on all points.

    Parameters
    ----------
    tie_tol : float
        Relative slack on γ* for the tie-break (default 1e-3). ``0`` disables the tie-break.
    working_set : bool
        Solve on a growing working set (default) or the full program on all points at once.
    cert_tol : float
        Relative tolerance of the all-points certificate (default 1e-6).
    batch : int or None
        Most points added per round (default ``max(8, n_parameters // 2)``).
    max_rounds : int
        Rounds per stage before giving up with :class:`~sysid_core.errors.FitError` (default 50).
    keep : float
        After each round, points whose residual is below ``keep`` times the bound leave the
        working set (default 0.8); a point that has to come back stays for good.
    """

    name = "minimax"
    description = "worst-case equation error, eq. (8)/(10); working set, least-squares tie-break"

    def __init__(
        self,
        tie_tol: Annotated[float, Ge(0)] = 1e-3,
        working_set: bool = True,
        cert_tol: Annotated[float, Ge(0)] = 1e-6,
        batch: Annotated[int, Gt(0)] | None = None,
        max_rounds: Annotated[int, Gt(0)] = 50,
        keep: Annotated[float, Ge(0)] = 0.8,
    ) -> None:
        if min(tie_tol, cert_tol, keep) < 0 or max_rounds < 1 or (batch is not None and batch < 1):
            raise ConfigError(
                "minimax options: tie_tol, cert_tol and keep must be >= 0, max_rounds and "
                "batch >= 1"
            )
        self.tie_tol = float(tie_tol)
        self.working_set = bool(working_set)
        self.cert_tol = float(cert_tol)
        self.batch = batch
        self.max_rounds = int(max_rounds)
        self.keep = float(keep)

    def fit(
        self, problem: FitProblem, solver: Solver, progress: Progress | None = None
    ) -> ObjectiveResult:
        say = progress or (lambda _msg: None)
        solves = iterations = 0
        n_pts, n_par = problem.n_points, problem.n_parameters
        if not self.working_set:
            points = np.arange(n_pts)
            sol = solver.solve(minimax_program(problem, points))
            solves, iterations = 1, sol.iterations
            theta, gamma = sol.x[:n_par], float(sol.x[n_par])
            say(f"minimax (full program, {n_pts} points): gamma = {gamma:.6g}")
            if self.tie_tol > 0 and gamma > _FLOOR:
                scale = max(float(theta @ problem.gram @ theta), _FLOOR**2)
                sol = solver.solve(
                    tie_break_program(problem, points, gamma * (1 + self.tie_tol), scale)
                )
                solves, iterations = 2, iterations + sol.iterations
                theta = sol.x[:n_par]
            r = problem.residuals(theta)
            return ObjectiveResult(
                theta=theta,
                gamma=gamma,
                max_residual=float(r.max()),
                certified=True,
                objective=self.name,
                solves=solves,
                working_set=n_pts,
                iterations=iterations,
                info={"tie_tol": self.tie_tol},
            )

        batch = self.batch or max(8, problem.n_parameters // 2)
        # Start from the largest residuals of the (cheap) least-squares fit, peaks first.
        ls = solver.solve(least_squares_program(problem))
        r = problem.residuals(ls.x[:n_par])
        ws = _WorkingSet(problem, solver, self, batch, say)
        ws.in_set[_select(r, -np.inf, ws.in_set, n_par + 1, problem.experiment)] = True
        ws.solves, ws.iterations, ws.r = 1, ls.iterations, r
        theta, gamma, r = ws.run("minimax", None, None)
        bound, tie = gamma, "not needed (exact fit)" if gamma <= _FLOOR else "disabled"
        if self.tie_tol > 0 and gamma > _FLOOR:
            try:
                theta, _, r = ws.run(
                    "tie-break",
                    gamma * (1 + self.tie_tol),
                    max(float(theta @ problem.gram @ theta), _FLOOR**2),
                )
                bound, tie = gamma * (1 + self.tie_tol), "done"
            except SolverError as exc:
                # Keep the certified minimax optimum rather than fail the whole fit.
                tie = f"failed ({exc.status}); the minimax optimum is returned as found"
                say(f"tie-break {tie}")
        max_r = float(r.max())
        return ObjectiveResult(
            theta=theta,
            gamma=gamma,
            max_residual=max_r,
            certified=bool(max_r <= bound * (1 + self.cert_tol) + _FLOOR),
            objective=self.name,
            solves=ws.solves,
            working_set=int(ws.in_set.sum()),
            iterations=ws.iterations,
            info={"tie_tol": self.tie_tol, "cert_tol": self.cert_tol, "tie_break": tie},
        )


class _WorkingSet:
    """The growing (and pruned) set of data points of one minimax fit."""

    def __init__(
        self, problem: FitProblem, solver: Solver, obj: Minimax, batch: int, say: Progress
    ) -> None:
        self.problem, self.solver, self.obj, self.batch, self.say = problem, solver, obj, batch, say
        n = problem.n_points
        self.in_set = np.zeros(n, dtype=bool)
        self.sticky = np.zeros(n, dtype=bool)
        self.dropped = np.zeros(n, dtype=bool)
        self.solves = self.iterations = self.retries = 0
        self.r = np.zeros(n)

    def run(self, stage: str, bound: float | None, scale: float | None):
        """Solve the stage's program on the set until every point meets the bound.

        ``bound=None``: the minimax stage (the bound is the optimal γ of each round).
        Returns ``(theta, gamma, residuals)``.
        """
        pb, obj = self.problem, self.obj
        n_par, n_pts = pb.n_parameters, pb.n_points
        gamma = np.nan
        for round_ in range(1, obj.max_rounds + 1):
            points = np.flatnonzero(self.in_set)
            try:
                if bound is None:
                    sol = self.solver.solve(minimax_program(pb, points))
                else:
                    sol = self.solver.solve(tie_break_program(pb, points, bound, scale))
            except SolverError as exc:
                # A small working set can make the program degenerate (a near-exact
                # interpolation); more points fix that. With every point in, it is an error.
                if (
                    bound is not None
                    or points.size == n_pts
                    or exc.status is not SolveStatus.INACCURATE
                    or self.retries >= 3
                ):
                    raise  # the tie-break falls back to the minimax optimum; see Minimax.fit
                self.retries += 1
                out = np.flatnonzero(~self.in_set)
                grow = out[np.argsort(-self.r[out])][: self.batch]
                self.in_set[grow] = self.sticky[grow] = True
                self.say(
                    f"{stage} round {round_}: solver status {exc.status} on {points.size} "
                    f"points; retrying with {grow.size} more"
                )
                continue
            self.solves += 1
            self.iterations += sol.iterations
            theta = sol.x[:n_par]
            gamma = float(sol.x[n_par])
            limit = gamma if bound is None else bound
            self.r = r = pb.residuals(theta)
            add = _select(
                r, limit * (1 + obj.cert_tol) + _FLOOR, self.in_set, self.batch, pb.experiment
            )
            self.say(
                f"{stage} round {round_}: {points.size} points, gamma = {gamma:.6g}, "
                f"{add.size} added"
            )
            if add.size == 0:
                return theta, gamma, r
            # Points far below the bound leave the set; one that comes back stays for good.
            self.sticky[add[self.dropped[add]]] = True
            self.in_set[add] = True
            prune = self.in_set & ~self.sticky & (r < obj.keep * limit)
            self.dropped |= prune
            self.in_set &= ~prune
        raise FitError(f"minimax {stage} working set did not converge in {obj.max_rounds} rounds")
