"""The ``least-squares`` objective: minimise the summed squared equation error."""

from __future__ import annotations

import numpy as np

from sysid_core.conic.program import Solver
from sysid_core.identification.covariance import theta_covariance
from sysid_core.identification.objective import Objective, ObjectiveResult, Progress
from sysid_core.identification.problem import FitProblem
from sysid_core.identification.programs import least_squares_program

__all__ = ["LeastSquares"]


class LeastSquares(Objective):
    """``min Σ_{k,q} ||E_{k,q}||_F²`` subject to the constraints of (8): one small QP.

    The statistically efficient choice under random measurement noise: the same equation errors
    and constraints as ``minimax``, all points weighted equally. It also states how uncertain
    its answer is: the covariance of the unknowns
    (:func:`sysid_core.identification.covariance.theta_covariance`),
    from which every tuning answer gets its confidence region. Takes no options.
    """

    name = "least-squares"
    description = "sum of squared equation errors (QP with 2x2 PSD constraints)"

    def fit(
        self, problem: FitProblem, solver: Solver, progress: Progress | None = None
    ) -> ObjectiveResult:
        sol = solver.solve(least_squares_program(problem))
        theta = sol.x[: problem.n_parameters]
        r = problem.residuals(theta)
        return ObjectiveResult(
            theta=theta,
            gamma=float(r.max()),
            max_residual=float(r.max()),
            certified=True,
            objective=self.name,
            solves=1,
            working_set=problem.n_points,
            iterations=sol.iterations,
            info={
                "mean_square": float(theta @ problem.gram @ theta),
                "rms": float(np.sqrt(np.mean(r**2))),
            },
            covariance=theta_covariance(problem, theta),
        )
