"""Plots of a tuning run (matplotlib), in the style of the paper's Figs. 4-6.

Each ``*_figure`` function returns a :class:`matplotlib.figure.Figure` (for notebooks and
reports); :func:`save_figure` writes one as PNG, atomically (the one PNG writer of the toolkit).

* :func:`fit_figure`: Bode magnitude and phase of the data and the model, per experiment.
* :func:`verification_figure`: the verification sweep, the identified model's prediction at
  the applied bias and the single-bias fit that measures the split.
* :func:`bias_path_figure`: every electrode's bias across iterations and the measured split.
* :func:`plot_iteration`, :func:`plot_bias_path`: what ``sysid tune`` writes.
"""

from __future__ import annotations

import io
import os
import textwrap
from collections.abc import Sequence
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np
import xarray as xr

from sysid_core.data.io import atomic_write
from sysid_core.data.schema import measured_mask

if TYPE_CHECKING:
    from matplotlib.axes import Axes
    from matplotlib.figure import Figure

    from sysid_core.model.fitted import FittedModel
    from sysid_core.run.summary import Verification
    from sysid_core.tuning.criteria import ConfidenceRegion

__all__ = [
    "PLOT_FORMATS",
    "bias_path_figure",
    "fit_figure",
    "plot_bias_path",
    "plot_iteration",
    "save_figure",
    "verification_figure",
]

_MARKERS = "odsv^<>p*h"


def _figure(rows: int, cols: int, size: tuple[float, float]) -> Figure:
    from matplotlib.figure import Figure

    fig = Figure(figsize=size, layout="constrained")
    fig.subplots(rows, cols, squeeze=False)
    return fig


#: Formats :func:`save_figure` writes, by file extension.
PLOT_FORMATS = ("png", "pdf", "svg")


def save_figure(fig: Figure, path: str | os.PathLike[str]) -> Path:
    """Write ``fig`` at ``path`` in the format of its extension (:data:`PLOT_FORMATS`).

    The write is atomic: ``path`` holds the old file or the complete new one.
    """
    fmt = Path(path).suffix.lstrip(".").lower() or "png"
    if fmt not in PLOT_FORMATS:
        raise ValueError(f"cannot write a plot as {fmt!r}; use one of {', '.join(PLOT_FORMATS)}")
    buf = io.BytesIO()
    fig.savefig(buf, format=fmt, dpi=110)
    data = buf.getvalue()
    return atomic_write(path, lambda tmp: tmp.write_bytes(data))


def _plain_frequency_axes(axes: Sequence[Axes]) -> None:
    """Frequencies written out (4429.6, 4429.8, ...), not as an offset (+4.43e3)."""
    for ax in axes:
        ax.ticklabel_format(axis="x", useOffset=False, style="plain")


def _channels(ds: xr.Dataset) -> list[tuple[int, int, str]]:
    return [
        (o, i, f"{ds['output'].values[o]} / {ds['input'].values[i]}")
        for o in range(ds.sizes["output"])
        for i in range(ds.sizes["input"])
    ]


