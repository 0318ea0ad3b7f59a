"""The split of a drifting gyro in time: one Kalman filter on a local linear trend.

Near degenerate modes the split is a vector ``s`` (Hz, two components: the traceless part of
the normalised stiffness ``M^{-1/2} K M^{-1/2}`` over ``4π² f``; its length is the split, its
direction the modes' orientation). On a drifting bench it moves in time. The model
(:class:`TrendModel`), for each of the two components alike::

    s(t + dt) = s(t) + dt · r(t) + w_s,      w_s ~ N(0, q_s dt)
    r(t + dt) = r(t) + w_r,                  w_r ~ N(0, q_r dt)
    r(t_0) ~ N(0, σ_r²),  s(t_0) diffuse

``r`` is the split's rate (charging that follows the applied bias, a temperature that ramps
along the gyro's own axes); ``q_r = σ_r² / τ_r`` lets the rate change by its own size in
``τ_r`` (the applied bias changes at every answer, and the charging with it); ``q_s`` is the
wander that no rate explains. Each verification window measures ``s`` at its time (where its
points tell the split, :func:`sysid_core.drift.windows.window_time`) with its own fit's
variance (its split interval, times ``λ`` where the windows scatter more than their fits say:
:mod:`sysid_core.identification.trendnoise`); the model a run anchors on its latest window
measures ``s`` there as zero with the variance of what a model's law misses near degenerate
modes (``σ_m²``). :func:`forecast` filters the measurements in time order and predicts ``s``
and its variance at any later time: where the answer will be verified.

The rules this replaces are its limits: the latest window's split alone (``q_s → ∞``), a line
in time through every window (``q_s = q_r = 0``, ``σ_r → ∞``), windows pooled with a prior on
the slope (``q_r = 0``, finite ``σ_r``), the anchored model alone (``σ_m → 0``).
"""

from __future__ import annotations

import dataclasses
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

__all__ = [
    "LAB_TREND",
    "SplitForecast",
    "TrendModel",
    "forecast",
    "forecast_weights",
    "log_likelihood",
    "variance_after",
]

#: The variance of a level nothing has measured yet, over the largest the data hold.
_DIFFUSE = 1e6


@dataclass(frozen=True)
class TrendModel:
    """How the split moves in time and what an anchored model misses of it.

    Attributes
    ----------
    rate_hz_per_s : float
        ``σ_r``, the prior standard deviation of each component of the split's rate.
    rate_change_s : float
        ``τ_r``, the time in which the rate changes by ``σ_r`` (``q_r = σ_r² / τ_r``).
    wander_hz2_per_s : float
        ``q_s``, the split's wander per second beyond its rate.
    model_error_hz : float
        ``σ_m``, what a model anchored on a window misses of that window's split (per
        component); ``inf``: the anchored model measures nothing.
    window_variance_scale : float, default 1
        ``λ``, how many times the windows' fits understate their variance: every window's
        variance is taken ``λ`` times larger.
    """

    rate_hz_per_s: float
    rate_change_s: float
    wander_hz2_per_s: float
    model_error_hz: float
    window_variance_scale: float = 1.0

    def __post_init__(self) -> None:
        """Refuse a negative or NaN parameter, or a variance scale under one."""
        for name in ("rate_hz_per_s", "rate_change_s", "wander_hz2_per_s", "model_error_hz"):
            value = getattr(self, name)
            if not value >= 0:  # NaN too
                raise ValueError(f"TrendModel.{name} must be >= 0, got {value!r}")
        if not 1.0 <= self.window_variance_scale < np.inf:
            raise ValueError(
                "TrendModel.window_variance_scale must be finite and >= 1, got "
                f"{self.window_variance_scale!r}"
            )

    def transition(self, dt: float) -> tuple[np.ndarray, np.ndarray]:
        """The state transition ``F`` and process covariance ``Q`` over ``dt`` seconds."""
        q_r = self.rate_hz_per_s**2 / self.rate_change_s if self.rate_change_s > 0 else np.inf
        f = np.array([[1.0, dt], [0.0, 1.0]])
        q = q_r * np.array([[dt**3 / 3, dt**2 / 2], [dt**2 / 2, dt]]) if dt else np.zeros((2, 2))
        q[0, 0] += self.wander_hz2_per_s * dt
        return f, q


