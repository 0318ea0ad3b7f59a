"""Tune random gyros on drifting benches; print a table row (docs/studies/drift-lab.md).

    python examples/drift_population.py --bench lab --drift none --seeds 101-124 --out runs/pop

Each gyro (``random-gyro``, one device seed each) is tuned, with the model structure that
matches its dynamics (``act`` or ``sen``), from 0 V to degenerate modes with B1 and B2
(acceptance 2 mHz, up to 4 iterations) on a simulated bench with a clock and the drifts of
``--bench``: ``lab`` (an uncontrolled lab: ±1.5 K/h ramp, the sign alternating with the
seed, 0.5 K/√h walk, 15 mV/h charging, 0.3 % / 0.1° analyzer wander, 60 dB SNR), ``good``
(0.2 K/h, 0.05 K/√h) or ``quiet`` (a clock without drift, 60 dB SNR). The judge is the gyro's
true split at the end of the run, which the run never sees. One JSON line per gyro goes to
``<out>/runs.jsonl``, then the table row. ``--experiment '{"locate_points": 21}'`` adds
``[experiment]`` keys to every run; ``--noise 1e-4`` sets the device's noise (80 dB) and
``--dac-bits 20`` its bias DAC (16 bits over ±10 V by default); ``--electrodes 3`` tunes with
B1, B2 and B3 (a gyro with two electrodes uses both; of more than two, the pair the run chooses
unless ``--every-electrode``). ``--draw K`` (K ≥ 1) tunes the
same gyros with another draw of the measurement noise and of the bench's drifts (the device's
``noise_seed = K``, the bench's seed ``seed + 100000 K``): two draws of the same code differ by
what a comparison of two codes must beat (docs/studies/drift-lab.md).
"""

from __future__ import annotations

import argparse
import json
import shutil
import sys
from pathlib import Path
from typing import Any

import numpy as np

from sysid_core import tune
from sysid_core.errors import SysidError
from sysid_core.plugin.registry import get_registry

BENCHES = {
    "lab": {
        "temperature_ramp_k_per_h": 1.5,
        "temperature_walk_k_per_sqrt_h": 0.5,
        "charging_v_per_h": 0.015,
        "gain_wander": 0.003,
        "phase_wander_deg": 0.1,
    },
    "good": {"temperature_ramp_k_per_h": 0.2, "temperature_walk_k_per_sqrt_h": 0.05},
    "quiet": {"temperature_ramp_k_per_h": 0.0},  # a clock, no drift
}
NOISE = {"lab": 1e-3, "good": None, "quiet": 1e-3}  # 60 dB SNR in the lab and the quiet bench
ACCEPTANCE = 0.002
DRAW_STRIDE = 100_000  # --draw K: the bench's seed is the gyro's plus K times this


def seeds(text: str) -> list[int]:
    """``101-124`` or ``1,5,9``."""
    if "-" in text:
        lo, hi = text.split("-")
        return list(range(int(lo), int(hi) + 1))
    return [int(s) for s in text.split(",")]


def make_device(
    seed: int,
    bench: str,
    tones: int = 1,
    noise: float | None = None,
    dac_bits: int | None = None,
    draw: int = 0,
    start_min: float = 0.0,
    reach: float | None = None,
) -> tuple[Any, dict]:
    """Gyro ``seed`` on ``bench`` (its drifts' draw ``draw``) and the device options it took.

    ``start_min``: the bench's clock starts that many minutes into its drifts (``start_s``);
    ``reach``: how far into its limits the gyro's degenerate bias may lie (the device's option).
    The same arguments give a replica of a population run's device (the same seeds).
    """
    sign = 1.0 if seed % 2 else -1.0
    table = {"clock": True, "seed": seed + DRAW_STRIDE * draw, "tones": tones, **BENCHES[bench]}
    table["temperature_ramp_k_per_h"] *= sign
    if start_min:
        table["start_s"] = 60.0 * start_min
    options: dict = {"seed": seed, "bench": table}
    noise = NOISE[bench] if noise is None else noise
    if noise is not None:
        options["noise"] = noise
    if dac_bits is not None:
        options["dac_bits"] = dac_bits
    if draw:
        options["noise_seed"] = draw
    if reach is not None:
        options["reach"] = reach
    return get_registry().device("random-gyro", **options), options


def one(
    seed: int,
    bench: str,
    drift: str,
    out: Path,
    iterations: int = 4,
    tones: int = 1,
    max_passes: int | None = None,
    experiment: dict | None = None,
    noise: float | None = None,
    dac_bits: int | None = None,
    draw: int = 0,
    electrodes: int = 2,
    start_min: float = 0.0,
    reach: float | None = None,
    pair: bool = True,
) -> dict:
    """Tune gyro ``seed``; its record (true split at the end, claim, points, bench time)."""
    device, options = make_device(seed, bench, tones, noise, dac_bits, draw, start_min, reach)
    config = {
        "device": {"name": "random-gyro", **{k: v for k, v in options.items() if k != "bench"}},
        "model": {"drift": drift, "structure": device.structure},
        "tuning": {
            "criterion": "degenerate",
            "electrodes": list(device.electrodes[: max(electrodes, 2)]),
            "pair": pair,
            "start_bias": [0.0] * len(device.electrodes),
            "acceptance_hz": ACCEPTANCE,
            # 0: the defaults, the bench-time budget ends a long run
            **({"max_iterations": iterations} if iterations else {}),
        },
        "experiment": {
            **(experiment or {}),
            **({} if max_passes is None else {"max_passes": max_passes}),
        },
    }
    folder = out / f"gyro{seed}"
    shutil.rmtree(folder, ignore_errors=True)
    try:
        result = tune(config, folder, plots=False, device=device)
    except SysidError as exc:
        return {"seed": seed, "error": str(exc)}
    f = device.true_modal_frequencies_hz(result.bias)
    return {
        "seed": seed,
        "frequency_hz": float(f.mean()),
        "true_end_split_hz": float(f[1] - f[0]),
        "measured_split_hz": result.split_hz,
        "converged": result.converged,
        "points": result.points,
        "bench_time_s": result.bench_time_s,
    }


