"""How well one window measures a fast gyro's split, bench by bench (docs/studies/drift-lab.md).

    python examples/drift_population.py --bench lab --drift track --seeds 101-124 --iterations 8
    python examples/window_scatter.py --runs runs/drift-population --seeds 101,106,108

For each gyro of a population run (``--runs``, the folder of ``examples/drift_population.py``),
the window that the run verified last (its frequencies, moved with the gyro's modes) is measured
``--windows`` times again on a fresh bench, at the DAC code near the gyro's degenerate bias whose
true split is nearest ``--split`` mHz (2, the population's acceptance), chosen again before
each window near the last (the drifts move it): ``quiet`` (60 dB, a clock, no drift), ``lab``
(the uncontrolled lab of drift_population.py), and the lab without one of its drifts (``lab
-walk``, ``-ramp``, ``-charging``, ``-wander``). Each window is fitted as the run fits a
verification (:meth:`sysid_core.measure.fitter.Fitter.window`: refitted with weights ``1/‖Z‖``), and
its split is compared with the TRUE split over the window (the mean of the true splits before
and after it). ``--design uniform`` measures the same number of points spread evenly over ±2 of
the wider bandwidth instead, ``--design core`` keeps the window's 4 far points and spreads the
others over ±1 of the wider bandwidth. One table row per gyro and bench: the bias of the
measured split (mean of measured minus true) and its scatter (standard deviation).
"""

from __future__ import annotations

import argparse
import json
from pathlib import Path
from typing import Any

import numpy as np
import xarray as xr

from sysid_core.data.schema import experiment_from_measurement
from sysid_core.identification.reweighting import refit
from sysid_core.plugin.registry import get_registry

LAB = {
    "temperature_ramp_k_per_h": 1.5,
    "temperature_walk_k_per_sqrt_h": 0.5,
    "charging_v_per_h": 0.015,
    "gain_wander": 0.003,
    "phase_wander_deg": 0.1,
}
WITHOUT = {
    "walk": ["temperature_walk_k_per_sqrt_h"],
    "ramp": ["temperature_ramp_k_per_h"],
    "charging": ["charging_v_per_h"],
    "wander": ["gain_wander", "phase_wander_deg"],
}
BENCHES = ["quiet", "lab", "lab -walk", "lab -ramp", "lab -charging", "lab -wander"]
NOISE = 1e-3  # 60 dB, as drift_population.py's lab and quiet benches


def bench_table(name: str, seed: int) -> dict:
    """The ``[device.bench]`` table of bench ``name`` (see the module)."""
    table: dict = {"clock": True, "seed": seed}
    if name == "quiet":
        return table
    table.update(LAB)
    table["temperature_ramp_k_per_h"] *= 1.0 if seed % 2 else -1.0  # as drift_population.py
    if name.startswith("lab -"):
        for key in WITHOUT[name.removeprefix("lab -")]:
            table[key] = 0.0
    return table


def last_window(folder: Path) -> tuple[np.ndarray, float, list[float], dict]:
    """A run's last verified window: its frequencies, the mean of its fitted modes and their
    bandwidths; and the run's ``[model]`` table."""
    summary = json.loads((folder / "summary.json").read_text())
    config = json.loads((folder / "config.json").read_text())["config"]
    windows = sorted(folder.glob("iter*/verify.nc"))
    if not windows:
        raise SystemExit(f"{folder} has no verify.nc: run examples/drift_population.py first")
    with xr.open_dataset(windows[-1]) as ds:
        freqs = np.asarray(ds["frequency"].values, dtype=float)
    evidence = [h["evidence"][-1] for h in summary["history"] if h["evidence"]]
    last = evidence[-1] if evidence else {}
    modes = last.get("frequencies_hz") or [float(np.median(freqs))]
    return freqs, float(np.mean(modes)), last.get("bandwidth_hz", []), config["model"]


def near_split(device: Any, split_hz: float, around: np.ndarray, reach: int = 8) -> np.ndarray:
    """The DAC code within ``reach`` codes of ``around`` (B1, B2) whose true split is nearest
    ``split_hz``."""
    exact = np.asarray(around, dtype=float)
    step = device.bias_resolution
    best, found = np.inf, exact
    for i in range(-reach, reach + 1):
        for j in range(-reach, reach + 1):
            bias = exact.copy()
            bias[:2] += step * np.array([i, j])
            applied = device.applied_bias(bias)
            f = device.true_modal_frequencies_hz(applied)
            if abs(f[1] - f[0] - split_hz) < best:
                best, found = abs(f[1] - f[0] - split_hz), applied
    return found


