"""How sure a tuning answer is: 95 % regions for its bias, split and frequency.

The fitted model's stiffness parameters (``M``, ``K0``, ``K_p``) come with a covariance
(:mod:`sysid_core.identification.covariance`, least-squares fits). :func:`confidence_region` draws
models from that Gaussian and asks each of them two questions about the answer ``b̂`` of a criterion:

* **split and frequency at b̂.** With ``K̃ = M^{-1/2} K(ŵ) M^{-1/2} = t I + [[d1, d2], [d2, -d1]]``
  the modes are ``sqrt(t ± |d|) / 2π``: the split depends on the deviatoric part ``d`` only.
  The region of ``d`` is the ellipse ``(d - d̂)ᵀ Σ_d⁻¹ (d - d̂) ≤ χ²₂(level)`` (``Σ_d`` from
  the draws); ``split_ci_hz`` is the range of splits over it (its lower end is 0 when the
  ellipse holds a degenerate model). ``frequency_ci_hz`` is the central interval of the mean
  modal frequency over the draws.
* **where would it be degenerate.** ``d`` is affine in the squared potentials ``w``, so each
  drawn model's degenerate point nearest ``ŵ`` (the smallest change of ``w``) is one
  least-squares step, exact with two tuned electrodes: ``δw = -D⁺ d`` with ``D`` the
  deviatoric parts of the drawn ``K̃_p``. For the ``target`` criterion the trace condition
  ``t = (2π f_target)²`` is added. ``bias_ci`` holds, per tuned electrode, the central
  interval of the drawn models' biases at level ``1 - (1 - level) / n`` (Bonferroni over the
  ``n`` tuned electrodes, so that the box holds every electrode together with at least
  ``level``); an electrode that is not tuned keeps its bias.

The draws use a fixed seed: the same model and answer give the same region.
"""

from __future__ import annotations

import math

import numpy as np

from sysid_core.conic.program import sym
from sysid_core.data.schema import squared_potentials
from sysid_core.model.fitted import FittedModel
from sysid_core.model.modal import normalised_stiffness, trace_deviation
from sysid_core.tuning.criteria import BiasSpace, ConfidenceRegion, TuningResult

__all__ = [
    "DEFAULT_LEVEL",
    "DEFAULT_SAMPLES",
    "confidence_region",
    "split_interval",
    "stiffness_draws",
    "stiffness_vector",
]

#: Confidence level of the regions a run reports.
DEFAULT_LEVEL = 0.95
#: Models drawn per region.
DEFAULT_SAMPLES = 4000
_TWO_PI = 2.0 * np.pi


def stiffness_vector(model: FittedModel) -> np.ndarray:
    """The model's stiffness parameters, in the order of the covariance's ``stiffness_map``.

    See :func:`sysid_core.identification.covariance.stiffness_map`.
    """

    def entries(x: np.ndarray) -> list[float]:
        return [float(x[0, 0]), float(x[0, 1]), float(x[1, 1])]

    values = entries(model.M) + entries(model.K0)
    for kp in model.Kp:
        values += entries(kp)
    return np.array(values)


