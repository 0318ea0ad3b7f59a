"""Tuning in the squared potentials ``w_p = v_p**2``, where every criterion is convex.

The stiffness ``K(w) = K0 + sum_p K_p w_p`` is affine in ``w``; the modal frequencies are the
generalized eigenvalues of ``(K(w), M)``. A criterion solves a small semidefinite program in
``w`` over the reachable box (from the device's bias limits), then maps ``w`` back to biases
``dv_p = v_gyro -/+ sqrt(w_p)`` inside the limits. A bias outside the limits is never returned.

Numerics: the programs are written for ``K~(w) = (K(w) - lam_ref M) / (lam_ref d)`` with
``lam_ref`` the mean eigenvalue at the centre of the box and ``d = 1e-3``, so a 1 mHz split is
O(1e-4) rather than O(1e-7) of the matrix entries.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any

import numpy as np
import scipy.linalg
import scipy.sparse as sp

from sysid_core.conic import SQRT2, ConeDims, ConicProgram
from sysid_core.errors import BiasLimitError, ConfigError, SolverError

if TYPE_CHECKING:
    from sysid_core.interfaces import Solver
    from sysid_core.model import FittedModel

__all__ = [
    "BiasSpace",
    "TuningResult",
    "bias_from_w",
    "degenerate_w",
    "frequencies_from_w",
    "spread_program",
    "w_interval",
]

_D = 1e-3
_SVEC = np.diag([1.0, SQRT2, 1.0])


def _sv(x: np.ndarray) -> np.ndarray:
    return _SVEC @ np.array([x[0, 0], x[1, 0], x[1, 1]])


def degenerate_w(
    k_base: np.ndarray, k_a: np.ndarray, k_b: np.ndarray, m: np.ndarray
) -> tuple[float, float, float]:
    """Exact two-electrode degeneracy: solve ``k_base + w_a k_a + w_b k_b = lam m``.

    Three linear equations (the entries of a symmetric 2x2) in ``(w_a, w_b, lam)``; the
    modal frequencies are then both ``sqrt(lam) / 2 pi``.
    """
    def entries(x: np.ndarray) -> np.ndarray:
        return np.array([x[0, 0], x[0, 1], x[1, 1]])

    lhs = np.column_stack([entries(k_a), entries(k_b), -entries(m)])
    w_a, w_b, lam = np.linalg.solve(lhs, -entries(k_base))
    return float(w_a), float(w_b), float(lam)


def w_interval(v_gyro: float, low: float, high: float) -> tuple[float, float]:
    """Reachable ``w = (v_gyro - dv)**2`` for ``dv`` in ``[low, high]``."""
    if low > high:
        raise BiasLimitError(f"empty bias interval [{low}, {high}]")
    v_lo, v_hi = v_gyro - high, v_gyro - low
    w_max = max(v_lo**2, v_hi**2)
    w_min = 0.0 if v_lo <= 0.0 <= v_hi else min(v_lo**2, v_hi**2)
    return w_min, w_max


def bias_from_w(w: float, v_gyro: float, low: float, high: float, tol: float = 1e-9) -> float:
    """The bias ``dv = v_gyro -/+ sqrt(w)`` inside ``[low, high]`` (the smaller ``|dv|`` if both).

    Raises
    ------
    BiasLimitError
        If neither root is inside the limits.
    """
    root = float(np.sqrt(max(w, 0.0)))
    inside = [
        float(np.clip(dv, low, high))
        for dv in (v_gyro - root, v_gyro + root)
        if low - tol <= dv <= high + tol
    ]
    if not inside:
        raise BiasLimitError(
            f"w = {w:.6g} V^2 needs a bias of {v_gyro - root:.4f} or {v_gyro + root:.4f} V, "
            f"outside the limits [{low}, {high}] V"
        )
    return min(inside, key=abs)


def frequencies_from_w(model: FittedModel, w: np.ndarray) -> np.ndarray:
    """Undamped modal frequencies (Hz) of ``model`` at squared potentials ``w``."""
    lam = scipy.linalg.eigh(model.stiffness_w(w), model.M, eigvals_only=True)
    return np.sqrt(np.clip(lam, 0.0, None)) / (2 * np.pi)


@dataclass(frozen=True)
class BiasSpace:
    """Where a criterion may move the biases.

    Attributes
    ----------
    electrodes : list of str
        All of the device's bias electrodes.
    tuned : list of str
        The electrodes being tuned, in the order of the model's electrodes.
    start_bias : ndarray
        Bias of every electrode (volts); electrodes not tuned stay at these values.
    limits : tuple of float
        Allowed bias ``(low, high)`` in volts.
    structure_potential : float
        ``v_gyro`` in volts.
    """

    electrodes: list[str]
    tuned: list[str]
    start_bias: np.ndarray
    limits: tuple[float, float]
    structure_potential: float

    def __post_init__(self) -> None:
        unknown = [e for e in self.tuned if e not in self.electrodes]
        if unknown:
            raise ConfigError(
                f"cannot tune electrode(s) {unknown}: the device has {self.electrodes}"
            )
        if len(self.start_bias) != len(self.electrodes):
            raise ConfigError(
                f"start_bias has {len(self.start_bias)} values; the device has "
                f"{len(self.electrodes)} electrodes ({', '.join(self.electrodes)})"
            )

    @property
    def index(self) -> list[int]:
        """Positions of the tuned electrodes among all electrodes."""
        return [self.electrodes.index(e) for e in self.tuned]

    def box(self, max_abs_bias: float | None = None) -> np.ndarray:
        """Reachable ``w`` per tuned electrode, ``(n_t, 2)``; optionally with ``|dv| <= T``."""
        low, high = self.limits
        if max_abs_bias is not None:
            low, high = max(low, -max_abs_bias), min(high, max_abs_bias)
        return np.array([w_interval(self.structure_potential, low, high) for _ in self.tuned])

    def full_bias(self, tuned_bias: Sequence[float]) -> np.ndarray:
        """All electrodes' biases: the tuned ones set, the others at their start value."""
        out = np.array(self.start_bias, dtype=float)
        out[self.index] = tuned_bias
        return out

    def to_bias(self, w: np.ndarray, max_abs_bias: float | None = None) -> np.ndarray:
        """Full bias vector for squared potentials ``w`` of the tuned electrodes."""
        low, high = self.limits
        if max_abs_bias is not None:
            low, high = max(low, -max_abs_bias), min(high, max_abs_bias)
        tuned = [bias_from_w(wp, self.structure_potential, low, high) for wp in w]
        return self.full_bias(tuned)


