r"""Conic programs in standard form, the solver interface, and the building blocks of both.

A :class:`ConicProgram` is

.. math::

    \min_x \tfrac12 x^T P x + c^T x \quad \text{s.t.}\quad b - A x = s \in \mathcal K,

where :math:`\mathcal K` is the product, in this order, of a zero cone, a nonnegative orthant,
second-order cones and positive-semidefinite cones. A PSD cone of size :math:`n` takes the
scaled lower triangle of a symmetric matrix in column-major order (off-diagonal entries multiplied
by :math:`\sqrt 2`), which is SCS's convention; backends that use another order permute rows.

This is where objectives (which assemble programs) and solvers (which solve them) meet: a
:class:`Solver` backend returns a :class:`ConicSolution` whose :class:`SolveStatus` is the
toolkit's own, never the solver's word, or raises :class:`~sysid_core.errors.SolverError`
carrying that status.

Building blocks shared by every program: :func:`svec_indices` (positions in a PSD cone),
:func:`sym` / :data:`SYM_BASIS` (the symmetric 2×2 matrices the models are made of) and
:func:`svec2` (a symmetric 2×2 matrix as the three rows of a 2×2 PSD cone).
"""

from __future__ import annotations

import enum
from abc import ABC, abstractmethod
from dataclasses import dataclass
from functools import cache
from typing import ClassVar

import numpy as np
import scipy.sparse as sp

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

SQRT2 = float(np.sqrt(2.0))

#: Symmetric 2×2 basis: a symmetric matrix is ``x0*S0 + x1*S1 + x2*S2``.
SYM_BASIS = np.array([[[1.0, 0.0], [0.0, 0.0]], [[0.0, 1.0], [1.0, 0.0]], [[0.0, 0.0], [0.0, 1.0]]])
#: The svec (lower, column-major, scaled) of ``x0*S0 + x1*S1 + x2*S2`` is ``SVEC_SYM @ x``.
SVEC_SYM = np.diag([1.0, SQRT2, 1.0])


def sym(v: np.ndarray) -> np.ndarray:
    """The symmetric 2×2 matrix with entries ``[[v0, v1], [v1, v2]]``."""
    return np.tensordot(np.asarray(v, dtype=float), SYM_BASIS, axes=1)


def svec2(x: np.ndarray) -> np.ndarray:
    """The rows of a 2×2 PSD cone for the symmetric matrix ``x``: ``[x00, √2 x10, x11]``."""
    return np.array([x[0, 0], SQRT2 * x[1, 0], x[1, 1]])


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

    def __post_init__(self) -> None:
        """Check that ``c``, ``b``, ``cones`` and ``P`` agree with the shape of ``A``."""
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


class SolveStatus(enum.Enum):
    """How a solve ended, in the toolkit's words (each backend maps its solver's to these)."""

    #: An accurate optimum: the only status a :class:`ConicSolution` carries.
    SOLVED = "solved"
    #: Close to an optimum but not within tolerance (Clarabel "AlmostSolved", SCS
    #: "solved_inaccurate"): more data points or another solver may help.
    INACCURATE = "inaccurate"
    #: The program has no feasible point.
    INFEASIBLE = "infeasible"
    #: The objective is unbounded below.
    UNBOUNDED = "unbounded"
    #: Stopped by an iteration or time limit.
    LIMIT = "limit"
    #: Anything else: numerical trouble, a malformed program, an unknown status word.
    FAILED = "failed"

    def __str__(self) -> str:
        """The status word, e.g. ``"solved"``."""
        return self.value


@dataclass(frozen=True)
class ConicSolution:
    """What a :class:`Solver` returns (only for :attr:`SolveStatus.SOLVED`).

    Attributes
    ----------
    x : ndarray
        Primal solution.
    iterations : int
        Iterations the solver took.
    """

    x: np.ndarray
    iterations: int


class Solver(ABC):
    """A conic-solver backend: solves a :class:`ConicProgram`.

    A backend maps its solver's status words to :class:`SolveStatus` (``STATUS_MAP``): anything
    but an accurate optimum raises :class:`~sysid_core.errors.SolverError` with that status,
    never a silently bad answer. An unknown status word maps to ``FAILED``.
    """

    name: ClassVar[str]
    description: ClassVar[str] = ""
    #: The solver's status words and what they mean to the toolkit.
    STATUS_MAP: ClassVar[dict[str, SolveStatus]] = {}

    @abstractmethod
    def solve(self, program: ConicProgram) -> ConicSolution:
        """Solve ``program`` and return its solution, or raise ``SolverError``."""

    def status(self, word: str) -> SolveStatus:
        """The toolkit's status for the solver's status ``word``."""
        return self.STATUS_MAP.get(word, SolveStatus.FAILED)


def sigma_max_2x2(e: np.ndarray) -> np.ndarray:
    """Largest singular value of each complex 2x2 matrix in ``e`` (shape ``(..., 2, 2)``)."""
    fro2 = np.sum(np.abs(e) ** 2, axis=(-2, -1))
    det = e[..., 0, 0] * e[..., 1, 1] - e[..., 0, 1] * e[..., 1, 0]
    disc = np.sqrt(np.maximum(fro2**2 - 4 * np.abs(det) ** 2, 0.0))
    return np.sqrt(0.5 * (fro2 + disc))