def stiffness_draws(
    model: FittedModel, samples: int, seed: int = 0
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """``M``, ``K0`` and ``K_p`` of ``samples`` models drawn from a linear model's covariance.

    Shapes ``(S, 2, 2)``, ``(S, 2, 2)`` and ``(S, n_e, 2, 2)``; the draws use ``seed``. The
    model must have a :attr:`~sysid_core.model.fitted.FittedModel.stiffness_factor` and a law
    linear in ``w`` (:meth:`~sysid_core.model.fitted.FittedModel.linearized` makes one).
    """
    factor = model.stiffness_factor
    if factor is None:
        raise ValueError("the model has no covariance (a minimax fit): nothing to draw from")
    n_e = len(model.electrodes)
    z = np.random.default_rng(seed).standard_normal((samples, factor.shape[1]))
    draws = stiffness_vector(model) + z @ factor.T
    kp = sym(draws[:, 6 : 6 + 3 * n_e].reshape(samples, n_e, 3))
    return sym(draws[:, 0:3]), sym(draws[:, 3:6]), kp


def _split_hz(t: float | np.ndarray, r: float | np.ndarray) -> np.ndarray:
    """Split of modes ``sqrt(t ± r) / 2π`` (Hz)."""
    r = np.minimum(r, t)
    return np.asarray((np.sqrt(t + r) - np.sqrt(np.clip(t - r, 0.0, None))) / _TWO_PI)


def _split_range(t0: float, d0: np.ndarray, cov_d: np.ndarray, level: float) -> tuple[float, float]:
    """The split range (Hz) over the ``level`` ellipse of ``d`` (centre ``d0``, ``cov_d``)."""
    q = -2.0 * math.log(1.0 - level)  # chi-square quantile, 2 degrees of freedom
    lam_d, vec_d = np.linalg.eigh(cov_d)
    lam_d = np.clip(lam_d, 1e-300, None)
    angle = np.linspace(0.0, 2 * np.pi, 721)
    unit = np.stack([np.cos(angle), np.sin(angle)], axis=1)
    radius = np.hypot(*(d0 + math.sqrt(q) * (unit * np.sqrt(lam_d)) @ vec_d.T).T)
    inside = float(np.sum((vec_d.T @ d0) ** 2 / lam_d)) <= q
    return (
        0.0 if inside else float(_split_hz(t0, radius.min())),
        float(_split_hz(t0, radius.max())),
    )


def _split_and_frequency(
    t: np.ndarray, d: np.ndarray, t0: float, d0: np.ndarray, level: float
) -> tuple[tuple[float, float], tuple[float, float]]:
    """The split range and the mean modal frequency's interval (Hz) of the drawn models.

    The split range is over the ``level`` ellipse of the drawn ``d`` (centred on the model's
    ``d0``); the interval is the central one of the drawn mean modal frequency.
    """
    split_ci = _split_range(t0, d0, np.cov(d, rowvar=False), level)
    r = np.hypot(d[:, 0], d[:, 1])
    f_mean = 0.5 * (np.sqrt(np.clip(t + r, 0, None)) + np.sqrt(np.clip(t - r, 0, None))) / _TWO_PI
    alpha = 1.0 - level
    f_lo, f_hi = np.quantile(f_mean, [alpha / 2, 1 - alpha / 2])
    return split_ci, (float(f_lo), float(f_hi))


def confidence_region(
    model: FittedModel,
    result: TuningResult,
    space: BiasSpace,
    level: float = DEFAULT_LEVEL,
    samples: int = DEFAULT_SAMPLES,
    seed: int = 0,
    applied_bias: np.ndarray | None = None,
) -> ConfidenceRegion | None:
    """The region of ``result`` (a criterion's answer for ``model`` in ``space``).

    Returns ``None`` when the model has no covariance (a ``minimax`` fit).

    Parameters
    ----------
    model : FittedModel
        The model the criterion tuned; its electrodes are ``space.tuned``.
    result : TuningResult
        The answer; a ``target_hz`` in its ``info`` adds the frequency condition.
    space : BiasSpace
        The electrodes, limits and structure potential of the tuning.
    level : float
        Confidence level in (0, 1).
    samples : int
        Models drawn.
    seed : int
        Seed of the draws.
    applied_bias : ndarray, optional
        Every electrode's bias as the device will really apply it (a DAC's nearest code), if
        it says; the split and frequency ranges are for that bias (the bias box is not: it is
        about the true degenerate bias).
    """
    if model.stiffness_factor is None:
        return None
    if not 0.0 < level < 1.0:
        raise ValueError(f"level must be in (0, 1), got {level}")
    v_gyro = space.structure_potential
    index = space.index
    bias = np.asarray(result.bias, dtype=float)
    w_hat = squared_potentials(v_gyro, bias[index])
    n_t = len(index)
    if list(model.electrodes) != list(space.tuned):
        raise ValueError(
            f"the model's electrodes {model.electrodes} are not the tuned ones {space.tuned}"
        )
    m, k0, kp = stiffness_draws(model, samples, seed)
    t, d, t0, d0 = _trace_deviation_at(model, m, k0, kp, w_hat)

    # Where the split is predicted: the applied bias if the device says, and the ellipse of d.
    if applied_bias is None:
        t_at, d_at, t_at0, d_at0 = t, d, t0, d0
    else:
        w_at = squared_potentials(v_gyro, np.asarray(applied_bias, dtype=float)[index])
        t_at, d_at, t_at0, d_at0 = _trace_deviation_at(model, m, k0, kp, w_at)
    split_ci, (f_lo, f_hi) = _split_and_frequency(t_at, d_at, t_at0, d_at0, level)

    # Each draw's degenerate (or on-target) point nearest w_hat.
    target = result.info.get("target_hz")
    step = _degenerate_steps(model, m, kp, t, d, t0, d0, target)
    w = np.clip(w_hat + step, 0.0, None)
    sign = np.sign(v_gyro - bias[index])
    sign[sign == 0] = 1.0
    bias_draws = v_gyro - sign * np.sqrt(w)
    a = (1.0 - level) / n_t
    lo, hi = np.quantile(bias_draws, [a / 2, 1 - a / 2], axis=0)
    box = np.column_stack([bias, bias])
    box[index, 0], box[index, 1] = lo, hi
    return ConfidenceRegion(
        level=level,
        bias_ci=box,
        split_ci_hz=split_ci,
        frequency_ci_hz=(f_lo, f_hi),
        samples=samples,
    )


def _trace_deviation_at(
    model: FittedModel, m: np.ndarray, k0: np.ndarray, kp: np.ndarray, w: np.ndarray
) -> tuple[np.ndarray, np.ndarray, float, np.ndarray]:
    """``t`` and ``d`` of every drawn model and of ``model`` itself at squared potentials ``w``.

    The drawn models are ``m``, ``k0`` (``(S, 2, 2)``) and ``kp`` (``(S, n_e, 2, 2)``).
    """
    t, d = trace_deviation(normalised_stiffness(m, k0 + np.einsum("p,sp...->s...", w, kp)))
    t_own, d_own = trace_deviation(normalised_stiffness(model.M[None], model.stiffness_w(w)[None]))
    return t, d, float(t_own[0]), d_own[0]


def _degenerate_steps(
    model: FittedModel,
    m: np.ndarray,
    kp: np.ndarray,
    t: np.ndarray,
    d: np.ndarray,
    t0: float,
    d0: np.ndarray,
    target: float | None,
) -> np.ndarray:
    """Each draw's step in ``w`` from the answer to its degenerate (or on-target) point.

    One least-squares step, ``δw = -D⁺ d`` (with the trace condition for a ``target``), less
    the answer's own step under ``model``.
    """
    tp, dp = trace_deviation(normalised_stiffness(m, kp))  # (S, n_e), (S, n_e, 2)
    jac = np.transpose(dp, (0, 2, 1))  # (S, 2, n_e)
    rhs = -d
    if target is not None:
        jac = np.concatenate([jac, tp[:, None, :]], axis=1)
        rhs = np.concatenate([rhs, ((_TWO_PI * float(target)) ** 2 - t)[:, None]], axis=1)
    step = np.einsum("sij,sj->si", np.linalg.pinv(jac), rhs)
    # The answer's own step (nonzero where the conditions cannot all hold: an unreachable
    # goal, a target with two electrodes) is the criterion's compromise, not uncertainty.
    own_jac = np.transpose(
        trace_deviation(normalised_stiffness(model.M[None], model.Kp[None]))[1][0]
    )
    own_rhs = -d0
    if target is not None:
        own_tp = trace_deviation(normalised_stiffness(model.M[None], model.Kp[None]))[0][0]
        own_jac = np.vstack([own_jac, own_tp[None, :]])
        own_rhs = np.append(own_rhs, (_TWO_PI * float(target)) ** 2 - t0)
    return step - np.linalg.pinv(own_jac) @ own_rhs


def split_interval(model: FittedModel, level: float = DEFAULT_LEVEL) -> tuple[float, float] | None:
    """The ``level`` interval of the split (Hz) of a model of one bias (a verification's).

    The split range over the ``level`` ellipse of the normalised stiffness's deviation ``d``,
    whose covariance is the fit's, mapped to first order: ``(J F)(J F)ᵀ``, ``F`` the fit's
    covariance factor and ``J F`` by central differences along each of its columns. Sampling
    the stiffness (as :func:`confidence_region` does) would not do here: near degenerate modes
    the fit barely tells ``M`` and ``K`` from a common symmetric factor of both (``T M``,
    ``T K`` with ``R~ → T R~``), a direction of huge variance along which the split does not
    change to first order but the draws end far from the model. ``None`` without a covariance
    (``minimax``) or for a model with bias electrodes. The interval is the noise's: a model
    structure that cannot represent the gyro biases the split beyond it.
    """
    if model.stiffness_factor is None or len(model.electrodes):
        return None
    phi = stiffness_vector(model)[:6]

    def deviation(x: np.ndarray) -> np.ndarray:
        t, d = trace_deviation(normalised_stiffness(sym(x[None, 0:3]), sym(x[None, 3:6])))
        return np.array([t[0], *d[0]])

    # d along each column of the covariance's factor, by central differences of that direction
    # itself: the factor has a column of huge variance along which M and K0 scale together
    # and d does not move (to first order); a Jacobian of the entries times that column lost
    # the cancellation (first to a step sized by K0's entries in M's, 100x too wide an
    # interval on fast gyros; then to rounding, a bound 1.6x apart between two BLAS builds)
    cols = np.asarray(model.stiffness_factor[:6], dtype=float)
    block = np.repeat([np.abs(phi[:3]).max(), np.abs(phi[3:6]).max()], 3)
    block = np.where(block > 0, block, 1.0)
    factor = np.zeros((3, cols.shape[1]))
    for j in range(cols.shape[1]):
        c = cols[:, j]
        size = float(np.max(np.abs(c) / block))
        if size == 0.0:
            continue
        h = 1e-6 / size  # the step moves each matrix by a millionth of itself at most
        factor[:, j] = (deviation(phi + h * c) - deviation(phi - h * c)) / (2 * h)
    cov_d = factor[1:] @ factor[1:].T
    own = deviation(phi)
    return _split_range(float(own[0]), own[1:], cov_d, level)
