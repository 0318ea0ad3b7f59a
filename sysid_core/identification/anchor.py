"""The gyro now, from its latest verifications: a model's stiffness anchored in time.

A run's model is fitted to every sweep it has measured, over tens of minutes; on a bench that
drifts, it describes an average of the gyro over that time, while the tuning needs the gyro as
it will be at the next measurement. Dielectric charging moves the split by tens of mHz per hour
(measured on random gyros at 15 mV/h: 18-80 mHz/h), so a run that converges on the average keeps
missing by the lag (a 5 mHz split that four more iterations did not reduce).

:func:`anchor` keeps the model's bias law (``M``, ``C``, ``K_p``, the polynomial) and fits, to
the last verification sweeps alone, a stiffness offset ``A`` and (with two verifications or more
at different times) its rate ``D``, whose anisotropic part (the split's rate) only if the data
tell it from their noise (a Wald test at 95 %; else a common rate):

    K(v, t) = K(v) + A + (t − t_ref) D,

with a damping offset and a complex gain per sweep (the analyzer's wander) as nuisances. The
equation error of every point is linear in all of them, so this is one small least-squares
problem. :meth:`Anchor.model_at` gives the model at any time: the tuning solves it for the time of
the next verification. The rates (common and split, Hz/h) are
:func:`sysid_core.identification.drift.offset_drift` of that model (``meta["drift_trend"]``).
"""

from __future__ import annotations

import dataclasses
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
import xarray as xr

from sysid_core.conic.program import SYM_BASIS, sym
from sysid_core.data.schema import measured_mask, point_times
from sysid_core.errors import DataError
from sysid_core.model.fitted import FittedModel
from sysid_core.model.modal import mass_roots, normalised_stiffness, trace_deviation

__all__ = ["RATE_TEST_LIMIT", "Anchor", "anchor", "split_offset", "wald_statistic"]


@dataclass(frozen=True)
class Anchor:
    """A stiffness offset and rate that bring a model to the gyro of its latest verifications.

    Attributes
    ----------
    offset : ndarray (2, 2)
        Symmetric: the stiffness at ``t_ref`` minus the model's, same units as ``K0``.
    rate : ndarray (2, 2) or None
        Symmetric: the stiffness change per second, or None (one verification: no rate).
    t_ref : float
        The latest time stamp of the anchoring sweeps (seconds, the bench clock).
    sweeps : int
        How many sweeps anchored it.
    span_s : float
        The time they span.
    offset_covariance : ndarray (3, 3) or None
        The covariance of the offset's entries ``[A11, A12, A22]`` from the least squares'
        residuals (None without degrees of freedom).
    """

    offset: np.ndarray
    rate: np.ndarray | None
    t_ref: float
    sweeps: int
    span_s: float
    offset_covariance: np.ndarray | None = None

    def model_at(self, model: FittedModel, t_s: float) -> FittedModel:
        """``model`` with its stiffness at time ``t_s``; its ``meta`` says how it was made."""
        dk = self.offset + (0.0 if self.rate is None else (t_s - self.t_ref) * self.rate)
        meta = dict(model.meta)
        meta.update(
            drift_anchor_offset=self.offset.tolist(),
            drift_anchor_sweeps=self.sweeps,
            drift_anchor_time_s=float(t_s),
            drift_anchor_ahead_s=float(t_s - self.t_ref),
        )
        if self.rate is not None:
            meta.update(drift_trend=self.rate.tolist(), drift_trend_span_s=self.span_s)
        return dataclasses.replace(model, K0=np.asarray(model.K0) + dk, meta=meta)


