"""How fast the TRUE split of random gyros moves on a simulated bench: mHz/min and ppm/h.

The numbers behind the trial of a rate prior in ppm of the frequency
(docs/studies/drift-estimator.md). For each gyro of ``--seeds`` on ``--bench`` (the benches of
``drift_population.py``), how fast its true split leaves zero in the minute after its
degenerate bias of B1 and B2 a minute into the bench's clock
(``window_floor.split_drift_mhz_per_min``), in mHz/min and in ppm of its frequency per hour.

    python examples/split_rates.py --bench lab --seeds 273-320
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
from drift_population import BENCHES, make_device, seeds
from window_floor import split_drift_mhz_per_min


def split_rate(seed: int, bench: str, at_s: float = 60.0) -> dict:
    """Gyro ``seed``'s true split rate on ``bench`` from its degenerate bias at ``at_s``."""
    device, _ = make_device(seed, bench)
    mhz_per_min = abs(split_drift_mhz_per_min(device, at_s))
    f = float(device.f0_hz)
    ppm_per_h = mhz_per_min * 1e-3 * 60.0 / f * 1e6  # Hz/h over the frequency
    return {"seed": seed, "frequency_hz": f, "mhz_per_min": mhz_per_min, "ppm_per_h": ppm_per_h}


def main(argv: list[str] | None = None) -> int:
    """Print one line per gyro and the medians and maxima."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--bench", choices=sorted(BENCHES), default="lab")
    parser.add_argument("--seeds", default="273-320")
    args = parser.parse_args(argv)
    rows = [split_rate(s, args.bench) for s in seeds(args.seeds)]
    for r in rows:
        print(
            f"gyro {r['seed']}: {r['frequency_hz']:8.0f} Hz, {r['mhz_per_min']:8.3f} mHz/min, "
            f"{r['ppm_per_h']:7.2f} ppm/h"
        )
    for key, unit in (("mhz_per_min", "mHz/min"), ("ppm_per_h", "ppm/h")):
        values = np.array([r[key] for r in rows])
        print(
            f"{unit}: median {np.median(values):.3g}, range {values.min():.3g}-{values.max():.3g}"
        )
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
