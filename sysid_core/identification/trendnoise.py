"""What a run's windows say of the stated trend: their variance scale and how fast the rate changes.

The stated trend (:data:`~sysid_core.identification.splittrend.LAB_TREND`) takes each window's
variance from its fit and the split's rate as constant over a run. Either may be wrong for a
run, and each leaves its mark on the filter's innovations, the errors with which it predicts
each window before reading it:

* a fit's interval treats the noise of a window's points as independent, but part of what a
  window misses is common to all its points (the analyzer's gain and phase wander during it, a
  weak wide mode the points barely see), so a window may scatter more than its interval says:
  all innovations come out larger than the filter expects (the variance scale ``λ``);
* a lab whose charging and temperature change their pace within a run (a run that verifies one
  fast gyro hundreds of times over ten minutes) moves the split along a curve, not a line: a
  line through every window then averages the split of minutes ago into the forecast, and the
  innovations run in long excursions of one sign (the rate changes by its own size in ``τ_r``).

:func:`fitted_trend` estimates both by maximum likelihood of the innovations over a grid
(:data:`SCALES` times :data:`RATE_CHANGES_S`), and keeps the stated model unless the windows
reject it: a likelihood-ratio test at 95 % for two parameters that the stated model holds at
the edges of their ranges (``λ = 1``, ``1/τ_r = 0``), whose statistic is then a mixture
``¼ χ²₀ + ½ χ²₁ + ¼ χ²₂`` (Self & Liang 1987), critical value :data:`LR_CRITICAL`. Its limit:
where the windows sit at a new code each, what the model's law misses between the codes varies
with the bias, not with time, and reads as a change of pace too; the filter then leans on fewer
windows, which lengthens a run without making it wrong (docs/studies/repeated-looks.md measures
both cases on runs).

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

__all__ = ["LR_CRITICAL", "RATE_CHANGES_S", "SCALES", "fitted_trend", "noise_said"]

#: The 95 % point of twice the log-likelihood ratio for two parameters each on the edge of its
#: range: ``½ P(χ²₁ > c) + ¼ P(χ²₂ > c) = 0.05`` (4.23).
LR_CRITICAL = float(brentq(lambda c: 0.5 * chi2.sf(c, 1) + 0.25 * chi2.sf(c, 2) - 0.05, 0.1, 20.0))

#: The variance scales ``λ`` tried: 1 to 64 (a window scattering up to 8 times what its fit
#: states) in steps of √2.
SCALES = 2.0 ** (np.arange(13) / 2)

#: The times ``τ_r`` in which the split's rate may change by its prior's size: the stated
#: model's (none: ``inf``), then 4 h down to 1 min in steps of 4 (a window's spacing on a fast
#: gyro is seconds, a run's length minutes to an hour).
RATE_CHANGES_S = (float("inf"), 14_400.0, 3_600.0, 900.0, 225.0, 60.0)


def fitted_trend(
    times_s: Sequence[float],
    vectors_hz: np.ndarray,
    variances_hz2: Sequence[float],
    model: TrendModel,
    anchored_hz: np.ndarray | None = None,
    anchored_variances: Sequence[float] | None = None,
) -> TrendModel:
    """``model`` with the variance scale and the rate's change time the windows support.

    The arguments are those of :func:`~sysid_core.identification.splittrend.forecast`. The
    scales tried are ``model``'s times :data:`SCALES`, the change times ``model``'s and the
    shorter ones of :data:`RATE_CHANGES_S`. With fewer than three windows (the first two set
    the level and the rate, and leave no error to read), or when the test does not reject
    ``model``, ``model`` itself.
    """
    if np.unique(np.asarray(times_s, dtype=float)).size < 3:
        return model
    scales = SCALES * model.window_variance_scale
    changes = [model.rate_change_s, *(c for c in RATE_CHANGES_S if c < model.rate_change_s)]
    ll = np.array(
        [
            log_likelihood(
                times_s,
                vectors_hz,
                variances_hz2,
                dataclasses.replace(model, rate_change_s=change),
                scales,
                anchored_hz,
                anchored_variances,
            )
            for change in changes
        ]
    )
    i, j = np.unravel_index(int(np.argmax(ll)), ll.shape)
    if 2.0 * (ll[i, j] - ll[0, 0]) <= LR_CRITICAL:
        return model
    return dataclasses.replace(
        model, window_variance_scale=float(scales[j]), rate_change_s=float(changes[i])
    )


def noise_said(trend: TrendModel) -> str:
    """What the windows showed beyond the stated trend, in words ("" if nothing)."""
    said = []
    if trend.window_variance_scale > 1.0:
        said.append(
            f"the windows scattering {np.sqrt(trend.window_variance_scale):.2g} times what "
            "their fits state"
        )
    if np.isfinite(trend.rate_change_s):
        said.append(f"its rate changing within about {trend.rate_change_s / 60:.2g} min")
    return f" ({'; '.join(said)})" if said else ""