def designed(freqs: np.ndarray, bandwidths: list[float], design: str) -> np.ndarray:
    """The window's own frequencies, or ``design``'s with as many points (see the module)."""
    if design == "grid" or not bandwidths:
        return freqs
    center, wide, n = float(np.median(freqs)), float(max(bandwidths)), freqs.size
    if design == "uniform":
        return center + np.linspace(-2 * wide, 2 * wide, n)
    far = np.r_[freqs[:2], freqs[-2:]]
    return np.sort(np.r_[far, center + np.linspace(-wide, wide, n - far.size)])


def scatter(seed: int, folder: Path, bench: str, windows: int, design: str, split_hz: float) -> str:
    """The table row of gyro ``seed`` on ``bench``."""
    freqs, center, bandwidths, model = last_window(folder)
    registry = get_registry()
    device = registry.device("random-gyro", seed=seed, noise=NOISE, bench=bench_table(bench, seed))
    grid = designed(freqs, bandwidths, design)
    structure = registry.structure(
        model["structure"], order=model["order"], bias_terms=model["bias_terms"]
    )
    objective, solver = registry.objective("least-squares"), registry.solver("clarabel")
    true, measured = [], []
    bias = device.true_degenerate_bias()
    for _ in range(windows):
        bias = near_split(device, split_hz, bias)  # followed as the drifts move the gyro
        freqs = grid + float(np.mean(device.true_modal_frequencies_hz(bias))) - center
        before = device.true_modal_frequencies_hz(bias)
        response = device.measure(bias, freqs)
        after = device.true_modal_frequencies_hz(bias)
        ds = experiment_from_measurement(
            response, bias, device.electrodes, device.structure_potential, "random-gyro"
        )
        fitted, _ = refit(ds.isel(electrode=[]), structure, objective, solver)
        modes = np.asarray(fitted.modal([]).frequencies_hz, dtype=float)
        true.append(0.5 * (before[1] - before[0] + after[1] - after[0]))
        measured.append(modes[1] - modes[0])
    t, m = np.array(true) * 1e3, np.array(measured) * 1e3
    error = m - t
    kind = f"{device.f0_hz / 1e3:.1f} kHz, bw {' / '.join(f'{b:.2f}' for b in bandwidths)} Hz"
    return (
        f"| {seed} ({kind}) | {bench} | {freqs.size} | {t.mean():.2f} | {error.mean():+.2f} | "
        f"{error.std(ddof=1):.2f} |"
    )


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--runs", type=Path, default=Path("runs/drift-population"))
    parser.add_argument("--seeds", default="101,106,108", help="comma-separated gyro seeds")
    parser.add_argument("--windows", type=int, default=30, help="windows per gyro and bench")
    parser.add_argument("--benches", default=",".join(BENCHES))
    parser.add_argument("--design", choices=["grid", "uniform", "core"], default="grid")
    parser.add_argument("--split", type=float, default=2.0, help="the true split to measure (mHz)")
    args = parser.parse_args()
    if args.windows < 2:
        parser.error(f"--windows must be at least 2, got {args.windows}")
    benches = [b.strip() for b in args.benches.split(",")]
    unknown = [b for b in benches if b not in BENCHES]
    if unknown:
        parser.error(f"unknown bench {unknown[0]!r}; choose from {', '.join(BENCHES)}")
    print(
        "| gyro | bench | points | true split (mHz, mean) | measured − true: mean (mHz) | "
        "standard deviation (mHz) |"
    )
    print("|---|---|---|---|---|---|")
    try:
        chosen = [int(s) for s in args.seeds.split(",")]
    except ValueError:
        parser.error(
            f"--seeds must be comma-separated integers such as 101,106, got {args.seeds!r}"
        )
    for seed in chosen:
        folder = args.runs / f"gyro{seed}"
        if not (folder / "summary.json").is_file():
            parser.error(f"{folder} holds no run: run examples/drift_population.py first")
        for bench in benches:
            print(
                scatter(seed, folder, bench, args.windows, args.design, args.split * 1e-3),
                flush=True,
            )


if __name__ == "__main__":
    main()
