"""Two modes whose grid cores overlap are measured by one grid, at the finer of their steps."""

from __future__ import annotations

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

from sysid_core.measure import lean, modegrid
from sysid_core.measure.evidence import local_steps
from sysid_core.measure.lean import ModeGuess
from sysid_core.measure.modegrid import GridShape, shaped_grid
from sysid_core.measure.modegrid import shaped_grid as mode_grid  # the default shape
from sysid_core.measure.sweeps import SweepPlan

PLAN = SweepPlan((2540.0, 2650.0), 0.5, 6.0, 0.05, 6.0, 0.05, 20_000)


def _core(points: np.ndarray, guess: ModeGuess) -> np.ndarray:
    """The points within the modes' cores (the anchors are outside)."""
    f, half = guess.frequencies_hz, guess.core_half_widths()
    inside = np.abs(points[:, None] - f[None, :]) <= half[None, :] * 1.5 + 1e-9
    return points[np.any(inside, axis=1)]


def test_near_degenerate_modes_take_one_mode_s_points() -> None:
    """Modes 0.1 mHz apart: one grid of 7-8 core points, not two interleaved ones of 14."""
    guess = ModeGuess.of([2595.97, 2595.9701], [0.06, 0.057])
    points = mode_grid(guess, PLAN)
    core = _core(points, guess)
    assert 7 <= core.size <= 8
    assert points.size == core.size + lean.ANCHORS
    # no two points a fraction of a step apart: the smallest gap is the grid's step
    gaps = np.diff(core)
    np.testing.assert_allclose(gaps, gaps[0], rtol=1e-9)


def test_modes_far_apart_keep_their_own_grids() -> None:
    """Modes 1 Hz (17 bandwidths) apart: two cores of 7 points each, as before."""
    guess = ModeGuess.of([2595.0, 2596.0], [0.06, 0.06])
    core = _core(mode_grid(guess, PLAN), guess)
    assert core.size == 14


def test_modes_of_different_bandwidths_take_a_graded_grid() -> None:
    """Near degenerate modes of Q 17 000 and 8 000 (bandwidths 0.066 and 0.14 Hz at 1113 Hz).

    The even grid spends the narrow mode's step over the wide mode's core: 13 core points. The
    graded one keeps that step over the narrow mode's core and the wide mode's own step beyond
    it: 11 points, every mode's step within its core no coarser than its own grid's. With one
    tone (every point a dwell) the graded grid is measured.
    """
    guess = ModeGuess.of([1113.348, 1113.3481], [0.066, 0.14], 0.01)
    plan = SweepPlan((1075.5, 1153.3), 0.5, 6.0, 0.05, 6.0, 0.05, 20_000)
    even = shaped_grid(guess, plan, shape=GridShape(1.5, 2, graded=False))
    graded = shaped_grid(guess, plan, shape=GridShape(1.5, 2, graded=True))
    assert (_core(even, guess).size, _core(graded, guess).size) == (13, 11)
    steps, _ = modegrid._core_steps(guess, lean.POINTS_PER_BANDWIDTH, lean.MAX_HALF_POINTS, 1.5)
    for grid in (even, graded):
        got = local_steps(grid, guess.frequencies_hz, guess.bandwidth_hz)
        assert np.all(got <= steps * (1 + 1e-9))
    # the narrow mode's step only within its core: the graded grid's largest core step is the
    # wide mode's own
    gaps = np.diff(_core(graded, guess))
    np.testing.assert_allclose([gaps.min(), gaps.max()], np.sort(steps), rtol=1e-9)
    chosen = modegrid.mode_grid(guess, plan, resolve=True, cost_s=lambda n: 1.2 + n)
    assert chosen.size == graded.size


@settings(max_examples=60, deadline=None)
@given(
    split_bw=st.floats(0.0, 6.0),
    bw0=st.floats(0.02, 0.2),
    ratio=st.floats(0.5, 2.0),
    sigma_bw=st.floats(0.0, 3.0),
    graded=st.booleans(),
)
def test_one_grid_resolves_each_mode_as_finely_with_no_more_points(
    split_bw: float, bw0: float, ratio: float, sigma_bw: float, graded: bool
) -> None:
    """Whatever the split: each mode's step is no coarser than its own grid's, never more points.

    Found by hypothesis: modes one bandwidth apart whose grids hold two points 1.3 µHz apart.
    The same for the graded grid (the finer step over the finer mode's core only).

    The reference is the two cores laid side by side (the grid before the union), each at its
    own step (``_core_steps``).
    """
    bw = np.array([bw0, bw0 * ratio])
    f = 2595.0 + np.array([0.0, split_bw * bw0])
    guess = ModeGuess.of(f, bw, sigma_bw * bw0)
    steps, counts = modegrid._core_steps(guess, lean.POINTS_PER_BANDWIDTH, lean.MAX_HALF_POINTS)
    points = shaped_grid(guess, PLAN, shape=GridShape(graded=graded))
    got = local_steps(points, guess.frequencies_hz, bw)
    # points closer than a thousandth of the narrowest bandwidth are merged into one
    # (``modegrid._mode_points``): that moves a step by at most that much
    assert np.all(got <= steps * (1 + 1e-9) + 1e-3 * bw.min())
    separate = sum(2 * k + 1 for k in counts) + lean.ANCHORS
    assert points.size <= separate
