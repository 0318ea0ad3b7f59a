"""Replay a tracked run's windows: which way of combining them predicts the next split best.

    python examples/drift_population.py --bench lab --drift track --seeds 101-124 --iterations 8
    python examples/window_replay.py runs/drift-population --trend line=1e-3,1e9,0,inf,7e-4,0

For every gyro of a population run (its folder, of ``examples/drift_population.py``; several
folders make one table; ``--draw`` the draw they were run with) and every iteration after which
the run's latest verified window and at least one earlier one measured a split under ten
acceptances
(:data:`sysid_core.drift.tracker.NEAR_ACCEPTANCES`), each way below predicts the split *vector*
at the next verification's bias and middle time, and a replica of the run's device gives the
TRUE one there (charging and the ramp are functions of the clock; the replica's temperature walk
is another draw, and the simulated temperature scales the whole stiffness, which leaves the split
as it is). The split vector is the deviation ``d`` of the normalised stiffness
``M^{-1/2} K M^{-1/2}`` (eigenvalues ``t ± |d|``) as ``d / (2π √t)``: its length is the split
in Hz, its direction the modes' orientation. The ways:

* ``tracker``: the run's own answer model (the next iteration's ``model-now.nc``: its fit
  anchored on up to four windows, moved by the split its windows predict;
  :class:`sysid_core.drift.tracker.Tracker`);
* ``anchor``: the next iteration's fit anchored on the latest window alone;
* ``latest``: that, given the latest window's own split
  (:func:`sysid_core.identification.anchor.split_offset`), always;
* ``mean-3``: given the mean of the three latest windows' own splits, each against the
  anchored model at its own time and bias;
* ``weighted-60s``: their mean over every window, weighted by ``exp(−age / 60 s)``;
* ``rate``: a straight line in time through every window's, taken to the next window's time;
* ``filter``: the run's estimator on the same windows
  (:func:`sysid_core.drift.forecast.windows_forecast`: one Kalman filter on a line in time
  through each window's own split and its anchored one, each with its fit's variance);
* ``filter-NAME``: a variant of it given with ``--trend`` (another trend model, every window
  with one noise, or without the anchored measurements);
* ``true-drift``: the mean of the four latest windows' own splits, each brought to the latest
  window's time and then to the next window's by the TRUE drift of the split (the replica's
  change of the split vector at the window's bias), which no run knows: what combining the
  windows would give if the split's drift were known.

One table row per way, over the gyros under and over 8 kHz: the root mean square, median and 90th
percentile of the vector error (mHz) and the shares of predictions within 1 and 2 mHz; then, per
kind, the median true rate of the split vector at the next bias (mHz/min) and the median error
of the rate the ``rate`` way draws through the windows (with three windows or more).

A window averaged over passes (``max_passes``) is replayed as its last pass.
"""

from __future__ import annotations

import argparse
import dataclasses
import json
import sys
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np
import xarray as xr

sys.path.insert(0, str(Path(__file__).resolve().parent))

from drift_population import make_device

from sysid_core.api import load_model
from sysid_core.data.schema import load_dataset
from sysid_core.drift.forecast import _vector, split_variance, windows_forecast
from sysid_core.drift.tracker import NEAR_ACCEPTANCES
from sysid_core.identification.anchor import anchor, split_offset
from sysid_core.identification.splittrend import TrendModel, forecast
from sysid_core.model.fitted import FittedModel
from sysid_core.model.modal import mass_roots, normalised_stiffness, trace_deviation

#: ``--trend`` variants of the filter: name to (model, fixed window noise in Hz or 0 for each
#: window's own variance, anchored measurements' variance over the own ones or 0 for none).
KALMAN: dict[str, tuple[TrendModel, float, float]] = {}


def trend_variant(spec: str) -> tuple[str, tuple[TrendModel, float, float]]:
    """``NAME=σ_r,τ_r,q_s,σ_m[,noise[,ratio]]`` (Hz/s, s, Hz²/s, Hz, Hz, 1) as a variant."""
    name, _, values = spec.partition("=")
    v = [float(x) for x in values.split(",")]
    if len(v) < 4:
        raise argparse.ArgumentTypeError(f"--trend {spec!r}: NAME=σ_r,τ_r,q_s,σ_m[,noise[,ratio]]")
    noise = v[4] if len(v) > 4 else 0.0
    ratio = v[5] if len(v) > 5 else 1.0
    return "filter-" + name, (TrendModel(*v[:4]), noise, ratio)


