"""The fit-objective interface: what an objective does with a problem and a solver.

An :class:`Objective` assembles conic programs from a
:class:`~sysid_core.identification.problem.FitProblem`
(:mod:`sysid_core.identification.programs`), solves them with the
:class:`~sysid_core.conic.program.Solver` it is given, as many times as its method needs, and
returns an :class:`ObjectiveResult` in scaled units;
:func:`sysid_core.identification.fitting.model_from_problem` maps that to physical units.
"""

from __future__ import annotations

from abc import ABC, abstractmethod
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import ClassVar

import numpy as np

from sysid_core.conic.program import Solver
from sysid_core.identification.problem import FitProblem

__all__ = ["DEFAULT_OBJECTIVE", "DEFAULT_SOLVER", "Objective", "ObjectiveResult", "Progress"]

#: The default fit objective (statistically efficient under random noise, and it states a
#: covariance; see docs/fitting.md) and solver, for :func:`sysid_core.api.fit`, ``sysid fit``
#: and the configuration alike.
DEFAULT_OBJECTIVE = "least-squares"
DEFAULT_SOLVER = "clarabel"

#: Receives one-line progress messages from long computations.
Progress = Callable[[str], None]


@dataclass
class ObjectiveResult:
    """What an objective returns: the scaled solution and how it was reached.

    Attributes
    ----------
    theta : ndarray
        Scaled unknowns.
    gamma : float
        Optimal minimax value γ* (scaled units); for least squares, the largest residual.
    max_residual : float
        Largest σ̄(E) over all data points at ``theta`` (scaled units).
    certified : bool
        ``max_residual`` was checked on every data point against the objective's bound.
    objective : str
        Name of the objective.
    solves : int
        Number of conic solves.
    working_set : int
        Number of data points in the last program (all points for a full program).
    iterations : int
        Total solver iterations.
    info : dict
        Anything else worth reporting.
    covariance : ndarray or None
        Covariance of ``theta`` (scaled units) when the objective can state one (least
        squares: :func:`sysid_core.identification.covariance.theta_covariance`); ``None`` otherwise.
    """

    theta: np.ndarray
    gamma: float
    max_residual: float
    certified: bool
    objective: str
    solves: int = 1
    working_set: int = 0
    iterations: int = 0
    info: dict[str, object] = field(default_factory=dict)
    covariance: np.ndarray | None = None


class Objective(ABC):
    """A fit criterion over the equation errors of all data points."""

    name: ClassVar[str]
    description: ClassVar[str] = ""

    @abstractmethod
    def fit(
        self, problem: FitProblem, solver: Solver, progress: Progress | None = None
    ) -> ObjectiveResult:
        """Return the scaled parameter vector that optimises this objective on ``problem``.

        Raises
        ------
        SolverError
            If the solver cannot solve a program the objective needs (its ``status`` is a
            :class:`~sysid_core.conic.program.SolveStatus`).
        """
