"""Conic programs in standard form and the solver interface that the backends implement.

Lives here: :class:`ConicProgram` (``min ½xᵀPx + cᵀx`` s.t. ``b − Ax ∈ K``), the cones, the
symmetric-matrix vectorisation, :class:`Solver` and its statuses (:mod:`.program`).

May import: :mod:`sysid_core.errors` and :mod:`sysid_core.data`.
"""

from sysid_core.conic.program import (
    SQRT2,
    SVEC_SYM,
    SYM_BASIS,
    ConeDims,
    ConicProgram,
    ConicSolution,
    Solver,
    SolveStatus,
    sigma_max_2x2,
    svec2,
    svec_indices,
    svec_length,
    sym,
    upper_colmajor_permutation,
)

__all__ = [
    "SQRT2",
    "SVEC_SYM",
    "SYM_BASIS",
    "ConeDims",
    "ConicProgram",
    "ConicSolution",
    "SolveStatus",
    "Solver",
    "sigma_max_2x2",
    "svec2",
    "svec_indices",
    "svec_length",
    "sym",
    "upper_colmajor_permutation",
]