@dataclass
class TuningResult:
    """A criterion's answer.

    Attributes
    ----------
    bias : ndarray
        Bias of every electrode (volts), inside the limits.
    w : ndarray
        Squared potentials of the tuned electrodes.
    frequencies_hz : ndarray
        The model's modal frequencies at ``bias``.
    split_hz : float
        The model's predicted split at ``bias``.
    criterion : str
        Name of the criterion.
    value : float
        The criterion's optimal value in Hz (split, or frequency error for ``target``).
    info : dict
        Anything else (target, max |dv|, ...).
    """

    bias: np.ndarray
    w: np.ndarray
    frequencies_hz: np.ndarray
    split_hz: float
    criterion: str
    value: float
    info: dict[str, Any] = field(default_factory=dict)

    @property
    def frequency_hz(self) -> float:
        """Mean predicted modal frequency."""
        return float(np.mean(self.frequencies_hz))

    def as_dict(self) -> dict[str, Any]:
        """JSON-friendly form."""
        return {
            "criterion": self.criterion,
            "bias": [float(b) for b in self.bias],
            "predicted_frequencies_hz": [float(f) for f in self.frequencies_hz],
            "predicted_split_hz": self.split_hz,
            "value_hz": self.value,
            **{k: v for k, v in self.info.items() if isinstance(v, (int, float, str, list))},
        }


class _Scaled:
    """The model's stiffness in the well-conditioned coordinates of the module docstring."""

    def __init__(self, model: FittedModel, box: np.ndarray) -> None:
        self.model = model
        self.box = box
        self.w_c = box.mean(axis=1)
        self.w_s = np.maximum((box[:, 1] - box[:, 0]) / 2, 1e-12)
        k_c = model.stiffness_w(self.w_c)
        lam = scipy.linalg.eigh(k_c, model.M, eigvals_only=True)
        self.lam_ref = float(lam.mean())
        self.k_c = (k_c - self.lam_ref * model.M) / (self.lam_ref * _D)
        self.k_p = model.Kp * (self.w_s / (self.lam_ref * _D))[:, None, None]

    def w(self, u: np.ndarray) -> np.ndarray:
        """Squared potentials from the scaled variables ``u`` in [-1, 1]."""
        return self.w_c + self.w_s * u

    def hz(self, t: float) -> float:
        """An eigenvalue spread ``t`` (scaled) as a frequency difference near ``lam_ref`` (Hz)."""
        lam = self.lam_ref
        return float((np.sqrt(lam + t * lam * _D) - np.sqrt(lam)) / (2 * np.pi))

    def lam(self, mu: float) -> float:
        """A scaled eigenvalue offset ``mu`` as an eigenvalue."""
        return self.lam_ref * (1 + _D * mu)


