"""Repeated looks at the forecast: the level each look's bound on the split is held to.

A tracked run judges the split at the end of every verification window by the windows'
forecast (:meth:`~sysid_core.drift.tracker.Tracker.end_split`) and stops at the first window
whose bound is under the goal. Each look alone is a 95 % claim; a run that looks again and
again at one split on the goal (the DAC code it cannot improve on, verified again) passes it
sooner or later, because every look is another chance for the noise to fall low. Measured on
the filter's own estimator (windows of one noise, 0.35 of the goal per component, one every
15 s, a split vector of fixed length; docs/studies/repeated-looks.md): 100 looks at 95 % each
pass a split on the goal 50 % of the time, one 6.4 % over it 21 %.

So the ``k``-th look in a row at one split is held to the level :func:`look_level`
(``5 % / (1 + ln k)²``): the first at 95 %, the second at 98.3 %, the tenth at 99.5 %.
Successive looks at a filter that forgets nothing share almost all their information; the
chances they add grow with the logarithm of the number of windows, not with the number of
looks, so the level is spent over ``ln k``. On the same estimator: 5.2 % of runs pass a split on
the goal in 100 looks, 2.0 % one 6.4 % over it; a split at 0.7 of the goal passes at a median
20th look instead of the 7th, one at 0.4 at the 5th instead of the 3rd.

A look continues the count when the code it judges moves the split from the last look's code by
no more than one standard deviation of a component of the forecast (:func:`next_look`): no look
resolves such a change, so it is the same split looked at again (a run that steps one DAC code
to and fro looks at one split as often as one that stays). A code that moves the split by more
is a new split, and its first look is at 95 % again (docs/studies/repeated-looks.md measures the
other count, every look of a run, and what it costs a run that pools its windows at codes that
keep changing; docs/studies/local-law.md this one).
"""

from __future__ import annotations

import numpy as np
from scipy.stats import rice

__all__ = ["END_LEVEL", "look_level", "next_look", "rayleigh_point", "split_bound"]

#: What a single look may pass in error: the first look's level.
END_LEVEL = 0.05


def look_level(look: int) -> float:
    """The level of the ``look``-th look (1 the first): ``END_LEVEL / (1 + ln look)²``."""
    if look < 1:
        raise ValueError(f"looks are counted from 1, got {look!r}")
    return END_LEVEL / (1.0 + np.log(look)) ** 2


def next_look(looks: int, change_hz: float, sigma_hz: float) -> int:
    """The count of a look whose code moves the split by ``change_hz`` from the last look's.

    ``looks``: the last look's count (0: none yet); ``change_hz``: the length of the change of
    the split vector the model predicts between the two codes, at one time (``inf`` where it
    cannot say); ``sigma_hz``: the forecast's standard deviation of a component. Within it, the
    same split again (``looks + 1``); beyond it, a new one (1).
    """
    return looks + 1 if looks >= 1 and change_hz <= sigma_hz else 1


def split_bound(mean_hz: float, sigma_hz: float, look: int) -> float:
    """The upper bound on a split vector's length at the ``look``-th look (Hz).

    The Rice distribution's ``1 − look_level(look)`` point of the length of a two-component
    vector of length ``mean_hz`` whose components each have the standard deviation
    ``sigma_hz`` (``mean_hz`` itself when ``sigma_hz`` is 0).
    """
    if sigma_hz <= 0:
        return float(mean_hz)
    return float(rice.ppf(1.0 - look_level(look), mean_hz / sigma_hz, scale=sigma_hz))


def rayleigh_point(look: int) -> float:
    """:func:`split_bound` of a vector of mean zero, in its components' standard deviations.

    The Rayleigh distribution's ``1 − look_level(look)`` point, ``√(−2 ln level)``: 2.45 at
    the first look.
    """
    return float(np.sqrt(-2.0 * np.log(look_level(look))))