WAYS = ["tracker", "anchor", "latest", "mean-3", "weighted-60s", "rate", "filter", "true-drift"]
#: The key of :func:`predictions` that holds the ``rate`` way's change of the split vector in a
#: minute (mHz), not a prediction.
RATE = "rate per minute"
#: A gyro at this frequency or over is fast (Hz).
FAST_HZ = 8000.0


def split_vector(m: Any, k: Any) -> np.ndarray:
    """The split vector (mHz) of mass ``m`` and stiffness ``k`` (see the module)."""
    ns = normalised_stiffness(np.asarray(m, float)[None], np.asarray(k, float)[None])
    t, d = trace_deviation(ns[0])
    return np.asarray(d, dtype=float) / (2 * np.pi * np.sqrt(t)) * 1e3


def _times(ds: xr.Dataset) -> np.ndarray:
    t = np.asarray(ds["time_s"].values, dtype=float).ravel()
    return t[np.isfinite(t)]


@dataclasses.dataclass
class Window:
    """One iteration's verified window: the sweep, its own model, its split (Hz)."""

    iteration: int
    sweep: xr.Dataset
    own: FittedModel
    split_hz: float


def windows(folder: Path) -> dict[int, Window]:
    """Each verified iteration's latest window (by its time stamps)."""
    summary = json.loads((folder / "summary.json").read_text())
    found = {}
    for h in summary["history"]:
        it, there = h["iteration"], folder / f"iter{h['iteration']:02d}"
        if h.get("verification") != "verified" or h.get("measured_split_hz") is None:
            continue
        sweeps = [load_dataset(p) for p in there.glob("verify*.nc") if "model" not in p.name]
        sweeps = [s for s in sweeps if "time_s" in s and _times(s).size]
        if not sweeps or not (there / "verify-model.nc").exists():
            continue
        last = max(sweeps, key=lambda s: float(_times(s).max()))
        own = load_model(there / "verify-model.nc")
        found[it] = Window(it, last, own, float(h["measured_split_hz"]))
    return found


def _line(t: np.ndarray, y: np.ndarray, w: np.ndarray, at: float) -> np.ndarray:
    """Weighted least squares ``y ≈ a + b (t − t[-1])`` (each column of ``y``), at ``at``."""
    x = np.c_[np.ones_like(t), t - t[-1]]
    beta = np.linalg.lstsq(x * np.sqrt(w)[:, None], y * np.sqrt(w)[:, None], rcond=None)[0]
    return beta[0] + beta[1] * (at - t[-1])


#: The true change of the split vector (mHz) at a bias (every electrode) from one time to another.
Drift = Callable[[np.ndarray, float, float], np.ndarray]