def fit_figure(ds: xr.Dataset, model: FittedModel, title: str = "") -> Figure:
    """Data (markers) and model (lines) per experiment: magnitude (dB) and phase (deg)."""
    fig = _figure(4, 2, (11, 11))
    axes = fig.axes
    f = ds["frequency"].values
    mask = measured_mask(ds)
    dense = np.linspace(f.min(), f.max(), 1200)
    for k in range(ds.sizes["experiment"]):
        bias = ds["bias"].values[k]
        data = ds["response"].values[k][mask[k]]
        fk = f[mask[k]]
        resp = model.response(dense, bias)
        label = "[" + ", ".join(f"{b:.2f}" for b in bias) + "] V"
        for row, (o, i, name) in enumerate(_channels(ds)):
            ax_m, ax_p = axes[2 * row], axes[2 * row + 1]
            (line,) = ax_m.plot(dense, 20 * np.log10(np.abs(resp[:, o, i])), lw=1)
            color = line.get_color()
            ax_m.plot(
                fk,
                20 * np.log10(np.abs(data[:, o, i])),
                _MARKERS[k % 10],
                ms=3,
                mfc="none",
                color=color,
                label=label if row == 0 else None,
            )
            ax_p.plot(dense, np.degrees(np.angle(resp[:, o, i])), lw=1, color=color)
            ax_p.plot(
                fk,
                np.degrees(np.angle(data[:, o, i])),
                _MARKERS[k % 10],
                ms=3,
                mfc="none",
                color=color,
            )
            ax_m.set_ylabel(f"{name}\n|H| [dB]")
            ax_p.set_ylabel("phase [deg]")
    for ax in axes[-2:]:
        ax.set_xlabel("frequency [Hz]")
    _plain_frequency_axes(axes)
    from matplotlib.lines import Line2D

    handles, _ = axes[0].get_legend_handles_labels()
    handles += [
        Line2D([], [], ls="none", marker="o", mfc="none", color="0.35", label="markers: data"),
        Line2D([], [], color="0.35", label="lines: model"),
    ]
    axes[0].legend(handles=handles, fontsize=7, title="bias", title_fontsize=7)
    fig.suptitle(title or "identified model (lines) and data (markers)")
    return fig


def verification_figure(
    sweep: xr.Dataset,
    predicted: FittedModel,
    bias: Sequence[float] | np.ndarray,
    fitted: FittedModel,
    title: str = "",
) -> Figure:
    """Verification sweep (markers), the prediction at ``bias`` (dashed) and its fit (solid)."""
    fig = _figure(4, 2, (11, 10))
    axes = fig.axes
    f = sweep["frequency"].values
    data = sweep["response"].values[0]
    dense = np.linspace(f.min(), f.max(), 800)
    pred = predicted.response(dense, bias)
    fit = fitted.response(dense, [])
    for row, (o, i, name) in enumerate(_channels(sweep)):
        ax_m, ax_p = axes[2 * row], axes[2 * row + 1]
        ax_m.plot(f, 20 * np.log10(np.abs(data[:, o, i])), "o", ms=3, mfc="none", label="data")
        ax_m.plot(dense, 20 * np.log10(np.abs(pred[:, o, i])), "--", lw=1, label="prediction")
        ax_m.plot(dense, 20 * np.log10(np.abs(fit[:, o, i])), "-", lw=1, label="fit of sweep")
        ax_p.plot(f, np.degrees(np.angle(data[:, o, i])), "d", ms=3, mfc="none")
        ax_p.plot(dense, np.degrees(np.angle(pred[:, o, i])), "--", lw=1)
        ax_p.plot(dense, np.degrees(np.angle(fit[:, o, i])), "-", lw=1)
        ax_m.set_ylabel(f"{name}\n|H| [dB]")
        ax_p.set_ylabel("phase [deg]")
    for ax in axes[-2:]:
        ax.set_xlabel("frequency [Hz]")
    _plain_frequency_axes(axes)
    axes[0].legend(fontsize=7)
    rep = fitted.modal([])
    text = title or (
        f"verification: modes {rep.frequencies_hz[0]:.4f} / {rep.frequencies_hz[1]:.4f} Hz, "
        f"split {rep.split_hz * 1e3:.1f} mHz"
    )
    fig.suptitle(textwrap.fill(text, 110))
    return fig


def bias_path_figure(
    biases: Sequence[Sequence[float]],
    splits_hz: Sequence[float | None],
    electrodes: Sequence[str],
    limits: tuple[float, float] | None = None,
    acceptance_hz: float | None = None,
    regions: Sequence[ConfidenceRegion | None] | None = None,
) -> Figure:
    """Every electrode's bias after each iteration, and the split each verification measured.

    ``biases[0]`` is the start bias, ``biases[k]`` the bias of iteration ``k``. A split of
    ``None`` (the verification did not show both modes) is drawn as a cross at the bottom.
    ``regions[k - 1]``, the confidence region of iteration ``k``'s answer, adds error bars to
    its biases and its predicted split range next to the measured split.
    """
    fig = _figure(1, 2, (11, 4.5))
    ax_b, ax_s = fig.axes
    regions = list(regions or [])
    _bias_panel(ax_b, np.asarray(biases, dtype=float), electrodes, limits, regions)
    _split_panel(ax_s, splits_hz, acceptance_hz, regions)
    return fig


