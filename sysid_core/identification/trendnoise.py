"""What a run's windows say of their own scatter: the windows' variance scale.

The stated trend (:data:`~sysid_core.identification.splittrend.LAB_TREND`) takes each window's
variance from its fit. A fit's interval treats the noise of a window's points as independent,
but part of what a window misses is common to all its points (the analyzer's gain and phase
wander during it, a weak wide mode the points barely see), so a window may scatter more than its
interval says. That leaves a mark on the filter's innovations, the errors with which it predicts
each window before reading it: all of them come out larger than the filter expects.

:func:`fitted_trend` estimates the scale ``λ`` on every window's variance by maximum likelihood
of the innovations over a grid (:data:`SCALES`), and keeps the stated model unless the windows
reject it: a likelihood-ratio test at 95 % for one parameter that the stated model holds at the
edge of its range (``λ = 1``), whose statistic is then a mixture ``½ χ²₀ + ½ χ²₁`` (Self &
Liang 1987), critical value :data:`LR_CRITICAL`.

A wander of the split's level (``q_s``) estimated the same way was tried and not kept
(docs/studies/window-scatter.md): a window error that persists from window to window reads as a
wander, and answers that follow it move the gyro away from where it was tuned.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Sequence

import numpy as np
from scipy.optimize import brentq
from scipy.stats import chi2

from sysid_core.identification.splittrend import TrendModel, log_likelihood

__all__ = ["LR_CRITICAL", "SCALES", "fitted_trend"]

#: The 95 % point of twice the log-likelihood ratio for one parameter on the edge of its range:
#: ``½ P(χ²₁ > c) = 0.05`` (2.71).
LR_CRITICAL = float(brentq(lambda c: 0.5 * chi2.sf(c, 1) - 0.05, 0.1, 20.0))

#: The variance scales ``λ`` tried: 1 to 64 (a window scattering up to 8 times what its fit
#: states) in steps of √2.
SCALES = 2.0 ** (np.arange(13) / 2)


def fitted_trend(
    times_s: Sequence[float],
    vectors_hz: np.ndarray,
    variances_hz2: Sequence[float],
    model: TrendModel,
    anchored_hz: np.ndarray | None = None,
    anchored_variances: Sequence[float] | None = None,
) -> TrendModel:
    """``model`` with the windows' variance scale the windows support.

    The arguments are those of :func:`~sysid_core.identification.splittrend.forecast`. The
    scales tried are ``model``'s times :data:`SCALES`. With fewer than three windows (the first
    two set the level and the rate, and leave no error to read), or when the test does not
    reject ``model``, ``model`` itself.
    """
    if np.unique(np.asarray(times_s, dtype=float)).size < 3:
        return model
    scales = SCALES * model.window_variance_scale
    ll = log_likelihood(
        times_s, vectors_hz, variances_hz2, model, scales, anchored_hz, anchored_variances
    )
    best = int(np.argmax(ll))
    if 2.0 * (ll[best] - ll[0]) <= LR_CRITICAL:
        return model
    return dataclasses.replace(model, window_variance_scale=float(scales[best]))
