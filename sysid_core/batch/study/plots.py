"""Study plots in the style of the paper's Figs. 7-10."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np
import xarray as xr

from sysid_core.device.protocol import SimulatedDevice
from sysid_core.run.plots import save_figure

__all__ = ["plot_population", "plot_study", "true_split_map"]


def true_split_map(
    device: SimulatedDevice,
    base_bias: np.ndarray,
    tuned_index: list[int],
    center: np.ndarray,
    half_width: float,
    n: int = 121,
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The device's TRUE split on a grid of the first two tuned electrodes' biases."""
    a = np.linspace(center[0] - half_width, center[0] + half_width, n)
    b = np.linspace(center[1] - half_width, center[1] + half_width, n)
    low, high = device.bias_limits
    split = np.full((n, n), np.nan)
    for i, y in enumerate(b):
        for j, x in enumerate(a):
            if low <= x <= high and low <= y <= high:
                bias = np.array(base_bias, dtype=float)
                bias[tuned_index[0]], bias[tuned_index[1]] = x, y
                # a list: SimulatedDevice.true_modal_frequencies_hz takes a Sequence[float]
                f = device.true_modal_frequencies_hz(bias.tolist())
                split[i, j] = f[1] - f[0]
    return a, b, split


def plot_study(
    ds: xr.Dataset,
    device: Any,
    tuned_index: list[int],
    out: Path,
    tuned_bias: list[float] | None = None,
) -> list[Path]:
    """One PNG per objective, model and iteration: predicted biases over true-split contours."""
    from matplotlib.figure import Figure

    if len(tuned_index) < 2 or not isinstance(device, SimulatedDevice):
        return []
    bias = ds["predicted_bias"].values[..., tuned_index[:2]]
    finite = bias[np.isfinite(bias).all(axis=-1)]
    if finite.size == 0:
        return []
    center = np.asarray(tuned_bias, dtype=float) if tuned_bias else np.median(finite, axis=0)
    base = np.zeros(ds.sizes["electrode"])
    if tuned_bias is None:  # the truth's tuned point, refined on two nested grids
        for hw in (0.6, 0.02):
            a, b, split = true_split_map(device, base, tuned_index, center, hw, n=81)
            if np.isfinite(split).any():
                k = np.nanargmin(split)
                center = np.array([a[k % a.size], b[k // a.size]])
    starts = ds["start_bias"].values[:, tuned_index[:2]]
    dist = np.linalg.norm(starts - center, axis=1)
    size = 8 + 60 * dist / max(dist.max(), 1e-9)
    paths = []
    for obj in ds["objective"].values:
        for model in ds["model"].values:
            for it in ds["iteration"].values:
                sel = ds.sel(objective=obj, model=model, iteration=it)
                p = sel["predicted_bias"].values[:, tuned_index[:2]]
                s = sel["true_split_hz"].values
                far = np.abs(p - center)[np.isfinite(p).all(axis=1)].max(axis=1)
                half = float(np.clip(1.15 * np.percentile(far, 90), 0.02, 3.0)) if far.size else 1
                a, b, split = true_split_map(device, base, tuned_index, center, half, n=101)
                fig = Figure(figsize=(6.2, 5.6), layout="constrained")
                ax = fig.subplots()
                cs = ax.contour(
                    a, b, split, levels=[0.01, 0.1, 1.0], colors=["C2", "C1", "C3"], linewidths=0.8
                )
                ax.clabel(cs, fmt={0.01: "10 mHz", 0.1: "100 mHz", 1.0: "1 Hz"}, fontsize=7)
                ok = np.isfinite(p).all(axis=1)
                ax.scatter(
                    p[ok, 0],
                    p[ok, 1],
                    s=size[ok],
                    facecolors="none",
                    edgecolors="C0",
                    linewidths=0.8,
                )
                out_of_view = int((ok & ((np.abs(p - center) > half).any(axis=1))).sum())
                m = p[ok].mean(axis=0) if ok.any() else [np.nan, np.nan]
                sd = p[ok].std(axis=0, ddof=1) if ok.sum() > 1 else [np.nan, np.nan]
                ax.set_xlim(a[0], a[-1])
                ax.set_ylim(b[0], b[-1])
                e = [str(v) for v in ds["electrode"].values[tuned_index[:2]]]
                ax.set_xlabel(f"{e[0]} bias [V]")
                ax.set_ylabel(f"{e[1]} bias [V]")
                ax.set_title(
                    f"{model}, {obj}, iteration {int(it)}: mean ({m[0]:.3f}, {m[1]:.3f}) V, "
                    f"std ({sd[0]:.3f}, {sd[1]:.3f}) V\n"
                    f"true split < 10 mHz: {int((s < 0.01).sum())}/{int(ok.sum())}, "
                    f"< 300 mHz: {int((s < 0.3).sum())}/{int(ok.sum())}"
                    + (f"; {out_of_view} outside the view" if out_of_view else ""),
                    fontsize=8,
                )
                path = out / f"fig-{obj}-{model}-iter{int(it)}.png"
                paths.append(save_figure(fig, path))
    return paths


def plot_population(ds: xr.Dataset, out: Path, goal_hz: float = 0.002) -> list[Path]:
    """One PNG per objective and model: the distribution of true splits after each iteration.

    An empirical cumulative distribution per iteration (log split axis), with the ``goal_hz``
    line and the fraction of gyros under it in the legend.
    """
    from matplotlib.figure import Figure

    paths = []
    for obj in ds["objective"].values:
        for model in ds["model"].values:
            fig = Figure(figsize=(6.4, 4.4), layout="constrained")
            ax = fig.subplots()
            sel = ds.sel(objective=obj, model=model)
            n = 0
            for it in sel["iteration"].values:
                s = sel["true_split_hz"].sel(iteration=it).values
                s = np.sort(s[np.isfinite(s)])
                if s.size == 0:
                    continue
                n = max(n, s.size)
                under = float((s < goal_hz).mean())
                y = np.arange(1, s.size + 1) / s.size
                ax.step(
                    np.clip(s, 1e-6, None) * 1e3,
                    y,
                    where="post",
                    label=f"iteration {int(it)}: {under:.0%} < {goal_hz * 1e3:g} mHz",
                )
            ax.axvline(goal_hz * 1e3, color="0.4", linestyle="--", linewidth=0.8)
            ax.set_xscale("log")
            ax.set_xlabel("true split after the iteration [mHz]")
            ax.set_ylabel("fraction of gyros")
            ax.set_ylim(0, 1.02)
            ax.grid(True, which="both", alpha=0.3)
            ax.legend(fontsize=8, loc="lower right")
            which = "each gyro's own structure" if str(model) == "auto" else f"{model} structure"
            ax.set_title(f"{n} gyros, {which}, {obj}", fontsize=9)
            paths.append(save_figure(fig, out / f"fig-{obj}-{model}-population.png"))
    return paths