#: The trend a run assumes (docs/drift-model.md, where each number is derived and measured):
#: a rate of 1.8 mHz/min (one standard deviation per component: the split's rate on a lab's
#: fast gyros, where charging of tens of mV/h acts through sensitivities of tens of mHz/V,
#: is 0.3-3 mHz/min), constant over a run (letting it change in 4 h predicted worse), no wander
#: beyond it, and an anchored model that misses the split by 2 mHz (what a model's mass,
#: damping and polynomial miss near degenerate modes: 1-3 mHz). Where a run's windows scatter
#: more than their fits state, :mod:`sysid_core.identification.trendnoise` scales their variances.
LAB_TREND = TrendModel(
    rate_hz_per_s=3e-5, rate_change_s=float("inf"), wander_hz2_per_s=0.0, model_error_hz=2e-3
)


@dataclass(frozen=True)
class SplitForecast:
    """The split vector predicted at a time, and its uncertainty.

    Attributes
    ----------
    vector_hz : ndarray (2,)
        The predicted split vector (Hz); its length is the split.
    variance_hz2 : float
        The variance of each of its components (they are alike).
    rate_hz_per_s : ndarray (2,)
        The filtered rate of the split vector at the last measurement.
    rate_variance : float
        Its variance per component ((Hz/s)²).
    windows : int
        How many windows were filtered.
    covariance : ndarray (3, 3)
        The filter's covariance after the latest window (level, rate, what the anchored model
        misses), per component: what :func:`variance_after` carries on.
    own_variance_hz2, anchored_variance_hz2 : float
        The median variance of the windows' own splits and of their anchored ones (``inf``:
        none measured), scaled by the trend's ``λ``: what a window like them would add.
    trend : TrendModel
        The model the windows were filtered with.
    """

    vector_hz: np.ndarray
    variance_hz2: float
    rate_hz_per_s: np.ndarray
    rate_variance: float
    windows: int
    covariance: np.ndarray = dataclasses.field(default_factory=lambda: np.zeros((3, 3)))
    own_variance_hz2: float = float("inf")
    anchored_variance_hz2: float = float("inf")
    trend: TrendModel = LAB_TREND

    @property
    def split_hz(self) -> float:
        """The predicted split (Hz): the vector's length."""
        return float(np.hypot(*self.vector_hz))

    @property
    def sigma_hz(self) -> float:
        """The standard deviation of each component of the prediction (Hz)."""
        return float(np.sqrt(self.variance_hz2))


def forecast(
    times_s: Sequence[float],
    vectors_hz: np.ndarray,
    variances_hz2: Sequence[float],
    at_s: float,
    model: TrendModel,
    anchored_hz: np.ndarray | None = None,
    anchored_variances: Sequence[float] | None = None,
) -> SplitForecast:
    """The split vector at ``at_s``, filtered from the windows' split vectors.

    Parameters
    ----------
    times_s : sequence of float
        The time of each window (seconds, the bench clock; where its points tell the split),
        in any order.
    vectors_hz : ndarray (n, 2)
        Each window's own split vector, against one reference model (Hz).
    variances_hz2 : sequence of float
        Each window's variance per component (Hz²).
    at_s : float
        When the split is wanted: not before the latest window.
    model : TrendModel
        The split's motion in time.
    anchored_hz : ndarray (n, 2), optional
        Each window's split vector as the reference model anchored on that window alone
        measures it: the truth plus what the model misses (a state of its own, prior
        ``model.model_error_hz²``).
    anchored_variances : sequence of float, optional
        Their variances per component (Hz²); the windows' own by default. An infinite one
        measures nothing.

    Returns
    -------
    SplitForecast

    Raises
    ------
    ValueError
        With no window, shapes that do not agree, or a time or variance that is not finite.
    """
    rows = _rows(times_s, vectors_hz, variances_hz2, model, anchored_hz, anchored_variances)
    scale = model.window_variance_scale
    x, p, now, _ = _filter(rows, model)
    rate, rate_var, after = x[1].copy(), float(p[1, 1]), p.copy()
    x, p = _predict(x, p, model, max(float(at_s) - now, 0.0))
    own = [v for _, h, _, v in rows if h is _OWN]
    anchored = [v for _, h, _, v in rows if h is _BOTH]
    return SplitForecast(
        vector_hz=x[0],
        variance_hz2=float(p[0, 0]),
        rate_hz_per_s=rate,
        rate_variance=rate_var,
        windows=len(own),
        covariance=after,
        own_variance_hz2=scale * float(np.median(own)),
        anchored_variance_hz2=scale * float(np.median(anchored)) if anchored else float("inf"),
        trend=model,
    )