def _bias_panel(
    ax_b: Axes,
    b: np.ndarray,
    electrodes: Sequence[str],
    limits: tuple[float, float] | None,
    regions: list[ConfidenceRegion | None],
) -> None:
    """The left panel of :func:`bias_path_figure`: each electrode's bias per iteration."""
    steps = np.arange(b.shape[0])
    for p, name in enumerate(electrodes):
        line = ax_b.plot(steps, b[:, p], "-o", ms=4, label=name)[0]
        for k, region in enumerate(regions[: b.shape[0] - 1], start=1):
            if region is None:
                continue
            lo, hi = region.bias_ci[p]
            if hi > lo:
                err = [[max(b[k, p] - lo, 0.0)], [max(hi - b[k, p], 0.0)]]
                ax_b.errorbar(k, b[k, p], yerr=err, color=line.get_color(), capsize=4, lw=1)
                if k == len(regions):  # the last answer's only: earlier labels would overlap
                    half = 0.5 * (hi - lo)
                    ax_b.annotate(
                        f"±{half * 1e3:.3g} mV" if half < 1.0 else f"±{half:.3g} V",
                        (k, b[k, p]),
                        xytext=(6, -3 - 9 * p),
                        textcoords="offset points",
                        fontsize=7,
                        color=line.get_color(),
                    )
    if limits is not None:
        ax_b.axhspan(limits[0], limits[1], color="0.93", zorder=0, label="allowed bias")
        # the early answers' regions can reach far past the limits: the axis shows the limits
        margin = 0.15 * (limits[1] - limits[0])
        ax_b.set_ylim(limits[0] - margin, limits[1] + margin)
    ax_b.set_xticks(steps, ["start", *[str(k) for k in steps[1:]]])
    ax_b.set_xlim(-0.3, steps[-1] + (0.6 if regions else 0.3))
    ax_b.set_xlabel("iteration")
    ax_b.set_ylabel("bias [V]")
    ax_b.set_title(
        "bias of each electrode" + (" (bars: confidence region of each answer)" if regions else "")
    )
    ax_b.legend(fontsize=8, ncols=2)


def _split_panel(
    ax_s: Axes,
    splits_hz: Sequence[float | None],
    acceptance_hz: float | None,
    regions: list[ConfidenceRegion | None],
) -> None:
    """The right panel of :func:`bias_path_figure`: the measured and predicted splits."""
    from matplotlib.ticker import FuncFormatter

    it = np.arange(1, len(splits_hz) + 1)
    known = np.array([s is not None and np.isfinite(s) for s in splits_hz], dtype=bool)
    mhz = np.array(
        [s * 1e3 if k and s is not None else np.nan for s, k in zip(splits_hz, known, strict=True)]
    )
    floor = 1e-3
    if known.any():
        ax_s.semilogy(it[known], np.maximum(mhz[known], floor), "-o", label="measured split")
    if (~known).any():
        bottom = np.nanmin(np.r_[mhz[known], acceptance_hz * 1e3 if acceptance_hz else 1.0])
        ax_s.semilogy(
            it[~known],
            np.full((~known).sum(), max(bottom / 3, floor)),
            "x",
            ms=9,
            color="tab:red",
            label="not verified (no split measured)",
        )
    shown = [r for r in regions[: len(splits_hz)] if r is not None]
    if shown:
        _predicted_splits(ax_s, mhz[known], regions[: len(splits_hz)], shown, acceptance_hz, floor)
    if acceptance_hz is not None:
        ax_s.axhline(acceptance_hz * 1e3, color="tab:green", ls="--", label="acceptance")
    ax_s.yaxis.set_major_formatter(FuncFormatter(lambda v, _: f"{v:g}"))
    ax_s.yaxis.set_minor_formatter(FuncFormatter(lambda v, _: ""))
    ax_s.set_xlabel("iteration")
    ax_s.set_ylabel("measured split [mHz]")
    ax_s.set_xticks(it)
    ax_s.set_xlim(0.5, len(splits_hz) + 0.5)
    ax_s.set_title("split after each iteration")
    ax_s.legend(fontsize=8)


