"""What one verification window can tell a gyro's split, against how fast the lab drifts it.

    python examples/drift_population.py --bench lab --drift track --seeds 101-124 --iterations 8
    python examples/window_floor.py --runs runs/drift-population --seeds 101,108,120

For each gyro of a population run (``--runs``, the folder of ``examples/drift_population.py``)
one table row (docs/studies/drift-lab.md, "Where the fast gyros stop"):

* the split's drift: the TRUE split at the gyro's degenerate bias of one moment, a minute
  later, on the bench of the run (the uncontrolled lab: charging moves it, the temperature
  hardly; mHz per minute);
* one window: the window the run verified last, measured on a bench with a clock and no drift
  at 60 dB (``quiet``), at the DAC code whose true split is nearest ``--split`` mHz; its bench
  time by the clock (settling included);
* what ``--windows`` such windows measured: the split of each window's own fit (as the run fits
  a verification), and the split of the run's last model anchored on that window alone
  (:func:`sysid_core.identification.anchor.anchor`, an offset and no rate): the mean and the
  standard deviation of each, beside the true split.

A split whose windows scatter by σ (the smaller of the two scatters) needs about
``(σ / 1 mHz)²`` windows, at least one, to be known to 1 mHz; the last column is the split's
drift over the bench time they take.
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path
from typing import Any

import numpy as np
from scipy.optimize import minimize
from sysid_simgyro.device import modal_analysis

sys.path.insert(0, str(Path(__file__).resolve().parent))

from drift_population import make_device
from window_scatter import NOISE, bench_table, last_window, near_split

from sysid_core.api import load_model
from sysid_core.data.schema import experiment_from_measurement
from sysid_core.identification.anchor import anchor
from sysid_core.identification.reweighting import refit
from sysid_core.plugin.registry import get_registry

MINUTE = 60.0


def split_drift_mhz_per_min(device: Any, at_s: float) -> float:
    """How fast the true split leaves zero at the degenerate bias of time ``at_s`` (mHz/min).

    ``device``: a simulated gyro on a bench with a clock (a replica of a run's device). The
    degenerate bias at ``at_s`` is searched over B1 and B2 (the truth, not the DAC's codes),
    then held for a minute. Ask in time order: the temperature's walk is drawn as times are.
    """
    n = len(device.electrodes)
    start = np.asarray(device.true_degenerate_bias(), dtype=float)[:2]

    def split(b: np.ndarray, t: float) -> float:
        # the drifted truth at any bias, not only at the DAC's codes (true_split_hz rounds)
        k = device._drifted_stiffness(np.r_[b, np.zeros(n - 2)], np.array([t]))[0]
        f = modal_analysis(device.truth.M, device.truth.C, k)[0]
        return float(f[1] - f[0]) * 1e3

    best = minimize(
        lambda b: split(b, at_s),
        start,
        method="Nelder-Mead",
        options={"xatol": 1e-9, "fatol": 1e-9},
    )
    return split(best.x, at_s + MINUTE) - split(best.x, at_s)


def floor_row(seed: int, folder: Path, windows: int, split_hz: float) -> str:
    """The table row of gyro ``seed`` (see the module)."""
    freqs, center, bandwidths, config = last_window(folder)
    summary = json.loads((folder / "summary.json").read_text())
    model = load_model(sorted(folder.glob("iter*/model.nc"))[-1])
    registry = get_registry()
    device: Any = registry.device(
        "random-gyro", seed=seed, noise=NOISE, bench=bench_table("quiet", seed)
    )
    structure = registry.structure(
        config["structure"], order=config["order"], bias_terms=config["bias_terms"]
    )
    objective, solver = registry.objective("least-squares"), registry.solver("clarabel")
    bias = near_split(device, split_hz, device.true_degenerate_bias())
    true, own, anchored, spans = [], [], [], []
    for k in range(windows):
        grid = freqs + float(np.mean(device.true_modal_frequencies_hz(bias))) - center
        before = device.time_s
        if k:  # a bias change each time, as between verifications: the settling counts
            device.measure(bias + 10 * device.bias_resolution * np.eye(len(bias))[0], grid[:1])
            before = device.time_s
        true.append(device.true_split_hz(bias))
        response = device.measure(bias, grid)
        spans.append(device.time_s - before)
        ds = experiment_from_measurement(
            response, bias, device.electrodes, device.structure_potential, "random-gyro"
        )
        fitted, _ = refit(ds.isel(electrode=[]), structure, objective, solver)
        f = np.asarray(fitted.modal([]).frequencies_hz, dtype=float)
        own.append(f[1] - f[0])
        moved = anchor(model, [ds], rate=False).model_at(model, 0.0)
        tuned = np.asarray(ds.sel(electrode=list(model.electrodes))["bias"].values[0])
        g = np.asarray(moved.modal(tuned).frequencies_hz, dtype=float)
        anchored.append(g[1] - g[0])
    t, o, a = (np.array(v) * 1e3 for v in (true, own, anchored))
    lab, _ = make_device(seed, "lab")  # the run's own bench, draw 0
    rate = abs(split_drift_mhz_per_min(lab, 0.5 * float(summary["bench_time_s"] or 0.0)))
    window_min = float(np.median(spans)) / MINUTE
    # windows to know the split to 1 mHz, by the better of the two estimates
    needed = max(min(float(o.std(ddof=1)), float(a.std(ddof=1))) ** 2, 1.0)
    bw = " / ".join(f"{b:.2f}" for b in bandwidths)
    return (
        f"| {seed} | {device.f0_hz / 1e3:.1f} | {bw} | {rate:.2f} | {freqs.size} | "
        f"{window_min * MINUTE:.0f} | {t.mean():.2f} | {o.mean():.2f} ± {o.std(ddof=1):.2f} | "
        f"{a.mean():.2f} ± {a.std(ddof=1):.2f} | {rate * needed * window_min:.2g} |"
    )


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--runs", type=Path, default=Path("runs/drift-population"))
    parser.add_argument("--seeds", default="101,108", help="comma-separated gyro seeds")
    parser.add_argument("--windows", type=int, default=16, help="windows per gyro")
    parser.add_argument("--split", type=float, default=0.0, help="the true split (mHz)")
    args = parser.parse_args()
    if args.windows < 2:
        parser.error(f"--windows must be at least 2, got {args.windows}")
    try:
        chosen = [int(s) for s in args.seeds.split(",")]
    except ValueError:
        parser.error(
            f"--seeds must be comma-separated integers such as 101,108, got {args.seeds!r}"
        )
    print(
        "| gyro | kHz | bandwidths (Hz) | split drift (mHz/min) | window points | window (s) | "
        "true split (mHz) | window's own fit (mHz) | model anchored on it (mHz) | "
        "drift while windows reach 1 mHz (mHz) |"
    )
    print("|---|---|---|---|---|---|---|---|---|---|")
    for seed in chosen:
        folder = args.runs / f"gyro{seed}"
        if not (folder / "summary.json").is_file():
            parser.error(f"{folder} holds no run: run examples/drift_population.py first")
        print(floor_row(seed, folder, args.windows, args.split * 1e-3), flush=True)


if __name__ == "__main__":
    main()