def forecast_weights(
    times_s: Sequence[float], variances_hz2: Sequence[float], at_s: float, model: TrendModel
) -> tuple[np.ndarray, float]:
    """:func:`forecast` from the windows' own splits alone, as weights on what they read.

    The filter is linear in the windows' vectors (its priors' means are zero), so the forecast
    at ``at_s`` is ``weights @ vectors_hz`` for any vectors the windows could read (to a
    millionth: the diffuse prior's variance scales with what they read); returns the
    weights (one per window, in the order given) and the forecast's standard deviation per
    component, which do not depend on the vectors. What a study of many draws on one clock
    filters once instead of once per draw.
    """
    n = len(times_s)
    # a reading of the windows' own size: the filter's "nothing known" scales with it
    size = float(np.sqrt(np.max(variances_hz2))) or 1.0
    weights, unit = np.zeros(n), np.zeros((n, 2))
    sigma = 0.0
    for i in range(n):
        unit[:] = 0.0
        unit[i, 0] = size
        found = forecast(times_s, unit, variances_hz2, at_s, model)
        weights[i], sigma = found.vector_hz[0] / size, found.sigma_hz
    return weights, sigma


def log_likelihood(
    times_s: Sequence[float],
    vectors_hz: np.ndarray,
    variances_hz2: Sequence[float],
    model: TrendModel,
    window_variance_scale: np.ndarray,
    anchored_hz: np.ndarray | None = None,
    anchored_variances: Sequence[float] | None = None,
) -> np.ndarray:
    """The log-likelihood of the windows under ``model`` with each variance scale ``λ``.

    The likelihood of the filter's innovations (the errors with which it predicts each window
    before reading it), for every ``window_variance_scale`` (an array) in place of ``model``'s;
    the other arguments are :func:`forecast`'s. Differences between scales are what a
    maximum-likelihood choice of the scale reads.
    """
    rows = _rows(times_s, vectors_hz, variances_hz2, model, anchored_hz, anchored_variances)
    return _filter(rows, model, np.asarray(window_variance_scale, dtype=float))[3]


#: One measurement of the filter: its time, what it measures of the state (:data:`_OWN` or
#: :data:`_BOTH`), the split vector it reads and its variance as the window's fit states it.
Row = tuple[float, np.ndarray, np.ndarray, float]


def _rows(
    times_s: Sequence[float],
    vectors_hz: np.ndarray,
    variances_hz2: Sequence[float],
    model: TrendModel,
    anchored_hz: np.ndarray | None,
    anchored_variances: Sequence[float] | None,
) -> list[Row]:
    """The windows' measurements in time order (see :func:`forecast` for the arguments)."""
    t = np.asarray(times_s, dtype=float)
    y = np.asarray(vectors_hz, dtype=float).reshape(-1, 2)
    r = np.asarray(variances_hz2, dtype=float)
    if not t.size or t.shape != r.shape or y.shape[0] != t.size:
        raise ValueError(
            f"forecast needs one time, vector and variance per window, got {t.size}, "
            f"{y.shape[0]} and {r.size}"
        )
    if not (np.all(np.isfinite(t)) and np.all(np.isfinite(y)) and np.all(r >= 0)):
        raise ValueError("forecast: window times, vectors and variances must be finite")
    rows: list[Row] = []
    for i in np.argsort(t, kind="stable"):
        rows.append((float(t[i]), _OWN, y[i], float(r[i])))
        if anchored_hz is not None and np.isfinite(model.model_error_hz):
            a = np.asarray(anchored_hz, dtype=float).reshape(-1, 2)[i]
            va = float(r[i] if anchored_variances is None else anchored_variances[i])
            if np.isfinite(va):
                rows.append((float(t[i]), _BOTH, a, va))
    return rows


