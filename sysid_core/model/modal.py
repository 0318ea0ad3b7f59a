"""Modes of ``M x'' + C x' + K x``: frequencies, Q, and each mode's share of a model's response.

* :func:`modal_analysis`: undamped frequencies (generalized eigenvalues of ``(K, M)``), damped
  frequencies and Q of the two modes.
* :func:`principal_part`: the response's two resonances as ``Cc (sI - T)^-1 Bc``, exactly, with
  the polynomial ``P`` continued to the poles. Used to realise a model as a state-space system
  (:mod:`sysid_core.model.export`) and to tell whether a mode shows in a measurement
  (:mod:`sysid_core.measure.verification`).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np
import scipy.linalg

from sysid_core.data.schema import squared_potentials
from sysid_core.errors import ModelError

__all__ = [
    "MODAL_COND_LIMIT",
    "ModalReport",
    "bandwidth_hz",
    "degenerate_bias",
    "degenerate_pair_bias",
    "degenerate_w",
    "mass_roots",
    "modal_analysis",
    "modal_frequencies_hz",
    "mode_peaks",
    "normalised_stiffness",
    "principal_part",
    "snr_loss_db",
    "split_vector_hz",
    "trace_deviation",
]

#: :func:`principal_part` keeps the two modes in triangular (Schur) form instead of diagonal
#: form when the eigenvectors' condition number exceeds this (nearly defective modes).
MODAL_COND_LIMIT = 1e6


def normalised_stiffness(m: np.ndarray, k: np.ndarray) -> np.ndarray:
    """``M^{-1/2} K M^{-1/2}`` for stacks ``m`` ``(S, 2, 2)`` and ``k`` ``(S, ..., 2, 2)``.

    Its eigenvalues are the generalized eigenvalues of ``(K, M)``: the squared undamped modal
    frequencies (rad/s)².
    """
    lam, vec = np.linalg.eigh(m)
    root = 1.0 / np.sqrt(np.clip(lam, 1e-12, None))
    mh = np.einsum("sij,sj,skj->sik", vec, root, vec)
    extra = k.ndim - 3
    mh_b = mh.reshape(mh.shape[0], *([1] * extra), 2, 2)
    return mh_b @ k @ mh_b


def mass_roots(m: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """``M^{1/2}`` and ``M^{-1/2}`` of one symmetric positive definite 2×2 mass matrix.

    A traceless offset ``D`` of the normalised stiffness is ``M^{1/2} D M^{1/2}`` in the
    model's own frame.
    """
    lam, vec = np.linalg.eigh(np.asarray(m, dtype=float))
    root = (vec * np.sqrt(np.clip(lam, 0.0, None))) @ vec.T
    return root, (vec / np.sqrt(np.clip(lam, 1e-300, None))) @ vec.T


def trace_deviation(k: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """``t`` and ``d = (d1, d2)`` of symmetric 2×2 matrices (last two axes).

    The eigenvalues are ``t ± |d|``, so ``|d|`` alone sets how far apart they are.
    """
    t = 0.5 * (k[..., 0, 0] + k[..., 1, 1])
    d = np.stack([0.5 * (k[..., 0, 0] - k[..., 1, 1]), k[..., 0, 1]], axis=-1)
    return t, d


def modal_frequencies_hz(k: np.ndarray, m: np.ndarray) -> np.ndarray:
    """The two undamped modal frequencies (Hz) of stiffness ``k`` and mass ``m``, ascending.

    The one modal-frequency function of the toolkit: ``sqrt(λ) / 2π`` for the generalized
    eigenvalues ``λ = t ± |d|`` of ``(K, M)`` (:func:`normalised_stiffness`,
    :func:`trace_deviation`), in closed form. ``k`` may be one matrix ``(2, 2)`` or a stack
    ``(S, 2, 2)`` (then ``m`` is one matrix or a stack of ``S``); the result has shape ``(2,)``
    or ``(S, 2)``. A negative eigenvalue (no oscillating mode) gives frequency 0.
    """
    k = np.asarray(k, dtype=float)
    single = k.ndim == 2
    ks = k[None] if single else k
    ms = np.broadcast_to(np.asarray(m, dtype=float), ks.shape)
    t, d = trace_deviation(normalised_stiffness(np.ascontiguousarray(ms), ks[:, None])[:, 0])
    r = np.hypot(d[..., 0], d[..., 1])
    low = np.sqrt(np.clip(t - r, 0.0, None))
    high = np.sqrt(np.clip(t + r, 0.0, None))
    f = np.stack([low, high], axis=-1) / (2 * np.pi)
    return f[0] if single else f


def bandwidth_hz(frequencies_hz: np.ndarray, q: np.ndarray) -> np.ndarray:
    """Half-power bandwidths ``f / Q`` (Hz); ``inf`` where ``Q`` is not a positive number."""
    f = np.asarray(frequencies_hz, dtype=float)
    q = np.asarray(q, dtype=float)
    ok = np.isfinite(q) & (q > 0)
    return np.where(ok, f / np.where(ok, q, 1.0), np.inf)


def snr_loss_db(split_hz: float, center_hz: float, q: float) -> float:
    """SNR loss ``10 log10(1 + 4 Q^2 mu^2)`` in dB, ``mu = split / center`` (paper, Sec. I)."""
    mu = split_hz / center_hz
    return float(10 * np.log10(1 + 4 * q**2 * mu**2))


@dataclass(frozen=True)
class ModalReport:
    """Modal figures of a model at one bias.

    Attributes
    ----------
    bias : list of float
        Bias potentials (volts relative to ground).
    frequencies_hz : ndarray
        Undamped modal frequencies (generalized eigenvalues of ``(K, M)``), ascending.
    damped_hz : ndarray
        Exact damped modal frequencies, ascending.
    q : ndarray
        Quality factor of each damped mode.
    split_hz : float
        ``frequencies_hz[1] - frequencies_hz[0]``.
    snr_loss_db : float
        ``10 log10(1 + 4 Q^2 mu^2)`` with the mean Q and ``mu = split / mean frequency``.
    """

    bias: list[float]
    frequencies_hz: np.ndarray
    damped_hz: np.ndarray
    q: np.ndarray
    split_hz: float
    snr_loss_db: float

    @property
    def center_hz(self) -> float:
        """The mean of the two undamped modal frequencies (Hz)."""
        return float(np.mean(self.frequencies_hz))

    @property
    def bandwidth_hz(self) -> np.ndarray:
        """Each mode's half-power bandwidth ``f / Q`` (Hz; :func:`bandwidth_hz`)."""
        return bandwidth_hz(self.frequencies_hz, self.q)

    def as_dict(self) -> dict[str, Any]:
        """JSON-friendly form."""
        return {
            "bias": [float(b) for b in self.bias],
            "frequencies_hz": [float(f) for f in self.frequencies_hz],
            "damped_hz": [float(f) for f in self.damped_hz],
            "q": [float(q) for q in self.q],
            "split_hz": self.split_hz,
            "snr_loss_db": self.snr_loss_db,
        }


