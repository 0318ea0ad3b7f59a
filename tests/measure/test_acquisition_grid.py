"""A scout fills whole acquisitions: an acquisition costs the same with one point as with all
its tones, so a sweep's last acquisition is filled, or dropped when a few points spill into it.

Truth: the grid's own definition (even steps over the windows, at least ``MIN_POINTS``) and the
cost of a sweep in acquisitions (:func:`~sysid_core.clock.benchtime.acquisitions`).
"""

from __future__ import annotations

import dataclasses

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

from sysid_core.clock.benchtime import acquisitions
from sysid_core.measure.lean import QUIET_SCOUT_POINTS, SCOUT_MIN_POINTS, ModeGuess, scout_grid
from sysid_core.measure.sweeps import MIN_POINTS, SweepPlan, acquisition_grid, grid, n_points


@settings(max_examples=200, deadline=None)
@given(
    lo=st.floats(1000.0, 30_000.0),
    widths=st.lists(st.floats(0.05, 40.0), min_size=1, max_size=2),
    gap=st.floats(0.1, 50.0),
    step=st.floats(0.01, 3.0),
    tones=st.integers(1, 16),
)
def test_whole_acquisitions_within_half_an_acquisition_of_the_grid(
    lo: float, widths: list[float], gap: float, step: float, tones: int
) -> None:
    """On any windows: the points lie in them, ascending; with one tone they are the grid (at
    least ``MIN_POINTS``); with several, a whole number of acquisitions, within half an
    acquisition of the grid's count, and never an acquisition more than the grid costs."""
    windows, start = [], lo
    for w in widths:
        windows.append((start, start + w))
        start += w + gap
    n = sum(n_points(a, b, step) for a, b in windows)
    points = acquisition_grid(windows, step, tones)
    assert np.all(np.diff(points) > 0)
    inside = np.zeros(points.size, dtype=bool)
    for a, b in windows:
        inside |= (points >= a - 1e-9 * b) & (points <= b + 1e-9 * b)
    wanted = max(n, MIN_POINTS)
    if tones == 1:
        assert points.size == wanted
        if n >= MIN_POINTS:
            np.testing.assert_array_equal(
                points, np.concatenate([grid(a, b, step) for a, b in windows])
            )
        else:  # too few: evenly over the windows' span
            assert points[0] == windows[0][0] and points[-1] == windows[-1][1]
        return
    assert inside.all()
    assert points.size % tones == 0
    assert abs(points.size - wanted) <= tones / 2
    assert acquisitions(points.size, tones) <= acquisitions(wanted, tones)


def test_a_scout_of_eleven_points_with_eight_tones_is_one_acquisition() -> None:
    """Two modes 1 Hz apart at a 0.5 Hz resolution: the scout's windows hold 11 points, which
    take two acquisitions of 8 tones for 3 points in the second; 8 points take one, and are a
    one-tone scout's floor too. With 13 tones the 11 points fill one acquisition of 13."""
    guess = ModeGuess.of([4400.0, 4401.0], [0.05, 0.05])
    plan = SweepPlan((4300.0, 4500.0), 0.5, 6.0, 0.05, 6.0, 0.05, 20_000)
    one = scout_grid(guess, plan)
    assert one.size == SCOUT_MIN_POINTS < MIN_POINTS
    eight = scout_grid(guess, dataclasses.replace(plan, tones=8))
    assert eight.size == 8 and acquisitions(eight.size, 8) == 1
    assert eight.min() >= one.min() and eight.max() <= one.max()
    thirteen = scout_grid(guess, dataclasses.replace(plan, tones=13))
    assert thirteen.size == 13


def test_a_quiet_benchs_scout_has_a_lower_floor_only_where_it_saves_an_acquisition() -> None:
    """The same windows on a quiet bench: a one-tone scout of 6 points, not 8 (2 dwells less);
    with eight tones it is one acquisition of 8 either way, and with two tones 6 points are
    three acquisitions instead of four."""
    guess = ModeGuess.of([4400.0, 4401.0], [0.05, 0.05])
    plan = SweepPlan((4300.0, 4500.0), 0.5, 6.0, 0.05, 6.0, 0.05, 20_000)
    quiet = scout_grid(guess, plan, quiet=True)
    assert quiet.size == QUIET_SCOUT_POINTS < SCOUT_MIN_POINTS == scout_grid(guess, plan).size
    assert quiet.min() >= scout_grid(guess, plan).min()  # the same windows, sparser
    assert quiet.max() <= scout_grid(guess, plan).max()
    eight = dataclasses.replace(plan, tones=8)
    assert np.array_equal(scout_grid(guess, eight, quiet=True), scout_grid(guess, eight))
    two = dataclasses.replace(plan, tones=2)
    assert acquisitions(scout_grid(guess, two, quiet=True).size, 2) == 3
    assert acquisitions(scout_grid(guess, two).size, 2) == 4