def _filter(
    rows: list[Row], model: TrendModel, scale: np.ndarray | None = None
) -> tuple[np.ndarray, np.ndarray, float, np.ndarray]:
    """The state and covariance after the last row, its time, and the rows' log-likelihood.

    With ``scale`` (an array), one filter for each of its values in place of ``model``'s
    ``λ``, run together: the state gains its shape in front. The log-likelihood is that of the
    innovations (each row's two components alike and independent), the first row's included:
    it is the same for every scale.
    """
    scale = np.asarray(model.window_variance_scale if scale is None else scale, dtype=float)
    shape = scale.shape
    # state rows: the level, its rate, what the anchored model misses; columns: the components
    x = np.zeros((*shape, 3, 2))
    # "nothing known" as a variance a million times any the data hold: far wider than them,
    # not so wide that the first update loses their digits
    own = [(y, v) for _, h, y, v in rows if h is _OWN]
    big = max(max(v for _, v in own), max(float(np.max(y**2)) for y, _ in own), 1e-30)
    if np.isfinite(model.model_error_hz):
        big = max(big, model.model_error_hz**2)
    diffuse = _DIFFUSE * big * float(np.max(scale))
    m2 = model.model_error_hz**2 if np.isfinite(model.model_error_hz) else diffuse
    p = np.broadcast_to(np.diag([diffuse, model.rate_hz_per_s**2, m2]), (*shape, 3, 3)).copy()
    loglik = np.zeros(shape)
    now = rows[0][0]
    for when, h, vector, variance in rows:
        x, p = _predict(x, p, model, when - now)
        now = when
        x, p, innovation, s = _update(x, p, h, vector, scale * variance)
        loglik -= np.log(2 * np.pi * s) + 0.5 * np.sum(innovation**2, axis=-1) / s
    return x, p, now, loglik


def variance_after(
    found: SplitForecast, model: TrendModel, windows: int, every_s: float, ahead_s: float
) -> float:
    """The variance per component of the split after ``windows`` more windows like the last.

    The filter's covariance does not depend on what the windows measure, only on when and how
    well: this carries ``found``'s on through ``windows`` windows, one every ``every_s``
    seconds, each measuring the split with the windows' median variances (own and anchored),
    and ``ahead_s`` seconds past the last (the end of a window, from its time). What a run
    can still show at best: the variance its verdict would hold if every answer from now on
    were perfect.
    """
    x, p = np.zeros((3, 2)), np.asarray(found.covariance, dtype=float)
    anchored = np.isfinite(found.anchored_variance_hz2) and np.isfinite(model.model_error_hz)
    for _ in range(max(int(windows), 0)):
        x, p = _predict(x, p, model, every_s)
        x, p, _, _ = _update(x, p, _OWN, np.zeros(2), found.own_variance_hz2)
        if anchored:
            x, p, _, _ = _update(x, p, _BOTH, np.zeros(2), found.anchored_variance_hz2)
    return float(_predict(x, p, model, max(ahead_s, 0.0))[1][0, 0])


#: What a window's own split measures (the level) and its anchored one (the level and what the
#: anchored model misses).
_OWN, _BOTH = np.array([1.0, 0.0, 0.0]), np.array([1.0, 0.0, 1.0])


def _update(
    x: np.ndarray, p: np.ndarray, h: np.ndarray, vector: np.ndarray, variance: float | np.ndarray
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """The state after one measurement ``h · x = vector`` of ``variance``.

    Returns the state, its covariance, the innovation and its variance; leading axes of ``x``,
    ``p`` and ``variance`` run together.
    """
    ph = p @ h
    s = ph @ h + np.maximum(variance, 1e-30)
    gain = ph / s[..., None]
    innovation = vector - h @ x
    x = x + gain[..., :, None] * innovation[..., None, :]
    p = p - gain[..., :, None] * ph[..., None, :]
    return x, 0.5 * (p + np.swapaxes(p, -1, -2)), innovation, s


def _predict(
    x: np.ndarray, p: np.ndarray, model: TrendModel, dt: float
) -> tuple[np.ndarray, np.ndarray]:
    """The state and its covariance ``dt`` seconds later (what the model misses stays)."""
    f2, q2 = model.transition(dt)
    f, q = np.eye(3), np.zeros((3, 3))
    f[:2, :2], q[:2, :2] = f2, q2
    return f @ x, f @ p @ f.T + q