def predictions(
    model: FittedModel,
    now: FittedModel | None,
    near: list[Window],
    bias: np.ndarray,
    at: float,
    drift: Drift | None = None,
    applied: np.ndarray | None = None,
    sigma: dict[str, float] | None = None,
) -> dict[str, np.ndarray]:
    """Each way's split vector (mHz) at ``bias`` (the model's electrodes) and time ``at``.

    ``drift`` (the truth's, of a replica) and ``applied`` (the bias of every electrode at
    ``at``) give the ``true-drift`` way; ``sigma``, if given, receives the ``filter`` way's own
    standard deviation per component (mHz).
    """
    latest = near[-1]
    found = anchor(model, [latest.sweep], rate=False)
    base = found.model_at(model, at)
    offsets = np.array(
        [
            split_offset(found.model_at(model, float(_times(w.sweep).mean())), w.sweep, w.own)
            for w in near
        ]
    )
    ages = np.array([float(_times(w.sweep).mean()) for w in near])

    def given(offset: np.ndarray) -> np.ndarray:
        return split_vector(base.M, np.asarray(base.stiffness(bias)) + offset)

    flat = offsets.reshape(len(near), -1)
    weights = np.exp(-(ages[-1] - ages) / 60.0)
    out = {
        "anchor": given(np.zeros((2, 2))),
        "latest": given(offsets[-1]),
        "mean-3": given(offsets[-3:].mean(axis=0)),
        "weighted-60s": given((weights @ flat / weights.sum()).reshape(2, 2)),
        "rate": given(_line(ages, flat, np.ones_like(ages), at).reshape(2, 2))
        if len(near) > 2
        else given(offsets[-1]),
    }
    root, inv_root = mass_roots(model.M)
    scale = 4 * np.pi**2 * float(np.mean(latest.own.modal_frequencies_hz([])))
    vecs = np.array([_vector(o, inv_root, scale) for o in offsets])
    var = [max(split_variance(w.own), 1e-18) for w in near]
    alone = np.array(
        [
            _vector(anchor(model, [w.sweep], rate=False).offset - found.offset, inv_root, scale)
            for w in near
        ]
    )
    for name, (trend, noise, ratio) in KALMAN.items():
        own_var = [noise**2] * len(var) if noise > 0 else var
        fc = forecast(
            ages,
            vecs,
            own_var,
            at,
            trend,
            anchored_hz=alone if ratio > 0 else None,
            anchored_variances=[ratio * x for x in own_var],
        )
        a, b = fc.vector_hz * scale
        out[name] = given(root @ np.array([[a, b], [b, -a]]) @ root)
    _, fc = windows_forecast(model, base, [(w.sweep, w.own) for w in near], at)
    if sigma is not None:
        sigma["filter"] = 1e3 * fc.sigma_hz
    a, b = fc.vector_hz * scale
    out["filter"] = given(root @ np.array([[a, b], [b, -a]]) @ root)
    if len(near) > 2:
        later = given(_line(ages, flat, np.ones_like(ages), at + 60.0).reshape(2, 2))
        out[RATE] = later - out["rate"]
    if now is not None:
        out["tracker"] = split_vector(now.M, now.stiffness(bias))
    if drift is not None and applied is not None:
        out["true-drift"] = _true_drift(base, model, near[-4:], drift, applied, bias, at)
    return out


def _true_drift(
    base: FittedModel,
    model: FittedModel,
    near: list[Window],
    drift: Drift,
    applied: np.ndarray,
    bias: np.ndarray,
    at: float,
) -> np.ndarray:
    """The ``true-drift`` way: the windows' own splits moved in time by the truth's drift."""
    t_latest = float(_times(near[-1].sweep).mean())
    electrodes = list(model.electrodes)
    errors = []
    for w in near:
        own = split_vector(w.own.M, w.own.stiffness([]))
        tuned = np.asarray(w.sweep.sel(electrode=electrodes)["bias"].values[0], dtype=float)
        every = np.asarray(w.sweep["bias"].values[0], dtype=float)
        then = float(_times(w.sweep).mean())
        missed = own - split_vector(base.M, base.stiffness(tuned))
        errors.append(missed + drift(every, then, t_latest))
    ahead = drift(applied, t_latest, at)
    return split_vector(base.M, base.stiffness(bias)) + np.mean(errors, axis=0) + ahead


def replay(folder: Path, device: Any, acceptance_hz: float = 0.002) -> list[dict[str, float]]:
    """The vector error (mHz) of each way at each replayed iteration of the run in ``folder``.

    ``device``: a replica of the run's simulated device. Each row also holds ``true``, the
    length of the true split vector there (mHz), ``iteration``, ``rate_true``, the length of
    the true split vector's change in a minute at the next bias (mHz/min), and with three
    windows or more ``rate_error``, how far the ``rate`` way's change in a minute is from it.
    """
    found = windows(folder)
    rows = []
    for it in sorted(found):
        nxt = found.get(it + 1)
        near = [w for i, w in sorted(found.items()) if i <= it]
        near = [w for w in near if w.split_hz <= NEAR_ACCEPTANCES * acceptance_hz]
        if nxt is None or len(near) < 2 or near[-1].iteration != it:
            continue
        there = folder / f"iter{it + 1:02d}"
        model = load_model(there / "model.nc")
        now = load_model(there / "model-now.nc") if (there / "model-now.nc").exists() else None
        bias = np.asarray(nxt.sweep["bias"].values[0], dtype=float)
        tuned = np.asarray(nxt.sweep.sel(electrode=list(model.electrodes))["bias"].values[0])
        at = float(_times(nxt.sweep).mean())

        def truth(every: np.ndarray, t: float) -> np.ndarray:
            k = device._drifted_stiffness(device.applied_bias(every), np.array([t]))[0]
            return split_vector(device.truth.M, k)

        def drift(every: np.ndarray, t0: float, t1: float) -> np.ndarray:
            return truth(every, t1) - truth(every, t0)

        true = truth(bias, at)
        row: dict[str, float] = {"iteration": float(it), "true": float(np.hypot(*true))}
        sigma: dict[str, float] = {}
        found_ways = predictions(model, now, near, tuned, at, drift, bias, sigma)
        row["filter_sigma"] = sigma["filter"]
        true_rate = drift(bias, at, at + 60.0)
        row["rate_true"] = float(np.hypot(*true_rate))
        if RATE in found_ways:
            row["rate_error"] = float(np.hypot(*(found_ways.pop(RATE) - true_rate)))
        for way, vector in found_ways.items():
            row[way] = float(np.hypot(*(vector - true)))
        rows.append(row)
    return rows