def _predicted_splits(
    ax_s: Axes,
    measured_mhz: np.ndarray,
    regions: list[ConfidenceRegion | None],
    shown: list[ConfidenceRegion],
    acceptance_hz: float | None,
    floor: float,
) -> None:
    """Each answer's predicted split range (mHz) next to the split its iteration measured."""
    # A range that reaches 0 runs off the bottom of the log axis (below every value shown).
    values = [v for v in measured_mhz] + [r.split_ci_hz[1] * 1e3 for r in shown]
    values += [acceptance_hz * 1e3] if acceptance_hz else []
    bottom = max(min(v for v in values if v > 0) / 10, floor) if any(values) else floor
    for k, region in enumerate(regions, start=1):
        if region is None:
            continue
        lo, hi = (v * 1e3 for v in region.split_ci_hz)
        ax_s.semilogy(
            [k + 0.1, k + 0.1],
            [max(lo, bottom / 2), max(hi, bottom)],
            "-",
            color="tab:orange",
            lw=6,
            alpha=0.6,
            solid_capstyle="butt",
            label=None
            if k > 1 and region is not shown[0]
            else (f"predicted split at the answer, {region.level:.0%} range"),
        )
    # both limits: set_ylim turns autoscaling off, and the acceptance line must stay in view
    ax_s.set_ylim(bottom, 2 * max(v for v in values if v > 0))


def plot_bias_path(
    biases: Sequence[Sequence[float]],
    splits_hz: Sequence[float | None],
    electrodes: Sequence[str],
    path: str | os.PathLike[str],
    limits: tuple[float, float] | None = None,
    acceptance_hz: float | None = None,
    regions: Sequence[ConfidenceRegion | None] | None = None,
) -> Path:
    """:func:`bias_path_figure` written to ``path``."""
    return save_figure(
        bias_path_figure(biases, splits_hz, electrodes, limits, acceptance_hz, regions), path
    )


def plot_iteration(
    it: int,
    ds: xr.Dataset,
    model: FittedModel,
    ver: Verification,
    tuned_bias: Sequence[float] | np.ndarray,
    folder: str | os.PathLike[str],
    fmt: str = "png",
    region: ConfidenceRegion | None = None,
) -> None:
    """An iteration's ``fit.<fmt>`` and ``verify.<fmt>`` in ``folder``.

    ``region`` (the answer's confidence region) adds the predicted split range to the title of
    the verification plot.
    """
    folder = Path(folder)
    units = str(ds.attrs.get("response_units", "") or "response units")
    facts = model.facts
    law = "" if facts.law is None else f" ({facts.law.law} stiffness law)"
    kind = f"{model.structure.name} model{law}"
    title = (
        f"iteration {it}: a previous {kind} anchored on {ds.sizes['experiment']} sweep(s)"
        if facts.from_model
        else f"iteration {it}: {kind} fitted to {ds.sizes['experiment']} experiments, "
        f"residual γ = {model.gamma:.3g} ({units})·(rad/s)²"
    )
    save_figure(fit_figure(ds, model, title), folder / f"fit.{fmt}")
    save_figure(
        verification_figure(
            ver.sweep.isel(electrode=[]),
            model,
            tuned_bias,
            ver.model,
            f"iteration {it} verification ({ver.status}"
            + (f", {ver.sweep.attrs['passes']} passes" if "passes" in ver.sweep.attrs else "")
            + f"): {ver.describe()}"
            + (
                ""
                if region is None
                else f"; predicted split {region.split_ci_hz[0] * 1e3:.3g}-"
                f"{region.split_ci_hz[1] * 1e3:.3g} mHz ({region.level:.0%})"
            ),
        ),
        folder / f"verify.{fmt}",
    )
