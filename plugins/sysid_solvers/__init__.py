"""Built-in conic-solver backends: Clarabel (interior point) and SCS (first-order, ADMM)."""

from sysid_solvers.clarabel_backend import ClarabelSolver
from sysid_solvers.scs_backend import ScsSolver

__all__ = ["ClarabelSolver", "ScsSolver"]