def table(rows: dict[str, list[dict[str, float]]], frequency_hz: dict[str, float]) -> str:
    """The markdown table of the module over ``rows`` (per gyro)."""
    lines = [
        "| way | gyros | predictions | error rms / median / 90 % (mHz) | within 1 mHz "
        "| within 2 mHz |",
        "|---|---|---|---|---|---|",
    ]
    kinds: list[tuple[str, Callable[[float], bool]]] = [
        ("under 8 kHz", lambda f: f < FAST_HZ),
        ("8 kHz or more", lambda f: f >= FAST_HZ),
    ]
    for way in [*WAYS, *KALMAN]:
        for label, keep in kinds:
            e = np.array(
                [r[way] for g, rs in rows.items() if keep(frequency_hz[g]) for r in rs if way in r]
            )
            if not e.size:
                continue
            rms = float(np.sqrt(np.mean(e**2)))
            lines.append(
                f"| `{way}` | {label} | {e.size} | {rms:.2f} / {np.median(e):.2f} / "
                f"{np.percentile(e, 90):.2f} | {np.mean(e < 1):.0%} | {np.mean(e < 2):.0%} |"
            )
    lines.append("")
    for label, keep in kinds:
        picked = [r for g, rs in rows.items() if keep(frequency_hz[g]) for r in rs]
        true = [r["rate_true"] for r in picked]
        missed = [r["rate_error"] for r in picked if "rate_error" in r]
        if true:
            lines.append(
                f"{label}: the split's true drift {np.median(true):.2f} mHz/min (median); "
                f"the `rate` way's line misses it by {np.median(missed):.2f} (median of "
                f"{len(missed)})"
                if missed
                else f"{label}: the split's true drift {np.median(true):.2f} mHz/min (median)"
            )
    return "\n".join(lines)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument(
        "runs", type=Path, nargs="+", help="folders of examples/drift_population.py"
    )
    parser.add_argument("--draw", type=int, default=0, help="the draw the runs were made with")
    parser.add_argument("--bench", default="lab", help="the bench the runs were made on")
    parser.add_argument(
        "--trend",
        type=trend_variant,
        action="append",
        default=[],
        help="a variant of the filter, NAME=σ_r,τ_r,q_s,σ_m[,noise[,ratio]] (Hz/s, s, Hz²/s, "
        "Hz; noise: every window's in Hz, 0 for each its own; ratio: the anchored "
        "measurements' variance over the own ones, 0 for none); repeatable",
    )
    args = parser.parse_args()
    KALMAN.update(args.trend)
    gyros = [path for runs in args.runs for path in sorted(runs.glob("gyro*/summary.json"))]
    if not gyros:
        names = " ".join(str(runs) for runs in args.runs)
        raise SystemExit(f"{names}: no gyro*/summary.json; run examples/drift_population.py")
    rows, frequency = {}, {}
    for path in gyros:
        seed = int(path.parent.name.removeprefix("gyro"))
        device, _ = make_device(seed, args.bench, draw=args.draw)
        rows[str(seed)] = replay(path.parent, device)
        frequency[str(seed)] = float(json.loads(path.read_text())["frequency_hz"] or 0.0)
        print(f"gyro {seed}: {len(rows[str(seed)])} predictions replayed", flush=True)
    print(table(rows, frequency))


if __name__ == "__main__":
    main()