def modal_analysis(
    m: np.ndarray, c: np.ndarray, k: np.ndarray
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Modal frequencies of ``M x'' + C x' + K x``.

    Returns
    -------
    undamped_hz : ndarray
        ``sqrt(lambda) / 2 pi`` for the generalized eigenvalues of ``(K, M)``, ascending.
    damped_hz : ndarray
        ``|Im s| / 2 pi`` of the state matrix's eigenvalues (one per mode), ascending.
    q : ndarray
        Quality factor ``|s| / (2 |Re s|)`` of each damped mode, in the order of ``damped_hz``.
    """
    undamped = modal_frequencies_hz(k, m)
    minv = np.linalg.inv(m)
    a = np.block([[np.zeros((2, 2)), np.eye(2)], [-minv @ k, -minv @ c]])
    s = np.linalg.eigvals(a)
    s = s[s.imag > 0] if np.count_nonzero(s.imag > 0) == 2 else s[np.argsort(-s.imag)[:2]]
    s = s[np.argsort(s.imag)]
    damped = np.abs(s.imag) / (2 * np.pi)
    with np.errstate(divide="ignore"):
        q = np.abs(s) / (2 * np.abs(s.real))
    return np.sort(undamped), damped, q


def principal_part(
    m: np.ndarray,
    c: np.ndarray,
    k: np.ndarray,
    poly: np.ndarray,
    omega_center: float,
    omega_half: float,
    side: str,
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The response's principal part at its two upper poles, as ``Cc (sI - T)^-1 Bc``.

    The response is ``P(nu) Z^-1`` (``side="output"``) or ``Z^-1 P(nu)`` (``"input"``) with
    ``Z(s) = M s^2 + C s + K`` and ``nu = (omega - omega_center) / omega_half``. ``T`` (2, 2)
    holds the upper poles of ``Z^-1`` (diagonal unless they are nearly defective, then upper
    triangular); ``Bc`` and ``Cc`` (2, 2) are complex. The principal part of
    ``P(nu(s)) C (sI - T)^-1 B`` is ``sum_l P_l C N^l (sI - T)^-1 B`` with the matrix
    ``N = nu(-jT)``: the analytic continuation of ``P`` to the poles, exact also for repeated
    poles.

    Raises
    ------
    ModelError
        If the mechanical poles are not two stable oscillating modes.
    """
    w0 = omega_center
    minv = np.linalg.inv(m)
    # States x and x'/w0: every entry of A is O(w0), so the poles are accurate to eps*w0
    # (with x' itself the O(w0^2) stiffness block costs about five digits of the damping).
    a = np.block([[np.zeros((2, 2)), w0 * np.eye(2)], [-minv @ k / w0, -minv @ c]])
    # scipy-stubs type ``sort`` only as the real form's (re, im) -> bool; with output="complex"
    # scipy passes the one complex eigenvalue (its own docstring's example does this).
    t, q, n_upper = scipy.linalg.schur(  # type: ignore[call-overload]
        a.astype(complex), output="complex", sort=lambda z: z.imag > 0
    )
    poles = np.diag(t)
    if n_upper != 2 or not np.all(np.isfinite(poles)) or np.any(poles.real >= 0):
        raise ModelError(
            "the model's mechanical poles at this bias are not two stable oscillating "
            f"modes (poles {', '.join(f'{p:.6g}' for p in poles)} rad/s): its damping C "
            "must be positive definite and its modes underdamped"
        )
    t11, t12, t22 = t[:2, :2], t[:2, 2:], t[2:, 2:]
    # Block-diagonalise: T11 S - S T22 = -T12; the upper and lower poles are 2*w0 apart.
    sylvester = scipy.linalg.solve_sylvester(t11, -t22, -t12)
    qh = q.conj().T
    left = qh[:2] - sylvester @ qh[2:]  # rows spanning the upper left-invariant subspace
    cx = q[:2, :2]  # [I 0] X
    yb = left[:, 2:] @ (minv / w0)  # Y [0; M^-1 / w0]
    nu = (-1j * t11 - w0 * np.eye(2)) / omega_half
    powers = [np.eye(2, dtype=complex)]
    for _ in range(1, poly.shape[0]):
        powers.append(powers[-1] @ nu)
    if side == "output":  # P Z^-1
        cc = sum(poly[d] @ cx @ powers[d] for d in range(poly.shape[0]))
        bc = yb
    elif side == "input":  # Z^-1 P
        cc = cx
        bc = sum(powers[d] @ yb @ poly[d] for d in range(poly.shape[0]))
    else:
        raise ModelError(f"unknown model side {side!r}: 'output' (P Z^-1) or 'input' (Z^-1 P)")
    lam, vec = np.linalg.eig(t11)
    if np.linalg.cond(vec) < MODAL_COND_LIMIT:  # modal form, unless nearly defective
        t11, cc, bc = np.diag(lam), cc @ vec, np.linalg.solve(vec, bc)
    # Balance each state: |column of Cc| = |row of Bc|.
    cn, bn = np.linalg.norm(cc, axis=0), np.linalg.norm(bc, axis=1)
    d = np.where((cn > 0) & (bn > 0), np.sqrt(bn / np.where(cn > 0, cn, 1.0)), 1.0)
    return t11 * d[None, :] / d[:, None], bc / d[:, None], cc * d[None, :]


def mode_peaks(t: np.ndarray, bc: np.ndarray, cc: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Each mode's pole and its response at its own resonance, ``σ̄(c_i b_iᵀ) / |Re p_i|``.

    From :func:`principal_part`. In triangular form (nearly defective modes) the coupling term
    is left out: both modes then share one resonance.

    Returns
    -------
    poles : ndarray, complex, shape (2,)
        Ascending in frequency.
    peaks : ndarray, shape (2,)
        In response units.
    """
    poles = np.diag(t)
    peaks = np.array(
        [
            np.linalg.norm(np.outer(cc[:, i], bc[i]), 2) / max(abs(poles[i].real), 1e-300)
            for i in range(poles.size)
        ]
    )
    order = np.argsort(poles.imag)
    return poles[order], peaks[order]


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


def degenerate_bias(
    k0: np.ndarray,
    kp: np.ndarray,
    m: np.ndarray,
    structure_potential: float,
    pair: tuple[int, int] = (0, 1),
) -> np.ndarray:
    """Biases (volts) on electrodes ``pair``, the others at 0 V, that make ``K(w) = lam M``.

    The exact two-electrode solution (:func:`degenerate_w`) for stiffness ``k0`` and ``kp``
    (one per electrode), with the root ``dv = v_gyro - sign(v_gyro) sqrt(w)`` (the one nearer
    0 V, right when ``|v_gyro|`` exceeds the biases, as on the cloverleaf). Returns every
    electrode's bias.
    """
    kp = np.asarray(kp, dtype=float).reshape(-1, 2, 2)
    a, b = pair
    n_e = kp.shape[0]
    w = squared_potentials(structure_potential, np.zeros(n_e))
    base = np.asarray(k0, dtype=float) + sum(w[p] * kp[p] for p in range(n_e) if p not in pair)
    bias = np.zeros(n_e)
    bias[[a, b]] = degenerate_pair_bias(base, kp[a], kp[b], m, structure_potential)
    return bias


def degenerate_pair_bias(
    base: np.ndarray,
    k_a: np.ndarray,
    k_b: np.ndarray,
    m: np.ndarray,
    structure_potential: float,
    clamp: bool = False,
) -> np.ndarray:
    """The biases ``(dv_a, dv_b)`` (volts) that make ``base + w_a k_a + w_b k_b = lam m``.

    The closed form of :func:`degenerate_w`, with the root ``dv = v_gyro - sign(v_gyro)
    sqrt(w)`` nearer 0 V. ``clamp`` takes a negative ``w`` (no real bias reaches it) as 0 (the
    electrode at ``v_gyro``) instead of giving NaN.

    Raises
    ------
    numpy.linalg.LinAlgError
        When the pair has no closed form (``k_a``, ``k_b`` and ``m`` linearly dependent).
    """
    wa, wb, _ = degenerate_w(
        np.asarray(base, dtype=float),
        np.asarray(k_a, dtype=float),
        np.asarray(k_b, dtype=float),
        np.asarray(m, dtype=float),
    )
    w = np.array([wa, wb])
    if clamp:
        w = np.maximum(w, 0.0)
    sign = 1.0 if structure_potential >= 0.0 else -1.0
    with np.errstate(invalid="ignore"):
        return structure_potential - sign * np.sqrt(w)


def split_vector_hz(mass: np.ndarray, stiffness: np.ndarray) -> np.ndarray:
    """The split vector (Hz) of a gyro of ``mass`` and ``stiffness`` (2×2): length the split.

    The traceless part ``d`` of ``M^{-1/2} K M^{-1/2}`` (eigenvalues ``t ± |d|``), as
    ``d / (2π √t)``.
    """
    ns = normalised_stiffness(
        np.asarray(mass, dtype=float)[None], np.asarray(stiffness, dtype=float)[None]
    )
    t, d = trace_deviation(ns[0])
    return np.asarray(d, dtype=float) / (2 * np.pi * np.sqrt(max(float(t), 1e-300)))
