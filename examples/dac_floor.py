"""The smallest true split a bias DAC can reach on each random gyro (docs/studies/drift-lab.md).

    python examples/dac_floor.py --seeds 101-124 301-324 401-424 501-524

A device with a DAC applies only its codes (``random-gyro``: 16 bits over ±10 V, a step of
0.31 mV). Near the exact degenerate bias the split changes by up to several mHz per code on a
fast gyro, so even a perfect model leaves the split of the best code. For each gyro (frozen, no
noise) this searches the codes within ``--reach`` steps of its exact degenerate bias on B1 and
B2 (every other electrode at 0 V, as the populations tune it) and prints the least true split,
the gyro's mean frequency and how much one code of B1 and of B2 moves the split there; then,
per set, how many gyros have a floor over 0.5 and over 1 mHz. ``--dac-bits`` sets the DAC;
``--third`` searches the codes of B3 as well (gyros with only two electrodes are skipped).
"""

from __future__ import annotations

import argparse
import itertools
from typing import Any

import numpy as np

from sysid_core.plugin.registry import get_registry


def seeds(text: str) -> list[int]:
    """``"101-124"`` or ``"7"`` as a list of seeds."""
    first, _, last = text.partition("-")
    return list(range(int(first), int(last or first) + 1))


def split_hz(device: Any, bias: np.ndarray) -> float:
    """The true split (Hz) at the code the device applies for ``bias``."""
    f = device.true_modal_frequencies_hz(device.applied_bias(bias))
    return float(f[1] - f[0])


def floor(device: Any, reach: int, electrodes: int = 2) -> tuple[float, float, float]:
    """The least true split within ``reach`` codes of the first ``electrodes`` electrodes (Hz),
    and the split one code of B1 and of B2 moves it by at the exact degenerate bias (Hz)."""
    exact = np.asarray(device.true_degenerate_bias(), dtype=float)
    step = float(device.bias_resolution)
    best = np.inf
    for codes in itertools.product(range(-reach, reach + 1), repeat=electrodes):
        bias = exact.copy()
        bias[:electrodes] += step * np.array(codes)
        best = min(best, split_hz(device, bias))
    slopes = []
    for k in range(2):
        bias = exact.copy()
        bias[k] += step
        f = device.true_modal_frequencies_hz(bias)
        slopes.append(float(f[1] - f[0]))
    return best, slopes[0], slopes[1]


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seeds", nargs="+", default=["101-124"], help="ranges such as 101-124")
    parser.add_argument("--reach", type=int, default=3, help="codes searched on either side")
    parser.add_argument("--dac-bits", type=int, default=None, help="the DAC's bits (16)")
    parser.add_argument("--third", action="store_true", help="search B3's codes as well")
    args = parser.parse_args()
    if args.reach < 1:
        parser.error(f"--reach must be at least 1, got {args.reach}")
    registry = get_registry()
    options = {} if args.dac_bits is None else {"dac_bits": args.dac_bits}
    print("| gyro | kHz | floor (mHz) | one code of B1, B2 moves the split (mHz) |")
    print("|---|---|---|---|")
    summary = []
    for text in args.seeds:
        floors = []
        try:
            chosen = seeds(text)
        except ValueError:
            parser.error(f"--seeds takes ranges such as 101-124 or single seeds, got {text!r}")
        for seed in chosen:
            device = registry.device("random-gyro", seed=seed, **options)
            if device.bias_resolution is None:
                parser.error("the DAC applies every bias exactly (--dac-bits 0): no floor")
            if args.third and len(device.electrodes) < 3:
                continue
            least, b1, b2 = floor(device, args.reach, 3 if args.third else 2)
            floors.append(least * 1e3)
            f = float(np.mean(device.true_modal_frequencies_hz(device.true_degenerate_bias())))
            print(
                f"| {seed} | {f / 1e3:.1f} | {least * 1e3:.2f} | {b1 * 1e3:.2f}, {b2 * 1e3:.2f} |",
                flush=True,
            )
        x = np.array(floors or [np.nan])
        summary.append(
            f"| {text} ({len(floors)} gyros) | {int(np.sum(x > 0.5))} | {int(np.sum(x > 1.0))} | "
            f"{np.nanmax(x):.2f} |"
        )
    print()
    print("| gyros | floor over 0.5 mHz | over 1 mHz | largest (mHz) |")
    print("|---|---|---|---|")
    print("\n".join(summary))


if __name__ == "__main__":
    main()
