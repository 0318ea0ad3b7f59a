"""SCS backend: calls ``scs.SCS`` directly on the standard form (SCS's own PSD convention)."""

from __future__ import annotations

from typing import Annotated, Any, ClassVar

import numpy as np
import scipy.sparse as sp
from annotated_types import Gt

from sysid_core.conic.program import ConicProgram, ConicSolution, Solver, SolveStatus
from sysid_core.errors import SolverError

__all__ = ["ScsSolver"]


class ScsSolver(Solver):
    """SCS splitting conic solver.

    Parameters
    ----------
    eps_abs, eps_rel : float
        Absolute and relative tolerances; default 1e-7 (SCS's own 1e-4 is too loose for
        tuning).
    eps_infeas : float, optional
        Infeasibility tolerance (SCS's default when not given).
    max_iters : int
        Iteration limit; default 200 000.
    time_limit_secs : float, optional
        Time limit (none by default).
    verbose : bool
        Print SCS's progress; default false.
    normalize, adaptive_scale, use_indirect, gpu : bool, optional
    scale, rho_x, alpha : float, optional
    acceleration_lookback, acceleration_interval : int, optional
        Passed to SCS when given (see SCS's documentation).

    Only status ``solved`` is accepted; every other status raises
    :class:`~sysid_core.errors.SolverError` with its :class:`~sysid_core.conic.program.SolveStatus`.
    """

    name = "scs"
    description = "SCS first-order (ADMM) conic solver (direct, standard form)"
    #: SCS's status words and the toolkit's (an unknown word is FAILED).
    STATUS_MAP: ClassVar[dict[str, SolveStatus]] = {
        "solved": SolveStatus.SOLVED,
        "solved_inaccurate": SolveStatus.INACCURATE,
        "infeasible": SolveStatus.INFEASIBLE,
        "infeasible_inaccurate": SolveStatus.INACCURATE,
        "unbounded": SolveStatus.UNBOUNDED,
        "unbounded_inaccurate": SolveStatus.INACCURATE,
        "interrupted": SolveStatus.LIMIT,
    }

    def __init__(
        self,
        *,
        eps_abs: Annotated[float, Gt(0)] = 1e-7,
        eps_rel: Annotated[float, Gt(0)] = 1e-7,
        eps_infeas: Annotated[float, Gt(0)] | None = None,
        max_iters: Annotated[int, Gt(0)] = 200_000,
        time_limit_secs: Annotated[float, Gt(0)] | None = None,
        verbose: bool = False,
        normalize: bool | None = None,
        scale: Annotated[float, Gt(0)] | None = None,
        adaptive_scale: bool | None = None,
        rho_x: Annotated[float, Gt(0)] | None = None,
        alpha: Annotated[float, Gt(0)] | None = None,
        acceleration_lookback: int | None = None,
        acceleration_interval: Annotated[int, Gt(0)] | None = None,
        use_indirect: bool | None = None,
        gpu: bool | None = None,
    ) -> None:
        given = dict(locals())
        given.pop("self")
        #: The settings passed to SCS (those left at None use SCS's defaults).
        self.options: dict[str, Any] = {k: v for k, v in given.items() if v is not None}

    def solve(self, program: ConicProgram) -> ConicSolution:
        import scs

        c = program.cones
        data = {"A": sp.csc_matrix(program.A), "b": program.b, "c": program.c}
        if program.P is not None:
            data["P"] = sp.triu(program.P, format="csc")
        cone = {"z": c.zero, "l": c.nonneg, "q": list(c.soc), "s": list(c.psd)}
        try:
            out = scs.SCS(data, cone, **self.options).solve()
        except Exception as exc:
            raise SolverError(f"SCS failed: {exc}", SolveStatus.FAILED, "error") from exc
        info = out["info"]
        raw = str(info["status"])
        status = self.status(raw)
        if status is not SolveStatus.SOLVED:
            raise SolverError(
                f"SCS ended with status {raw!r} after {info['iter']} iterations, not 'solved': "
                "the model would be unreliable. Try more iterations (max_iters), solver "
                "'clarabel', or check the data",
                status,
                raw,
                x=np.asarray(out["x"]) if status is SolveStatus.INACCURATE else None,
            )
        return ConicSolution(x=np.asarray(out["x"]), iterations=int(info["iter"]))
