"""How well one verification window measures a split, by its frequencies and by its fit.

    python examples/window_designs.py --seed 205 --bias 1.7242,4.2841 --windows 30

Random gyro ``--seed`` at ``--bias`` (B1, B2; the others at 0 V) on a bench with a clock and
no drift at 60 dB: ``--windows`` windows of each design are measured and fitted as a run fits a
verification (:meth:`sysid_core.measure.fitter.Fitter.window`); the row gives the mean split
and the scatter per component of the split vector, ``√((mean(s²) − s_true²) / 2)`` (the split
of a noisy pair reads high, so its scatter is taken from its square). The designs, 16 points
each, around the true modes (``bw`` the wider mode's half-power bandwidth):

* ``run``: the window a lean run verifies with (``lean.mode_grid`` with ``resolve``);
* ``uniform 1.5 bw`` and ``uniform 3 bw``: 16 points evenly over ±1.5 and ±3 bandwidths;
* ``uniform + far``: 12 evenly over ±1.5 bandwidths and the run's four far points.

Then the same ``run`` windows refitted by output error (a Levenberg-Marquardt polish of the
window's mass, damping, stiffness and polynomial on the weighted response; the mass's first
entry held, the scale): whether the run's equation-error fit loses information a fit by the
response would keep. One table row per design (docs/studies/bench-floor.md).
"""

from __future__ import annotations

import argparse
import dataclasses

import numpy as np
import xarray as xr
from scipy.optimize import least_squares

from sysid_core.data.schema import experiment_from_measurement
from sysid_core.measure.fitter import Fitter
from sysid_core.measure.lean import ModeGuess, mode_grid
from sysid_core.model.fitted import FittedModel
from sysid_core.plugin.registry import get_registry
from sysid_core.run.config import ExperimentConfig


def polish(model: FittedModel, ds: xr.Dataset) -> FittedModel:
    """``model`` refitted by output error on ``ds`` (one experiment, no electrodes)."""
    f = ds["frequency"].values
    psi = ds["response"].values[0]
    weight = 1 / np.sqrt(ds["noise_var"].values[0]) if "noise_var" in ds else np.ones(psi.shape)
    poly, scale = model.poly, float(np.abs(model.K0).max())

    def unpack(x: np.ndarray) -> FittedModel:
        m = np.array([[model.M[0, 0], x[0]], [x[0], x[1]]])
        c = np.array([[x[2], x[3]], [x[3], x[4]]])
        k = np.array([[x[5], x[6]], [x[6], x[7]]]) * scale
        p = (x[8 : 8 + poly.size] + 1j * x[8 + poly.size :]).reshape(poly.shape)
        return dataclasses.replace(model, M=m, C=c, K0=k, poly=p)

    m, c, k = model.M, model.C, model.K0 / scale
    x0 = np.r_[m[0, 1], m[1, 1], c[0, 0], c[0, 1], c[1, 1], k[0, 0], k[0, 1], k[1, 1]]
    x0 = np.r_[x0, poly.real.ravel(), poly.imag.ravel()]

    def residual(x: np.ndarray) -> np.ndarray:
        r = (unpack(x).response(f, []) - psi) * weight
        return np.r_[r.real.ravel(), r.imag.ravel()]

    return unpack(least_squares(residual, x0, x_scale="jac", method="lm", max_nfev=2000).x)


def main() -> None:
    """Measure every design ``--windows`` times; print the table."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seed", type=int, default=205)
    parser.add_argument("--bias", default="1.7242,4.2841", help="B1,B2 in volts")
    parser.add_argument("--windows", type=int, default=30)
    args = parser.parse_args()
    reg = get_registry()
    bench = {"clock": True, "seed": args.seed, "tones": 8}
    device = reg.device("random-gyro", seed=args.seed, noise=1e-3, bench=bench)
    names = list(device.electrodes)
    bias = np.zeros(len(names))
    bias[:2] = [float(v) for v in args.bias.split(",")]
    fitter = Fitter(
        reg.structure(device.structure), reg.objective("least-squares"), reg.solver("clarabel")
    )
    modes = np.asarray(device.true_modal_frequencies_hz(bias), dtype=float)
    true_split, fc = float(modes[1] - modes[0]), float(modes.mean())

    def measure(freqs: np.ndarray) -> xr.Dataset:
        da = device.measure(bias, np.sort(freqs))
        return experiment_from_measurement(da, bias, names, device.structure_potential, "random")

    # the run's window: from a first window's fitted modes and bandwidths
    plan = ExperimentConfig().sweep_plan(device.band_hz, tones=8)
    scout = fc + np.linspace(-30.0, 30.0, 61)
    _, evidence = fitter.window(measure(scout), band=False)
    bw = np.asarray(evidence.bandwidth_hz, dtype=float)
    guess = ModeGuess.of(np.asarray(evidence.frequencies_hz, dtype=float), bw, 0.0)
    run = np.unique(mode_grid(guess, plan, resolve=True))
    far = run[np.abs(run - fc) > 5 * float(bw.max())]
    wide = float(bw.max())
    designs = {
        "run": run,
        "uniform 1.5 bw": fc + np.linspace(-1.5, 1.5, 16) * wide,
        "uniform 3 bw": fc + np.linspace(-3.0, 3.0, 16) * wide,
        "uniform + far": np.r_[fc + np.linspace(-1.5, 1.5, 16 - far.size) * wide, far],
    }
    print(
        f"gyro {args.seed}: {fc / 1e3:.1f} kHz, bandwidths {bw[0]:.2f} / {bw[1]:.2f} Hz, "
        f"true split {true_split * 1e3:.3f} mHz, {args.windows} windows each"
    )
    print("| design | points | mean split (mHz) | scatter per component (mHz) |")
    print("|---|---|---|---|")

    def row(name: str, splits: list[float], points: int) -> None:
        s = np.asarray(splits)
        scatter = np.sqrt(max(float(np.mean(s**2)) - true_split**2, 0.0) / 2)
        print(f"| {name} | {points} | {s.mean() * 1e3:.2f} | {scatter * 1e3:.2f} |", flush=True)

    polished: list[float] = []
    for name, freqs in designs.items():
        splits = []
        for _ in range(args.windows):
            ds = measure(freqs)
            model, found = fitter.window(ds, band=False)
            splits.append(found.split_hz)
            if name == "run":
                polished.append(polish(model, ds.isel(electrode=[])).split_hz([]))
        row(name, splits, freqs.size)
    row("run, refitted by output error", polished, run.size)


if __name__ == "__main__":
    main()
