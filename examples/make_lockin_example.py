"""Make ``examples/lockin/``: the paper's three experiments as a lock-in amplifier exports them.

The same measurements as ``examples/measured/`` (``make_measured_example.py``: the simulated
cloverleaf, seed 2006, biases [0, 0], [1, 0] and [0, 1] V on B1, B2, 4385-4445 Hz at 0.5 Hz),
written the way a lock-in amplifier's sweeper exports them on a PC with a German locale: one
file per drive input (u1, then u2), fields separated by ``;``, decimal commas, one column pair
per demodulator (demodulator 1 reads output y1, demodulator 2 output y2): the magnitude ``R``
(volts; the drive is 1 V, so volts are V/V) and the phase ``Theta`` in degrees, and the filter
bandwidth, which the toolkit does not use. The manifest reads them with a column map
(docs/measured-data.md). Run::

    python examples/make_lockin_example.py [FOLDER]
"""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np
from sysid_cloverleaf.device import CloverleafGyro

HEADER = (
    "Frequency (Hz);Bandwidth (Hz);R Demod 1 (V);Theta Demod 1 (deg);R Demod 2 (V);"
    "Theta Demod 2 (deg)"
)
MANIFEST = """\
# The paper's three identification experiments on the simulated cloverleaf gyro (B3 held at
# 0 V), as a lock-in amplifier exports them; see examples/make_lockin_example.py.
device = "cloverleaf"
structure_potential_v = {vg}
electrodes = ["B1", "B2"]

[columns]
delimiter = ";"
decimal = ","
frequency = "Frequency (Hz)"
response_units = "V/V"  # the drive is 1 V: R in volts is |H| in V/V
y1 = {{ mag = "R Demod 1 (V)", phase_deg = "Theta Demod 1 (deg)" }}
y2 = {{ mag = "R Demod 2 (V)", phase_deg = "Theta Demod 2 (deg)" }}
"""


def number(value: float) -> str:
    """Every digit (so that the files read back to 1e-12), with a decimal comma."""
    return repr(float(value)).replace(".", ",")


def main(folder: Path) -> None:
    device = CloverleafGyro(seed=2006)
    freqs = np.linspace(4385.0, 4445.0, 121)
    folder.mkdir(parents=True, exist_ok=True)
    manifest = MANIFEST.format(vg=device.structure_potential)
    for k, bias in enumerate(([0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0])):
        h = device.measure(bias, freqs).values  # frequency x output x input, V/V
        for i in (0, 1):
            lines = [HEADER]
            for f, (z1, z2) in zip(freqs, h[:, :, i], strict=True):
                values = [f, 10.0, abs(z1), np.degrees(np.angle(z1))]
                values += [abs(z2), np.degrees(np.angle(z2))]
                lines.append(";".join(number(v) for v in values))
            (folder / f"exp{k}-u{i + 1}.csv").write_text("\n".join(lines) + "\n")
        manifest += (
            f"\n[[experiment]]\nbias_v = {bias[:2]}\n"
            f'files = {{ u1 = "exp{k}-u1.csv", u2 = "exp{k}-u2.csv" }}\n'
        )
    (folder / "manifest.toml").write_text(manifest)
    print(f"wrote {folder}/manifest.toml and 6 lock-in exports")


if __name__ == "__main__":
    main(Path(sys.argv[1]) if len(sys.argv) > 1 else Path(__file__).with_name("lockin"))