def progress(record: dict, done: int, total: int) -> str:
    """One line per finished gyro, for the terminal (the table comes at the end)."""
    head = f"[{done}/{total}] gyro {record['seed']}:"
    if "error" in record:
        return f"{head} error: {record['error']}"
    return (
        f"{head} {record['frequency_hz'] / 1e3:.1f} kHz, true split "
        f"{record['true_end_split_hz'] * 1e3:.3g} mHz at the end "
        f"({'converged' if record['converged'] else 'not converged'}), "
        f"{record['bench_time_s'] / 3600:.2f} h of bench time"
    )


def row(bench: str, drift: str, records: list[dict]) -> str:
    """The table row: true end split percentiles, within 2 mHz, false claims, bench time."""
    ok = [r for r in records if "error" not in r]
    end = np.array([r["true_end_split_hz"] * 1e3 for r in ok])
    false = sum(r["converged"] and r["true_end_split_hz"] > 2 * ACCEPTANCE for r in ok)
    within = int(np.sum(end <= ACCEPTANCE * 1e3))
    p50, p90 = np.percentile(end, [50, 90]) if end.size else (np.nan, np.nan)
    hours = np.median([r["bench_time_s"] for r in ok]) / 3600 if ok else np.nan
    points = np.median([r["points"] for r in ok]) if ok else np.nan
    return (
        f"| {bench} | `{drift}` | {within}/{len(records)} | {p50:.2f} / {p90:.2f} / "
        f"{end.max() if end.size else np.nan:.3g} | {sum(r['converged'] for r in ok)} | {false} | "
        f"{len(records) - len(ok)} | {points:.0f} | {hours:.2f} |"
    )


def main() -> None:
    """Parse the arguments, tune every gyro, print the row."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--bench", choices=sorted(BENCHES), default="lab")
    parser.add_argument("--drift", default="none", choices=["auto", "none", "track"])
    parser.add_argument("--seeds", default="101-124")
    parser.add_argument(
        "--iterations", type=int, default=4, help="max_iterations (4; 0: the default cap)"
    )
    parser.add_argument("--tones", type=int, default=1, help="tones per acquisition (1)")
    parser.add_argument(
        "--max-passes", type=int, default=None, help="[experiment] max_passes (its default)"
    )
    parser.add_argument(
        "--experiment", type=json.loads, default=None, help="more [experiment] keys, as JSON"
    )
    parser.add_argument(
        "--noise",
        type=float,
        default=None,
        help="the device's noise, relative to its peak (the bench's: 1e-3, 60 dB, in the lab)",
    )
    parser.add_argument(
        "--dac-bits", type=int, default=None, help="the bias DAC's bits over ±10 V (16; 0: exact)"
    )
    parser.add_argument(
        "--draw",
        type=int,
        default=0,
        help="another draw of the noise and the drifts for the same gyros (0: the seeds' own)",
    )
    parser.add_argument(
        "--start-min",
        type=float,
        default=0.0,
        help="start every run that many minutes into the bench's drifts ([device.bench] start_s)",
    )
    parser.add_argument(
        "--electrodes",
        type=int,
        default=2,
        help="tune with the first N electrodes (B1, B2, ...; a gyro with fewer uses all it has)",
    )
    parser.add_argument(
        "--reach",
        type=float,
        default=None,
        help="how far into its ±10 V limits each gyro's degenerate bias may lie (0.6; up to 1)",
    )
    parser.add_argument(
        "--every-electrode",
        action="store_true",
        help="tune every electrode given from the start ([tuning] pair = false)",
    )
    parser.add_argument("--out", type=Path, default=Path("runs/drift-population"))
    args = parser.parse_args()
    if args.draw < 0:
        parser.error(f"--draw must be a non-negative integer, got {args.draw}")
    if not args.start_min >= 0:
        parser.error(f"--start-min must be a non-negative number of minutes, got {args.start_min}")
    if args.electrodes < 2:
        parser.error(
            f"--electrodes must be at least 2 (degenerate modes need two), got {args.electrodes}"
        )
    args.out.mkdir(parents=True, exist_ok=True)
    records = []
    with (args.out / "runs.jsonl").open("w") as log:
        which = seeds(args.seeds)
        for seed in which:
            records.append(
                one(
                    seed,
                    args.bench,
                    args.drift,
                    args.out,
                    args.iterations,
                    args.tones,
                    args.max_passes,
                    args.experiment,
                    args.noise,
                    args.dac_bits,
                    args.draw,
                    args.electrodes,
                    args.start_min,
                    args.reach,
                    not args.every_electrode,
                )
            )
            log.write(json.dumps(records[-1]) + "\n")
            log.flush()
            print(progress(records[-1], len(records), len(which)), file=sys.stderr, flush=True)
    print(
        "| bench | drift | within 2 mHz | true end split p50 / p90 / max (mHz) | converged | "
        "converged over 4 mHz | errors | points (median) | bench time (median, h) |"
    )
    print("|---|---|---|---|---|---|---|---|---|")
    print(row(args.bench, args.drift, records))


if __name__ == "__main__":
    main()
