"""Entry point of the built-in solver backends."""

from __future__ import annotations

from collections.abc import Callable, Mapping

from sysid_core import hookimpl
from sysid_core.plugin.interfaces import Solver
from sysid_solvers.clarabel_backend import ClarabelSolver
from sysid_solvers.scs_backend import ScsSolver


@hookimpl
def sysid_solvers() -> Mapping[str, Callable[..., Solver]]:
    return {"clarabel": ClarabelSolver, "scs": ScsSolver}
