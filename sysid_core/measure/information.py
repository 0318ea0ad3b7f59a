"""What a sweep's points tell about the split, per second of bench clock.

Near one of the two modes a channel of the response is ``G(f) = r / (1 + j x) + d + e (f - f0)``
with ``x = 2 (f - f0) / b``: the modal frequency ``f0``, the bandwidth ``b``, a complex residue
``r`` and a feedthrough ``d + e (f - f0)`` (complex) that varies slowly with frequency. With
white noise of the same variance on every point, the Fisher information of a set of points about
the eight real parameters is ``JᵀJ`` (``J`` the Jacobian of the real and imaginary parts, rows
per point), and the variance of ``f0`` with the others unknown is ``(JᵀJ)⁻¹`` at ``f0``. What a
run needs from a window is the split, ``f2 - f1``, so :func:`split_information` is
``1 / (var f1 + var f2)``, each mode seen in a channel of its own (the 2×2 response of a gyro
separates two modes that a single channel would confuse). A guess whose modes are uncertain
(``σ``) is averaged over where they may be: both modes moved together by ``-2σ ... 2σ``, weighted
as a normal distribution.

The residues are set to 1 (unit peaks) and the noise to 1: the number ranks grids for one guess
against each other; it is not a variance of the bench. Per second of bench clock
(:func:`per_second`) is that information over what the sweep costs: settling after the bias
change, then its acquisitions with the device's ``tones``. A sweep of more points of the same
kind gains about as much information per point (within ``±1`` bandwidth of a mode a point
carries 96 % of what it can, ``docs/bench-time.md``), so what a shape of grid wins or loses shows
only per second: :func:`~sysid_core.measure.modegrid.mode_grid` measures the shape that carries the
most (``docs/studies/information.md`` has the numbers).
"""

from __future__ import annotations

from collections.abc import Callable, Sequence

import numpy as np

from sysid_core.clock.benchtime import acquisitions

__all__ = [
    "measuring_order",
    "mode_information",
    "per_second",
    "split_information",
    "split_weights",
    "sweep_cost",
]

#: Where the modes may be, in standard deviations of the guess, and the weights (a normal
#: distribution at five points).
_SHIFTS = np.array([-2.0, -1.0, 0.0, 1.0, 2.0])
_WEIGHTS = np.exp(-0.5 * _SHIFTS**2) / np.exp(-0.5 * _SHIFTS**2).sum()


def _jacobian(points: np.ndarray, f0: float, bw: float) -> np.ndarray:
    """Rows ``Re, Im`` per point of ``∂G/∂(f0, b, Re r, Im r, Re d, Im d, Re e, Im e)``.

    At ``r = 1``, ``d = e = 0``; frequencies in bandwidths (the variance of ``f0`` is then in
    bandwidths²), the slope over the points' span. The slope is left out when the points span
    under 2 bandwidths (it cannot be told from ``d`` and the residue there).
    """
    u = (points - f0) / bw
    x = 2.0 * u
    pole = 1.0 / (1.0 + 1j * x)
    one = np.ones_like(pole)
    cols = [2j * pole**2, 1j * x * pole**2, pole, 1j * pole, one, 1j * one]
    span = float(np.ptp(u))
    if span > 2.0:  # the slope over the points' span (a well-scaled column)
        cols += [u / span + 0j, 1j * u / span]
    jc = np.stack(cols, axis=1)
    return np.vstack([jc.real, jc.imag])


def _fisher(points: np.ndarray, f0: float, bw: float) -> tuple[np.ndarray, np.ndarray] | None:
    """The Jacobian of :func:`_jacobian` and its Fisher information ``JᵀJ``, or None.

    None when the points cannot tell the parameters apart (fewer equations than unknowns).
    """
    jac = _jacobian(np.asarray(points, dtype=float), float(f0), float(bw))
    if jac.shape[0] < jac.shape[1]:
        return None
    return jac, jac.T @ jac


def mode_information(points: np.ndarray, f0: float, bw: float) -> float:
    """``1 / var(f0)`` (Hz⁻², unit noise and residue) of one mode from ``points`` (Hz).

    Zero when the points cannot tell ``f0`` from the other parameters (too few of them).
    """
    found = _fisher(points, f0, bw)
    if found is None:
        return 0.0
    fisher = found[1]
    try:
        var = float(np.linalg.solve(fisher, np.eye(len(fisher))[0])[0])
    except np.linalg.LinAlgError:
        return 0.0
    if not np.isfinite(var) or var <= 0 or np.linalg.cond(fisher) > 1e12:
        return 0.0
    return 1.0 / (var * bw * bw)


