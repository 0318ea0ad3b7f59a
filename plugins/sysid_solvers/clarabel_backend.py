"""Clarabel backend: calls ``clarabel.DefaultSolver`` directly on the standard form."""

from __future__ import annotations

from typing import Any, ClassVar

import numpy as np
import scipy.sparse as sp

from sysid_core.conic.program import (
    ConicProgram,
    ConicSolution,
    Solver,
    SolveStatus,
    svec_length,
    upper_colmajor_permutation,
)
from sysid_core.errors import ConfigError, SolverError

__all__ = ["ClarabelSolver"]


def _row_permutation(program: ConicProgram) -> np.ndarray:
    """Rows of the canonical program in Clarabel's order (PSD blocks upper column-major)."""
    cones = program.cones
    head = cones.zero + cones.nonneg + sum(cones.soc)
    parts = [np.arange(head)]
    start = head
    for n in cones.psd:
        parts.append(start + upper_colmajor_permutation(n))
        start += svec_length(n)
    return np.concatenate(parts)


class ClarabelSolver(Solver):
    """Clarabel interior-point solver.

    Parameters
    ----------
    **options
        Any attribute of ``clarabel.DefaultSettings`` (``tol_gap_rel``, ``max_iter``, ...).
        Defaults here: ``verbose=False`` and ``chordal_decomposition_enable=False`` (measured on
        these 8x8 cones: decomposition splits them, costs about 45 % more time and ends
        "AlmostSolved").

    Only status ``Solved`` is accepted; any other status (``AlmostSolved`` included) raises
    :class:`~sysid_core.errors.SolverError` with its :class:`~sysid_core.conic.program.SolveStatus`.
    The options are open-ended (every Clarabel setting), so this backend takes ``**options``
    and lets Clarabel check each one as it is set, at construction.
    """

    name = "clarabel"
    description = "Clarabel interior-point conic solver (direct, standard form)"
    #: Clarabel's status words and the toolkit's (an unknown word is FAILED).
    STATUS_MAP: ClassVar[dict[str, SolveStatus]] = {
        "Solved": SolveStatus.SOLVED,
        "AlmostSolved": SolveStatus.INACCURATE,
        "AlmostPrimalInfeasible": SolveStatus.INACCURATE,
        "AlmostDualInfeasible": SolveStatus.INACCURATE,
        "PrimalInfeasible": SolveStatus.INFEASIBLE,
        "DualInfeasible": SolveStatus.UNBOUNDED,
        "MaxIterations": SolveStatus.LIMIT,
        "MaxTime": SolveStatus.LIMIT,
        "NumericalError": SolveStatus.FAILED,
        "InsufficientProgress": SolveStatus.FAILED,
    }

    def __init__(self, **options: Any) -> None:
        import clarabel

        settings = clarabel.DefaultSettings()
        known = [a for a in dir(settings) if not a.startswith("_") and a != "default"]
        for key, value in options.items():
            if key not in known:
                raise ConfigError(
                    f"unknown option {key!r} for solver 'clarabel'; see clarabel.DefaultSettings"
                    f" (e.g. tol_gap_rel, tol_feas, max_iter, time_limit, verbose)"
                )
            try:  # Clarabel checks each setting's type as it is set: do it now, not at the fit
                setattr(settings, key, value)
            except (TypeError, ValueError, OverflowError) as exc:
                raise ConfigError(
                    f"option {key!r} of solver 'clarabel' = {value!r} is not valid: {exc}"
                ) from None
        self.options = {"verbose": False, "chordal_decomposition_enable": False, **options}

    #: Static regularisation of the retry after an "AlmostSolved" (Clarabel's default: 1e-8).
    RETRY_REGULARIZATION = 1e-7

    def solve(self, program: ConicProgram) -> ConicSolution:
        """Solve; after an "AlmostSolved", once more with a stronger static regularisation.

        Measured on few-point fits (a lean run's 17-point window around two degenerate modes):
        the default stalls at "AlmostSolved" after 11 iterations, while a static
        regularisation of :data:`RETRY_REGULARIZATION` reaches "Solved" at the same tolerances
        with the same answer as SCS. The retry is skipped when the option was set by the user.
        """
        try:
            return self._solve(program, {})
        except SolverError as exc:
            if (
                exc.status is not SolveStatus.INACCURATE
                or "static_regularization_constant" in self.options
            ):
                raise
            return self._solve(
                program, {"static_regularization_constant": self.RETRY_REGULARIZATION}
            )

    def _solve(self, program: ConicProgram, extra: dict[str, Any]) -> ConicSolution:
        import clarabel

        settings = clarabel.DefaultSettings()
        for key, value in {**self.options, **extra}.items():
            setattr(settings, key, value)
        perm = _row_permutation(program)
        a = sp.csc_matrix(program.A)[perm]
        b = program.b[perm]
        n = program.n_variables
        p = sp.triu(program.P, format="csc") if program.P is not None else sp.csc_matrix((n, n))
        cones = []
        c = program.cones
        if c.zero:
            cones.append(clarabel.ZeroConeT(c.zero))
        if c.nonneg:
            cones.append(clarabel.NonnegativeConeT(c.nonneg))
        cones += [clarabel.SecondOrderConeT(q) for q in c.soc]
        cones += [clarabel.PSDTriangleConeT(s) for s in c.psd]
        try:
            sol = clarabel.DefaultSolver(p, program.c, sp.csc_matrix(a), b, cones, settings).solve()
        except Exception as exc:  # clarabel raises on malformed data
            raise SolverError(f"Clarabel failed: {exc}", SolveStatus.FAILED, "error") from exc
        raw = str(sol.status).split(".")[-1]
        status = self.status(raw)
        if status is not SolveStatus.SOLVED:
            raise SolverError(
                f"Clarabel ended with status {raw!r} after {sol.iterations} iterations, not "
                "'Solved': the model would be unreliable. Try solver 'scs', another objective, "
                "or check the data for outliers",
                status,
                raw,
                x=np.asarray(sol.x) if status is SolveStatus.INACCURATE else None,
            )
        return ConicSolution(x=np.asarray(sol.x), iterations=int(sol.iterations))
