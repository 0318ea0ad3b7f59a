"""Replay a tracked run's verdict forecast at chosen looks, with and without pooled variances.

    python examples/forecast_replay.py runs/looks/good1/run749 --looks 50-53

For each look (an iteration of the run folder), the windows the run's tracker would read (every
verified window up to that iteration whose least split is under ten acceptances; the run's
resets and refreshed windows are not replayed) are filtered as
:func:`sysid_core.drift.forecast.windows_forecast` does, at the end of that iteration's window,
against its ``model-now.nc``: with every window's own variance, with the variances pooled by
bias under the stated trend (``LAB_TREND`` as it is), and pooled with the trend the windows
choose (what a run does). Each line gives the forecast split at the window's bias, its
σ per component, the 95 % bound, and the trend the windows chose (``λ``, ``τ_r``). Then, for
the windows at the last look's bias, each one's split, stated σ and squared error against their
mean over its stated variance (1 expected). The tables of docs/studies/repeated-looks.md come
from this script.
"""

from __future__ import annotations

import argparse
import dataclasses
from pathlib import Path
from unittest import mock

import numpy as np

from sysid_core.api import load_model
from sysid_core.clock.runclock import stamps
from sysid_core.data.schema import load_dataset, requested_bias
from sysid_core.drift import forecast as windows
from sysid_core.drift.looks import split_bound
from sysid_core.drift.tracker import NEAR_ACCEPTANCES
from sysid_core.drift.windows import least_split
from sysid_core.model.modal import split_vector_hz


def span(text: str) -> list[int]:
    """``"50-53"`` or ``"53"`` as iterations."""
    lo, _, hi = text.partition("-")
    return list(range(int(lo), int(hi or lo) + 1))


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("run", type=Path, help="a run folder (summary.json, iterNN/)")
    parser.add_argument("--looks", type=span, required=True, help="iterations, e.g. 50-53")
    parser.add_argument("--acceptance", type=float, default=1e-3, help="Hz (1e-3)")
    args = parser.parse_args()
    near = NEAR_ACCEPTANCES * args.acceptance
    kept = []
    for it in range(1, max(args.looks) + 1):
        folder = args.run / f"iter{it:02d}"
        if not (folder / "verify-model.nc").exists():
            continue
        own = load_model(folder / "verify-model.nc")
        split = own.split_hz([])
        if least_split(split, own) <= near:
            kept.append((it, load_dataset(folder / "verify.nc"), own))
    print(
        "look | windows | own variances: split ± σ, bound | pooled, the stated trend: split ± σ, "
        "bound | pooled, the trend the windows choose: split ± σ, bound, λ, τ_r"
    )
    for look in args.looks:
        chosen = [(sweep, own) for it, sweep, own in kept if it <= look]
        if not chosen or not (args.run / f"iter{look:02d}" / "model-now.nc").exists():
            continue
        model = load_model(args.run / f"iter{look:02d}" / "model-now.nc")
        sweep = chosen[-1][0]
        end = float(stamps(sweep).max())
        bias = np.asarray(sweep.sel(electrode=list(model.electrodes))["bias"].values[0])
        row = [f"{look}", f"{len(chosen)}"]
        for pooled, fitted in ((False, True), (True, False), (True, True)):
            keep = windows.pooled_by_bias if pooled else (lambda s, v: list(v))
            trend = windows.fitted_trend if fitted else (lambda *a: a[3])
            with (
                mock.patch.object(windows, "pooled_by_bias", keep),
                mock.patch.object(windows, "fitted_trend", trend),
            ):
                offset, found = windows.windows_forecast(model, model, chosen, end)
            at = dataclasses.replace(model, K0=np.asarray(model.K0) + offset)
            mean = float(np.hypot(*split_vector_hz(at.M, at.stiffness(bias))))
            sigma = found.sigma_hz
            bound = split_bound(mean, sigma, 1)  # the first look's: 95 %
            row.append(f"{mean * 1e3:.3f} ± {sigma * 1e3:.3f} mHz, {bound * 1e3:.3f}")
            if pooled and fitted:
                chosen_trend = found.trend
                row.append(
                    f"λ {chosen_trend.window_variance_scale:.3g}, "
                    f"τ_r {chosen_trend.rate_change_s:g} s"
                )
        print(" | ".join(row))
    last = max(it for it, _, _ in kept if it <= max(args.looks))
    code = tuple(requested_bias(next(s for it, s, _ in kept if it == last)))
    same = [(it, own) for it, sweep, own in kept if tuple(requested_bias(sweep)) == code]
    vectors = np.array([split_vector_hz(own.M, own.K0) for _, own in same])
    mean = vectors.mean(axis=0)
    print(f"\nwindows at the last look's bias: {len(same)}")
    print("iteration | split (mHz) | stated σ (mHz) | squared error over stated variance")
    for (it, own), vector in zip(same, vectors, strict=True):
        sigma = float(np.sqrt(windows.split_variance(own)))
        error = float(np.sum((vector - mean) ** 2)) / (2 * sigma**2)
        print(f"{it} | {own.split_hz([]) * 1e3:.3f} | {sigma * 1e3:.3f} | {error:.2f}")


if __name__ == "__main__":
    main()
