"""A run whose windows cannot show a converged split stops there instead of spending its budget.

Truth: the goal ``split 95 % upper bound <= 2 × acceptance``. A window whose 95 % interval reaches
more than twice the acceptance above the split it measured fails that goal whatever the split;
three such windows in a row, each consistent with a converged split, end the run.
"""

from __future__ import annotations

import pytest

from sysid_core.run.judgement import UNRESOLVED_WINDOWS, unresolved

MHZ = 1e-3
ACCEPTANCE = 2 * MHZ


def window(split_mhz: float, low_mhz: float, high_mhz: float) -> tuple[float, list[float]]:
    return split_mhz * MHZ, [low_mhz * MHZ, high_mhz * MHZ]


def test_three_windows_that_could_not_have_shown_convergence_stop_the_run() -> None:
    # random gyro 317 (24 kHz) in the lab: windows whose intervals reach 6-8 mHz above them
    noisy = [window(7.41, 1.01, 14.43), window(5.2, 0.0, 11.6), window(7.17, 0.08, 15.56)]
    why = unresolved(noisy, ACCEPTANCE)
    assert why is not None and why.startswith("the last 3 verified windows could not show")
    assert "reach 6.4-8.39 mHz above the split they measured" in why
    assert UNRESOLVED_WINDOWS == 3 and unresolved(noisy[:2], ACCEPTANCE) is None


@pytest.mark.parametrize(
    "windows",
    [
        # one window of the three could have shown it (reach 3.9 mHz <= 4 mHz)
        [window(7.41, 1.01, 14.43), window(5.2, 0.0, 9.1), window(7.17, 0.08, 15.56)],
        # far from degenerate modes: the intervals exclude a converged split; not this rule's
        [window(300.0, 280.0, 330.0), window(250.0, 230.0, 270.0), window(90.0, 70.0, 110.0)],
        # a window without an interval (minimax, or not verified) is not counted
        [window(7.41, 1.01, 14.43), (5.2 * MHZ, None), window(7.17, 0.08, 15.56)],
        # windows that resolve the acceptance
        [window(1.2, 0.0, 2.5), window(0.8, 0.0, 2.2), window(1.5, 0.3, 3.0)],
    ],
)
def test_windows_that_could_show_it_or_that_exclude_it_do_not(
    windows: list[tuple[float, list[float] | None]],
) -> None:
    assert unresolved(windows, ACCEPTANCE) is None


def test_only_the_latest_windows_count() -> None:
    # the run's noise fell (passes averaged, a quieter bench): the latest window resolves
    windows = [window(7.4, 1.0, 14.4)] * 5 + [window(1.0, 0.0, 3.5)]
    assert unresolved(windows, ACCEPTANCE) is None
    assert unresolved([*windows, *[window(7.4, 1.0, 14.4)] * 3], ACCEPTANCE) is not None
