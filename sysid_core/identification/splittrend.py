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
wander that no rate explains. Each verification window measures ``s`` at the middle of its
time stamps with its own fit's variance (its split interval); the model a run anchors on its
latest window measures ``s`` there as zero with the variance of what a model's law misses
near degenerate modes (``σ_m²``). :func:`forecast` filters the measurements in time order and
predicts ``s`` and its variance at any later time: where the answer will be verified.

The rules this replaces are its limits: the latest window's split alone (``q_s → ∞``), a line
in time through every window (``q_s = q_r = 0``, ``σ_r → ∞``), windows pooled with a prior on
the slope (``q_r = 0``, finite ``σ_r``), the anchored model alone (``σ_m → 0``).
"""

from __future__ import annotations

import dataclasses
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

__all__ = ["LAB_TREND", "SplitForecast", "TrendModel", "forecast", "variance_after"]

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
    """

    rate_hz_per_s: float
    rate_change_s: float
    wander_hz2_per_s: float
    model_error_hz: float

    def __post_init__(self) -> None:
        """Refuse a negative or NaN parameter."""
        for name in ("rate_hz_per_s", "rate_change_s", "wander_hz2_per_s", "model_error_hz"):
            value = getattr(self, name)
            if not value >= 0:  # NaN too
                raise ValueError(f"TrendModel.{name} must be >= 0, got {value!r}")

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
#: damping and polynomial miss near degenerate modes: 1-3 mHz).
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
        none measured): what a window like them would add.
    """

    vector_hz: np.ndarray
    variance_hz2: float
    rate_hz_per_s: np.ndarray
    rate_variance: float
    windows: int
    covariance: np.ndarray = dataclasses.field(default_factory=lambda: np.zeros((3, 3)))
    own_variance_hz2: float = float("inf")
    anchored_variance_hz2: float = float("inf")

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
        The middle of each window (seconds, the bench clock), in any order.
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
    own, both = _OWN, _BOTH
    rows = []
    for i in np.argsort(t, kind="stable"):
        rows.append((float(t[i]), own, y[i], float(r[i])))
        if anchored_hz is not None and np.isfinite(model.model_error_hz):
            a = np.asarray(anchored_hz, dtype=float).reshape(-1, 2)[i]
            va = float(r[i] if anchored_variances is None else anchored_variances[i])
            if np.isfinite(va):
                rows.append((float(t[i]), both, a, va))
    # state rows: the level, its rate, what the anchored model misses; columns: the components
    x = np.zeros((3, 2))
    # "nothing known" as a variance a million times any the data hold: far wider than them,
    # not so wide that the first update loses their digits
    scale = max(float(np.max(r)), float(np.max(y**2)), 1e-30)
    if np.isfinite(model.model_error_hz):
        scale = max(scale, model.model_error_hz**2)
    diffuse = _DIFFUSE * scale
    m2 = model.model_error_hz**2 if np.isfinite(model.model_error_hz) else diffuse
    p = np.diag([diffuse, model.rate_hz_per_s**2, m2])
    now = rows[0][0]
    for when, h, vector, variance in rows:
        x, p, now = *_predict(x, p, model, when - now), when
        x, p = _update(x, p, h, vector, variance)
    rate, rate_var, after = x[1].copy(), float(p[1, 1]), p.copy()
    x, p = _predict(x, p, model, max(float(at_s) - now, 0.0))
    anchored = [v for when, h, _, v in rows if h is both]
    return SplitForecast(
        vector_hz=x[0],
        variance_hz2=float(p[0, 0]),
        rate_hz_per_s=rate,
        rate_variance=rate_var,
        windows=int(t.size),
        covariance=after,
        own_variance_hz2=float(np.median(r)),
        anchored_variance_hz2=float(np.median(anchored)) if anchored else float("inf"),
    )


def variance_after(
    found: SplitForecast, model: TrendModel, windows: int, every_s: float, ahead_s: float
) -> float:
    """The variance per component of the split after ``windows`` more windows like the last.

    The filter's covariance does not depend on what the windows measure, only on when and how
    well: this carries ``found``'s on through ``windows`` windows, one every ``every_s``
    seconds, each measuring the split with the windows' median variances (own and anchored),
    and ``ahead_s`` seconds past the last (the end of a window, from its middle). What a run
    can still show at best: the variance its verdict would hold if every answer from now on
    were perfect.
    """
    x, p = np.zeros((3, 2)), np.asarray(found.covariance, dtype=float)
    anchored = np.isfinite(found.anchored_variance_hz2) and np.isfinite(model.model_error_hz)
    for _ in range(max(int(windows), 0)):
        x, p = _predict(x, p, model, every_s)
        x, p = _update(x, p, _OWN, np.zeros(2), found.own_variance_hz2)
        if anchored:
            x, p = _update(x, p, _BOTH, np.zeros(2), found.anchored_variance_hz2)
    return float(_predict(x, p, model, max(ahead_s, 0.0))[1][0, 0])


#: What a window's own split measures (the level) and its anchored one (the level and what the
#: anchored model misses).
_OWN, _BOTH = np.array([1.0, 0.0, 0.0]), np.array([1.0, 0.0, 1.0])


def _update(
    x: np.ndarray, p: np.ndarray, h: np.ndarray, vector: np.ndarray, variance: float
) -> tuple[np.ndarray, np.ndarray]:
    """The state and covariance after one measurement ``h · x = vector`` of ``variance``."""
    gain = p @ h / (h @ p @ h + max(variance, 1e-30))
    x = x + np.outer(gain, vector - h @ x)
    p = p - np.outer(gain, h @ p)
    return x, 0.5 * (p + p.T)


def _predict(
    x: np.ndarray, p: np.ndarray, model: TrendModel, dt: float
) -> tuple[np.ndarray, np.ndarray]:
    """The state and its covariance ``dt`` seconds later (what the model misses stays)."""
    f2, q2 = model.transition(dt)
    f, q = np.eye(3), np.zeros((3, 3))
    f[:2, :2], q[:2, :2] = f2, q2
    return f @ x, f @ p @ f.T + q
