"""The split interval of one window is as wide as the fits scatter, not a hundred times wider.

Truth: the simulated gyro's undamped modal frequencies at the window's bias; the scatter is that
of fits to independent noise draws of the same window.
"""

from __future__ import annotations

import numpy as np
import pytest

from sysid_core import fit
from sysid_core.data.schema import experiment_from_measurement
from sysid_core.plugin.registry import get_registry
from sysid_core.tuning.confidence import split_interval

#: Random gyro 106 (28.3 kHz, input dynamics) near its degenerate bias: true split 2.0 mHz.
SEED = 106
BIAS = np.array([-4.8849, -5.0122, 0.0])
#: A lean verification window's offsets from the modes (Hz), as a run of this gyro placed it.
OFFSETS = np.array(
    [
        *(-50.07, -25.03, -10.01, -7.82, -6.67, -5.21, -3.33, -2.60, 0.02),
        *(2.63, 3.36, 5.25, 6.71, 7.86, 10.05, 25.06, 50.10),
    ]
)
DRAWS = 16


@pytest.mark.parametrize("noise", [1e-4, 1e-3])
def test_the_window_interval_matches_the_scatter_of_its_fits(noise: float) -> None:
    device = get_registry().device("random-gyro", seed=SEED, noise=noise)
    truth = device.true_modal_frequencies_hz(BIAS)
    true_split = float(truth[1] - truth[0])
    freqs = float(np.mean(truth)) + OFFSETS
    splits, reaches, covered = [], [], 0
    for _ in range(DRAWS):
        sweep = experiment_from_measurement(
            device.measure(BIAS, freqs),
            BIAS,
            list(device.electrodes),
            device.structure_potential,
            "random-gyro",
        )
        model = fit(sweep.isel(electrode=[]), structure=device.structure)
        f = model.modal([]).frequencies_hz
        low, high = split_interval(model)
        splits.append(float(f[1] - f[0]))
        reaches.append(high - splits[-1])
        covered += low <= true_split <= high
    scatter = float(np.sqrt(np.mean((np.array(splits) - true_split) ** 2)))
    # a 95 % reach of a 2-D ellipse is about 2.45 standard deviations of each component; it
    # was 60-200 mHz here (100x the scatter) while the Jacobian's step was sized by K0's
    # entries, which are ω² times M's
    assert np.median(reaches) <= 6.0 * scatter
    assert np.median(reaches) >= 1.0 * scatter
    assert covered >= DRAWS - 2  # 95 % intervals: at most 2 misses of 16 (p > 0.95)