def _mode_weights(points: np.ndarray, f0: float, bw: float) -> np.ndarray | None:
    """Each point's share of the estimate of ``f0``: ``a_i = e₀ᵀ F⁻¹ J_iᵀ J_i e₀`` (sum 1).

    ``F = JᵀJ`` the Fisher information, ``J_i`` the rows of point ``i``: a move ``δ_i`` of the
    mode at point ``i`` alone moves the least-squares estimate of ``f0`` by ``a_i δ_i``. None
    where the points cannot tell ``f0`` (:func:`mode_information` is 0).
    """
    found = _fisher(points, f0, bw)
    if found is None or np.linalg.cond(found[1]) > 1e12:
        return None
    jac, fisher = found
    row = np.linalg.solve(fisher, np.eye(len(fisher))[0])
    share = (jac @ row) * jac[:, 0]
    n = points.size
    return share[:n] + share[n:]


def split_weights(
    points: np.ndarray,
    frequencies_hz: np.ndarray | Sequence[float],
    bandwidth_hz: np.ndarray | Sequence[float],
) -> np.ndarray | None:
    """Each point's share of a window's estimate of the split ``f2 - f1`` (they sum to 1).

    A split that moves during the window (a drift) by ``δ_i`` at point ``i`` moves the estimate
    by ``Σ a_i δ_i``: for a split moving at a steady rate, the estimate is the split at the
    time ``Σ a_i t_i`` of the points' time stamps ``t_i`` (the window's *time*). Each mode's
    shares (:func:`_mode_weights`), averaged over the two (the split moves each by half).
    None where the points cannot tell a mode.
    """
    p = np.asarray(points, dtype=float)
    shares = [
        _mode_weights(p, float(fm), float(bm))
        for fm, bm in zip(np.asarray(frequencies_hz), np.asarray(bandwidth_hz), strict=True)
    ]
    if any(s is None for s in shares):
        return None
    return 0.5 * (shares[0] + shares[1])  # type: ignore[operator]


def measuring_order(
    points: np.ndarray,
    frequencies_hz: np.ndarray | Sequence[float],
    bandwidth_hz: np.ndarray | Sequence[float],
) -> np.ndarray:
    """``points`` in the order to measure them: the smallest share of the split first.

    A window's split is the split at its time (:func:`split_weights`), and a run that stops
    after it ends at its last point: measured least informative first, the window's time lies
    near its end, where the drift from it to the end is least. ``points`` sorted where the
    shares are not known.
    """
    p = np.sort(np.asarray(points, dtype=float))
    weights = split_weights(p, frequencies_hz, bandwidth_hz)
    if weights is None:
        return p
    return p[np.argsort(weights, kind="stable")]


def split_information(
    points: np.ndarray,
    frequencies_hz: np.ndarray | Sequence[float],
    bandwidth_hz: np.ndarray | Sequence[float],
    uncertainty_hz: np.ndarray | Sequence[float] = (0.0, 0.0),
) -> float:
    """``1 / var(f2 - f1)`` (Hz⁻²) from ``points``, expected over where the modes may be.

    Each mode in a channel of its own (see the module), both moved together by ``k σ``,
    ``k = -2 ... 2``, weighted as a normal distribution (``σ`` the larger of the two
    uncertainties; none: the modes where guessed).
    """
    f = np.asarray(frequencies_hz, dtype=float)
    bw = np.asarray(bandwidth_hz, dtype=float)
    sigma = float(np.max(np.abs(np.asarray(uncertainty_hz, dtype=float))))
    shifts, weights = (_SHIFTS * sigma, _WEIGHTS) if sigma > 0 else (np.zeros(1), np.ones(1))
    total = 0.0
    for shift, weight in zip(shifts, weights, strict=True):
        infos = [mode_information(points, fm + shift, bm) for fm, bm in zip(f, bw, strict=True)]
        if min(infos) <= 0:
            continue
        total += weight / sum(1.0 / i for i in infos)
    return total


def sweep_cost(n_points: int, tones: int, cost_s: Callable[[int], float] | None = None) -> float:
    """What a sweep of ``n_points`` costs: ``cost_s(n_points)``, else its acquisitions.

    ``cost_s``: the bench clock's price (settling after the bias change and its acquisitions,
    :meth:`~sysid_core.clock.runclock.RunClock.sweep_s`); without it, the acquisitions with
    ``tones`` (a cost to compare, not a time).
    """
    return float(acquisitions(n_points, tones)) if cost_s is None else float(cost_s(n_points))


def per_second(
    information: float, n_points: int, tones: int, cost_s: Callable[[int], float] | None = None
) -> float:
    """``information`` per second of bench clock of a sweep of ``n_points`` (:func:`sweep_cost`)."""
    cost = sweep_cost(n_points, tones, cost_s)
    return information / cost if cost > 0 else 0.0