def anchor(
    model: FittedModel,
    sweeps: Sequence[xr.Dataset],
    *,
    rate: bool = True,
    untimed: bool = False,
) -> Anchor:
    """Fit :class:`Anchor` to ``sweeps`` (time-stamped, each at one bias) with ``model``'s law.

    Parameters
    ----------
    model : FittedModel
        The run's model: its bias law is kept.
    sweeps : sequence of xarray.Dataset
        The verification sweeps, oldest first; every point with a time stamp.
    rate : bool
        Fit the rate too when the sweeps are at two times or more.
    untimed : bool
        Accept sweeps without time stamps (every point then counts as time 0): an offset
        only, no rate (a model brought to a gyro measured without a clock).

    Raises
    ------
    DataError
        With no sweep, or a sweep without a time stamp at every point (unless ``untimed``).
    """
    if not sweeps:
        raise DataError("no sweep to anchor the model on: verify a bias first")
    rows = []
    for j, sweep in enumerate(sweeps):
        # the electrodes the model has (the others' biases are in its K0)
        bias = _model_bias(model, sweep)
        masks = measured_mask(sweep)
        for k in range(sweep.sizes["experiment"]):
            t = point_times(sweep, k)
            if t is None and untimed:
                t = np.zeros(int(masks[k].sum()))
                rate = False
            if t is None:
                raise DataError(
                    f"anchoring sweep {j} has no time stamp at every point: the gyro now needs "
                    "the bench clock (time_s)"
                )
            omega = 2 * np.pi * sweep["frequency"].values[masks[k]]
            psi = sweep["response"].values[k][masks[k]]
            rows.append((omega, psi, bias[k], t))
    times = np.concatenate([r[3] for r in rows])
    t_ref = float(times.max())
    span = float(np.ptp(times))
    # a rate needs sweeps at different times, not one sweep's own span
    starts = np.array([r[3].min() for r in rows])
    with_rate = rate and len(rows) > 1 and float(np.ptp(starts)) > 0.0
    n_k = 3 * (2 if with_rate else 1) + 3  # offset, rate, damping offset
    n_par = n_k + 2 * len(rows)
    blocks, targets = [], []
    for j, (omega, psi, bias, t) in enumerate(rows):
        p = model.polynomial(omega, bias)
        z = model.z(omega, bias)
        e0 = p - model.structure.product(psi, z)
        cols = np.zeros((omega.size, 2, 2, n_par), dtype=complex)
        for b, basis in enumerate(SYM_BASIS):
            term = model.structure.product(psi, np.broadcast_to(basis, z.shape))
            cols[..., b] = term
            if with_rate:
                cols[..., 3 + b] = (t - t_ref)[:, None, None] * term
            cols[..., n_k - 3 + b] = 1j * omega[:, None, None] * term
        cols[..., n_k + 2 * j] = -p
        cols[..., n_k + 2 * j + 1] = -1j * p
        # e0 = cols @ x: the offsets that leave no equation error, by least squares; a
        # response's noise δψ enters the equation error as δψ Z, so each point is weighted by
        # 1/‖Z‖ (the points at the resonances, where Z is nearly singular, count the most)
        weight = 1.0 / np.maximum(np.linalg.norm(z, axis=(1, 2)), 1e-300)
        a = (cols * weight[:, None, None, None]).reshape(-1, n_par)
        y = (e0 * weight[:, None, None]).reshape(-1)
        blocks.append(np.concatenate([a.real, a.imag]))
        targets.append(np.concatenate([y.real, y.imag]))
    a_all, y_all = np.concatenate(blocks), np.concatenate(targets)
    x = _solve(a_all, y_all, np.asarray(model.M, dtype=float), with_rate)

    return Anchor(
        offset=sym(x[:3]),
        rate=sym(x[3:6]) if with_rate else None,
        t_ref=t_ref,
        sweeps=len(rows),
        span_s=span,
        offset_covariance=None if with_rate else _offset_covariance(a_all, y_all, x),
    )


def _offset_covariance(a: np.ndarray, y: np.ndarray, x: np.ndarray) -> np.ndarray | None:
    """The first three rows and columns of ``s² (aᵀa)⁻¹`` for ``a x ≈ y``; None if ``n <= p``."""
    n, p = a.shape
    if n <= p:
        return None
    resid = y - a @ x
    scale = _column_scale(a)
    inner = np.linalg.pinv((a / scale).T @ (a / scale))
    cov = float(resid @ resid) / (n - p) * inner / np.outer(scale, scale)
    return cov[:3, :3]


#: The split's rate (the anisotropic part of ``D``) is kept when its Wald statistic exceeds the
#: 95 % point of χ² with 2 degrees of freedom; otherwise ``D`` is a common rate only.
RATE_TEST_LIMIT = 5.99


def _solve(a: np.ndarray, y: np.ndarray, m: np.ndarray, with_rate: bool) -> np.ndarray:
    """The anchor's unknowns; the rate's part other than a common one only if significant."""
    x = _least_squares(a, y)
    if not with_rate:
        return x
    # the rate as c M + the rest: a common drift scales the stiffness, ≈ ω² M near the modes
    mass = np.array([m[0, 0], m[0, 1], m[1, 1]])
    basis = np.linalg.svd(mass[None, :])[2]  # rows: along M, then its complement
    basis[0] = mass
    split_rate = np.zeros((2, a.shape[1]))
    split_rate[:, 3:6] = np.linalg.inv(basis.T)[1:]
    if wald_statistic(a, y, x, split_rate) >= RATE_TEST_LIMIT:
        return x
    # the split's rate is not told from the windows' noise: a common rate only (measured:
    # windows seconds apart on a 28 kHz gyro gave split rates of 0.3-4 Hz/h, where charging
    # moves it by 0.1 Hz/h, and moved the answer 2 s ahead by 2 mHz)
    common = a.copy()
    common[:, 3] = a[:, 3:6] @ mass
    keep = np.r_[0:4, 6 : a.shape[1]]
    x = np.zeros(a.shape[1])
    x[keep] = _least_squares(common[:, keep], y)
    x[3:6] = x[3] * mass
    return x


