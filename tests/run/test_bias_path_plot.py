"""The bias path plot stays readable when the first answers are very uncertain.

A first answer's region can reach tens of volts past the limits (an extrapolating first fit):
the axis still shows the allowed bias, and only the last answer's half-widths are written (the
labels of every iteration overlapped where the biases settle).
"""

from __future__ import annotations

import numpy as np

from sysid_core.run.plots import bias_path_figure
from sysid_core.tuning.criteria import ConfidenceRegion


def _region(b: list[float], half: float) -> ConfidenceRegion:
    ci = np.array([[v - half, v + half] for v in b])
    return ConfidenceRegion(0.95, ci, (0.0, 1.0), (4430.0, 4431.0), 200)


def test_wide_early_regions_keep_the_limits_in_view_and_one_label_per_electrode() -> None:
    path = [[0.0, 0.0], [-0.4, -6.3], [-4.2, -4.7], [-4.72, -4.75], [-4.7217, -4.7549]]
    halves = [24.0, 8.0, 0.05, 0.003]
    regions = [_region(b, h) for b, h in zip(path[1:], halves, strict=True)]
    fig = bias_path_figure(
        path, [5.4, 0.55, 0.053, 0.0003], ["B1", "B2"], (-10.0, 10.0), 0.002, regions
    )
    ax = fig.axes[0]
    low, high = ax.get_ylim()
    assert -13.5 < low < -10.0 and 10.0 < high < 13.5
    labels = [t.get_text() for t in ax.texts]
    assert labels == ["±3 mV", "±3 mV"]
