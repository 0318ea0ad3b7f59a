"""Make ``examples/measured/``: the paper's three experiments as CSV response files and a manifest.

The same measurements as ``examples/cloverleaf-3exp.nc`` (``make_example_data.py``): the simulated
cloverleaf gyro, seed 2006, at the biases of eqs. (11)-(13), [0, 0], [1, 0] and [0, 1] V on
electrodes B1, B2 (B3 held at 0 V), 4385-4445 Hz at 0.5 Hz. Each sweep is written as one CSV file,
the way an instrument's export would be, and the manifest by hand. Run::

    python examples/make_measured_example.py [FOLDER]
"""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np
from sysid_cloverleaf.device import CloverleafGyro

from sysid_core.formats.sweepfiles import write_sweep


def main(folder: Path) -> None:
    device = CloverleafGyro(seed=2006)
    freqs = np.linspace(4385.0, 4445.0, 121)
    lines = [
        "# The paper's three identification experiments on the simulated cloverleaf gyro",
        "# (B3 held at 0 V); see examples/make_measured_example.py.",
        'device = "cloverleaf"',
        f"structure_potential_v = {device.structure_potential}",
        'electrodes = ["B1", "B2"]',
    ]
    for k, bias in enumerate(([0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0])):
        sweep = device.measure(bias, freqs)  # frequency x output x input, units V/V
        write_sweep(folder / f"exp{k}.csv", sweep)
        lines += ["", "[[experiment]]", f"bias_v = {bias[:2]}", f'file = "exp{k}.csv"']
    (folder / "manifest.toml").write_text("\n".join(lines) + "\n")
    print(f"wrote {folder}/manifest.toml and 3 CSV files")


if __name__ == "__main__":
    main(Path(sys.argv[1]) if len(sys.argv) > 1 else Path(__file__).with_name("measured"))
