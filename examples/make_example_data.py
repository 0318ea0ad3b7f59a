"""Make ``examples/cloverleaf-3exp.nc``: the paper's three identification experiments.

The simulated cloverleaf gyro (default noise, feedthrough, extra modes, DAC) is measured at the
biases of eqs. (11)-(13), [0, 0], [1, 0] and [0, 1] V on electrodes B1, B2 (B3 held at 0 V),
4385-4445 Hz at 0.5 Hz (121 points each). Run::

    python examples/make_example_data.py [OUT.nc]
"""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np
from sysid_cloverleaf.device import CloverleafGyro

from sysid_core.data.schema import concat_experiments, experiment_from_measurement, save_dataset


def main(out: Path) -> None:
    device = CloverleafGyro(seed=2006)
    freqs = np.linspace(4385.0, 4445.0, 121)
    parts = []
    for bias in ([0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]):
        da = device.measure(bias, freqs)
        parts.append(
            experiment_from_measurement(
                da, bias, device.electrodes, device.structure_potential, device="cloverleaf"
            )
        )
    ds = concat_experiments(parts).sel(electrode=["B1", "B2"])
    ds.attrs["held_bias"] = '{"B3": 0.0}'
    save_dataset(ds, out)
    print(f"wrote {out}: {ds.sizes['experiment']} experiments x {ds.sizes['frequency']} points")


if __name__ == "__main__":
    main(Path(sys.argv[1]) if len(sys.argv) > 1 else Path(__file__).with_name("cloverleaf-3exp.nc"))
