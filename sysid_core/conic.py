"""Conic programs in standard form: the meeting point of objectives and solvers.

A :class:`ConicProgram` is

.. math::

    \\min_x \\tfrac12 x^T P x + c^T x \\quad \\text{s.t.}\\quad b - A x = s \\in \\mathcal K,

where :math:`\\mathcal K` is the product, in this order, of a zero cone, a nonnegative orthant,
second-order cones and positive-semidefinite cones. A PSD cone of size :math:`n` takes the
scaled lower triangle of a symmetric matrix in column-major order (off-diagonal entries multiplied
by :math:`\\sqrt 2`), which is SCS's convention; backends that use another order permute rows.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from functools import cache

import numpy as np
import scipy.sparse as sp

__all__ = [
    "ConeDims",
    "ConicProgram",
    "ConicSolution",
    "svec_indices",
    "svec_length",
    "upper_colmajor_permutation",
]

SQRT2 = float(np.sqrt(2.0))


def svec_length(n: int) -> int:
    """Number of entries of the scaled triangle of an ``n`` × ``n`` symmetric matrix."""
    return n * (n + 1) // 2


@cache
def svec_indices(n: int) -> np.ndarray:
    """Row index of entry ``(i, j)``, ``i >= j``, in the canonical svec of an ``n`` × ``n`` matrix.

    Returns an ``n`` × ``n`` integer array ``idx`` with ``idx[i, j] = idx[j, i]`` equal to the
    position of that entry in the lower-triangle, column-major vector.
    """
    idx = np.empty((n, n), dtype=np.int64)
    k = 0
    for j in range(n):
        for i in range(j, n):
            idx[i, j] = idx[j, i] = k
            k += 1
    idx.setflags(write=False)
    return idx


@cache
def upper_colmajor_permutation(n: int) -> np.ndarray:
    """Positions, in the canonical svec, of the entries of the upper-column-major svec.

    ``canonical[perm]`` is the same matrix in Clarabel's order (upper triangle, column-major).
    """
    idx = svec_indices(n)
    perm = np.array([idx[i, j] for j in range(n) for i in range(j + 1)], dtype=np.int64)
    perm.setflags(write=False)
    return perm


@dataclass(frozen=True)
class ConeDims:
    """Sizes of the cones of a program, in the order zero, nonnegative, second-order, PSD."""

    zero: int = 0
    nonneg: int = 0
    soc: tuple[int, ...] = ()
    psd: tuple[int, ...] = ()

    @property
    def rows(self) -> int:
        """Total number of rows of ``A`` these cones take."""
        return self.zero + self.nonneg + sum(self.soc) + sum(svec_length(n) for n in self.psd)


@dataclass
class ConicProgram:
    """A conic program in standard form (see the module docstring).

    Attributes
    ----------
    c : ndarray, shape (n,)
        Linear objective.
    A : scipy.sparse.csc_matrix, shape (m, n)
        Constraint matrix.
    b : ndarray, shape (m,)
        Constraint offset.
    cones : ConeDims
        Cone sizes; ``cones.rows == m``.
    P : scipy.sparse.csc_matrix or None
        Symmetric PSD quadratic objective (full, not triangular), or ``None`` for a linear one.
    """

    c: np.ndarray
    A: sp.csc_matrix
    b: np.ndarray
    cones: ConeDims
    P: sp.csc_matrix | None = None
    meta: dict[str, object] = field(default_factory=dict)

    def __post_init__(self) -> None:
        m, n = self.A.shape
        if self.c.shape != (n,):
            raise ValueError(f"c has shape {self.c.shape}, expected ({n},)")
        if self.b.shape != (m,):
            raise ValueError(f"b has shape {self.b.shape}, expected ({m},)")
        if self.cones.rows != m:
            raise ValueError(f"cones take {self.cones.rows} rows but A has {m}")
        if self.P is not None and self.P.shape != (n, n):
            raise ValueError(f"P has shape {self.P.shape}, expected ({n}, {n})")

    @property
    def n_variables(self) -> int:
        """Number of variables."""
        return int(self.A.shape[1])

    @property
    def n_constraints(self) -> int:
        """Number of constraint rows."""
        return int(self.A.shape[0])


@dataclass
class ConicSolution:
    """What a :class:`~sysid_core.interfaces.Solver` returns.

    Attributes
    ----------
    x : ndarray
        Primal solution.
    objective : float
        Objective value at ``x``.
    status : str
        ``"solved"``; a backend raises :class:`~sysid_core.errors.SolverError` otherwise.
    solver_status : str
        The solver's own status word.
    iterations : int
        Iterations the solver took.
    solve_time : float
        Seconds spent in the solver.
    """

    x: np.ndarray
    objective: float
    status: str
    solver_status: str
    iterations: int
    solve_time: float