def _column_scale(a: np.ndarray) -> np.ndarray:
    scale = np.linalg.norm(a, axis=0)
    scale[scale == 0] = 1.0
    return scale


def _least_squares(a: np.ndarray, y: np.ndarray) -> np.ndarray:
    scale = _column_scale(a)
    return np.linalg.lstsq(a / scale, y, rcond=None)[0] / scale


def wald_statistic(a: np.ndarray, y: np.ndarray, x: np.ndarray, t: np.ndarray) -> float:
    """Wald statistic of ``t x`` for the least-squares solution ``x`` of ``a x ≈ y``.

    ``(t x)ᵀ Cov⁻¹ (t x)`` with ``Cov = s² t (aᵀa)⁻¹ tᵀ`` and the residual variance ``s²``;
    infinite when the residuals vanish, 0 without degrees of freedom.
    """
    n, p = a.shape
    if n <= p:
        return 0.0
    resid = y - a @ x
    s2 = float(resid @ resid) / (n - p)
    if s2 == 0.0:
        return float("inf")
    scale = _column_scale(a)
    ts = t / scale  # t x = (t / scale) (scale x)
    cov = s2 * ts @ np.linalg.pinv((a / scale).T @ (a / scale)) @ ts.T
    value = t @ x
    return float(value @ np.linalg.pinv(cov) @ value)


def _model_bias(model: FittedModel, sweep: xr.Dataset) -> np.ndarray:
    """The applied bias of each of ``sweep``'s experiments on ``model``'s electrodes (volts).

    ``(experiment, electrode)``, in the model's electrode order; the sweep's other electrodes
    are left out (their biases are in the model's ``K0``).

    Raises
    ------
    DataError
        If the sweep lacks one of the model's electrodes.
    """
    names = [str(e) for e in sweep["electrode"].values]
    try:
        index = [names.index(e) for e in model.electrodes]
    except ValueError:
        raise DataError(
            f"a sweep over electrodes {names} lacks one of the model's {list(model.electrodes)}"
        ) from None
    return np.asarray(sweep["bias"].values, dtype=float)[:, index]


def _deviation(m: np.ndarray, k: np.ndarray) -> tuple[float, np.ndarray]:
    """``t`` and ``d`` of the normalised stiffness ``M^{-1/2} K M^{-1/2}`` ((rad/s)²)."""
    ns = normalised_stiffness(np.asarray(m, dtype=float)[None], np.asarray(k, dtype=float)[None])
    t, d = trace_deviation(ns[0])
    return float(t), d


def split_offset(model: FittedModel, sweep: xr.Dataset, window: FittedModel) -> np.ndarray:
    """The stiffness offset that gives ``model`` the split a window's own fit measured.

    ``window`` is the single-bias model of ``sweep`` (one experiment). The offset
    ``A = M^{1/2} D M^{1/2}``, ``D`` traceless, turns the deviation ``d`` of ``model``'s
    normalised stiffness at the sweep's bias (its eigenvalues are ``t ± |d|``) into the
    window's: its orientation, and the length that gives the window's split in Hz at
    ``model``'s own ``t``; the mean frequency stays. :func:`anchor` holds the model's mass,
    damping and polynomial fixed, and what those miss near degenerate modes it can take for a
    split: measured on a 14.5 kHz gyro with bandwidths of 0.27 Hz, five windows' own fits
    agreed on ``d`` to 0.5 mHz (splits 3.8-5.0 mHz, as true) while the anchored model put
    0.3 mHz there.
    """
    bias = _model_bias(model, sweep)[0]
    m = np.asarray(model.M, dtype=float)
    t_w, d_w = _deviation(window.M, window.stiffness([]))
    t_m, d_m = _deviation(m, model.stiffness(bias))
    # the split the window measured, (√(t+r) − √(t−r)) / 2π, at the model's t
    a2 = (np.sqrt(t_w + np.hypot(*d_w)) - np.sqrt(max(t_w - np.hypot(*d_w), 0.0))) ** 2
    r = np.sqrt(max(t_m**2 - (t_m - 0.5 * a2) ** 2, 0.0))
    norm = float(np.hypot(*d_w))
    target = d_w * (r / norm) if norm > 0 else np.zeros(2)
    delta = target - d_m
    d = np.array([[delta[0], delta[1]], [delta[1], -delta[0]]])
    root, _ = mass_roots(m)
    return root @ d @ root