def spread_program(
    model: FittedModel,
    box: np.ndarray,
    target_lam: float | None = None,
    bound: float | None = None,
    anchor_w: np.ndarray | None = None,
) -> tuple[ConicProgram, _Scaled]:
    """The eigenvalue-spread program in scaled variables ``x = [u (n_t), mu, t]``.

    Without ``target_lam``: ``min t`` s.t. ``mu M ⪯ K~(w) ⪯ (mu + t) M`` (degenerate, eq. 14
    in its spread form). With ``target_lam``: ``min t`` s.t. ``(m0 - t) M ⪯ K~(w) ⪯ (m0 + t) M``
    where ``m0`` is the target (eq. 23 in a form that bounds the frequency error directly).
    With ``bound`` and ``anchor_w``: ``min ||(w - anchor_w)/s||^2`` s.t. ``t <= bound`` (the
    smallest change among near-optimal points, used to pick a unique answer).
    """
    sc = _Scaled(model, box)
    n_t = box.shape[0]
    n_x = n_t + 2
    iu, imu, it = slice(0, n_t), n_t, n_t + 1
    rows_a: list[np.ndarray] = []
    rows_b: list[np.ndarray] = []
    # Box: -1 <= u <= 1  ->  1 - u >= 0, 1 + u >= 0
    a_box = np.zeros((2 * n_t, n_x))
    a_box[:n_t, iu] = np.eye(n_t)
    a_box[n_t:, iu] = -np.eye(n_t)
    b_box = np.ones(2 * n_t)
    m_sv = _sv(model.M)
    kc_sv = _sv(sc.k_c)
    kp_sv = np.array([_sv(k) for k in sc.k_p]).T  # (3, n_t)
    # Lower: K~(w) - low*M ⪰ 0 ; upper: high*M - K~(w) ⪰ 0 ; s = b - A x
    lower = np.zeros((3, n_x))
    upper = np.zeros((3, n_x))
    lower[:, iu] = -kp_sv
    upper[:, iu] = kp_sv
    if target_lam is None:
        lower[:, imu] = m_sv  # - (-mu M)
        upper[:, imu] = -m_sv
        upper[:, it] = -m_sv
        b_low, b_up = kc_sv, -kc_sv
    else:
        m0 = (target_lam / sc.lam_ref - 1) / _D
        lower[:, it] = -m_sv  # K~ - (m0 - t) M
        upper[:, it] = -m_sv  # (m0 + t) M - K~
        b_low, b_up = kc_sv - m0 * m_sv, m0 * m_sv - kc_sv
    rows_a += [lower, upper]
    rows_b += [b_low, b_up]
    nonneg_a, nonneg_b = [a_box], [b_box]
    c = np.zeros(n_x)
    p = None
    if bound is None:
        c[it] = 1.0
    else:
        cap = np.zeros((1, n_x))
        cap[0, it] = 1.0
        nonneg_a.append(cap)
        nonneg_b.append(np.array([bound]))
        anchor_u = (np.asarray(anchor_w) - sc.w_c) / sc.w_s
        diag = np.zeros(n_x)
        diag[iu] = 2.0
        p = sp.diags(diag, format="csc")
        c[iu] = -2.0 * anchor_u
    a = np.vstack(nonneg_a + rows_a)
    b = np.concatenate(nonneg_b + rows_b)
    n_nonneg = sum(x.shape[0] for x in nonneg_a)
    prog = ConicProgram(
        c=c, A=sp.csc_matrix(a), b=b, cones=ConeDims(nonneg=n_nonneg, psd=(2, 2)), P=p
    )
    return prog, sc


def solve_spread(
    model: FittedModel,
    box: np.ndarray,
    solver: Solver,
    target_lam: float | None = None,
    anchor_w: np.ndarray | None = None,
    tie_tol_hz: float = 1e-5,
) -> tuple[np.ndarray, float]:
    """Minimise the spread (or target error); return ``(w, optimal value in Hz)``.

    With ``anchor_w`` and more than two tuned electrodes, the answer is the point closest to
    ``anchor_w`` (scaled) among those within ``tie_tol_hz`` of the optimum: unique. If that
    second program fails in the solver (seen with Clarabel, "InsufficientProgress", when the
    near-optimal set is a thin sliver far from the anchor), the first answer, also optimal, is
    kept.
    """
    prog, sc = spread_program(model, box, target_lam)
    sol = solver.solve(prog)
    n_t = box.shape[0]
    u, t = sol.x[:n_t], float(sol.x[n_t + 1])
    if anchor_w is not None and n_t > 2:
        # t (scaled) that corresponds to tie_tol_hz more spread
        lam = sc.lam_ref
        dt = ((np.sqrt(lam) + 2 * np.pi * tie_tol_hz) ** 2 - lam) / (lam * _D)
        prog2, _ = spread_program(model, box, target_lam, bound=t + dt, anchor_w=anchor_w)
        try:
            u = solver.solve(prog2).x[:n_t]
        except SolverError:
            pass  # keep the optimal (if not unique) answer of the first program
    w = np.clip(sc.w(np.clip(u, -1.0, 1.0)), box[:, 0], box[:, 1])
    return w, t


def reachable(value_hz: float, tolerance_hz: float) -> bool:
    """Whether an optimal spread / error is small enough to count as reached."""
    return value_hz <= tolerance_hz
