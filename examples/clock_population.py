"""Time to a tuned gyro by the bench clock: docs/studies/bench-time-lab.md ("Tuning by the clock").

    python examples/clock_population.py --gyro cloverleaf --tones 1 --starts 12
    python examples/clock_population.py --gyro random --tones 8 --seeds 201-224

Each run tunes a simulated gyro on a bench with a clock (settling 3 τ after each bias change,
5 Q/ω per acquisition, ``--tones`` frequencies per acquisition, each tone with √tones more
noise because the drive is shared) and the drift of a good lab (0.2 K/h ramp, 0.05 K/√h walk).
A run that never gets there counts as never (an infinite time) in the percentiles.
``cloverleaf``: the simulated cloverleaf from ``--starts`` random starts in ±9 V on B1 and B2
(start k uses seed k); ``random``: one random gyro per seed, from 0 V, first step 3 V, the
model structure that matches its dynamics (``act`` or ``sen``, as in docs/random-gyro.md).
Degenerate modes with B1 and B2, acceptance 1 mHz, up to 4 iterations (``--iterations``). With
``--from-model``, each run starts from the last model of a previous run on the same gyro (from
0 V, other noise and drift; its own time is not counted). ``--model`` and ``--experiment`` add
a ``[model]`` or ``[experiment]`` table given as JSON (``--model '{"stiffness": "linear"}'``);
``--electrodes 3`` tunes with B1, B2 and B3 (a gyro with two electrodes uses both); of more than
two, the run tunes the pair it chooses unless ``--every-electrode`` (``[tuning] pair = false``).
``--draw K`` (K ≥ 1) repeats the population with another draw of the noise and the drift: the
same gyros and starts (the random gyro's ``noise_seed = K``; the cloverleaf's seed, which
draws only its noise, and the bench's seed plus ``100000 K``).

After every measurement a recorder reads the TRUE split at that bias on the clock (the run never
sees it). The time to 1 mHz is the clock at the end of the first verification of an answer
whose true split was then at most 1 mHz. One JSON line per run goes to ``<out>/runs.jsonl``;
then the table row, and a line of medians in the gyro's own dwells (bench clock / ``dwell_s``):
in all, per purpose and settling against acquiring. ``--verbose`` prints every run's progress.
``--table DIR [DIR ...]`` prints the rows of earlier populations from their ``runs.jsonl``.
"""

from __future__ import annotations

import argparse
import json
import shutil
import sys
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from sysid_core import tune
from sysid_core.errors import SysidError
from sysid_core.plugin.registry import get_registry

GOOD_LAB = {"temperature_ramp_k_per_h": 0.2, "temperature_walk_k_per_sqrt_h": 0.05}
ACCEPTANCE = 0.001
TARGET_HZ = 0.001
DRAW_STRIDE = 100_000  # --draw K: the bench's seed (and the cloverleaf's) plus K times this


class Recorder:
    """A simulated device that notes, after each measurement, the bias, the clock and the TRUE
    split then; everything else is the device's own."""

    def __init__(self, device: Any) -> None:
        self._device = device
        self.log: list[tuple[list[float], float, float]] = []

    def __getattr__(self, name: str) -> Any:
        return getattr(self._device, name)

    def measure(self, bias: Any, frequencies_hz: Any) -> Any:
        """The device's measurement, noted."""
        da = self._device.measure(bias, frequencies_hz)
        split = float(self._device.true_split_hz(bias))
        self.log.append(([float(b) for b in bias], float(self._device.time_s), split))
        return da


def seeds(text: str) -> list[int]:
    """``201-224`` or ``1,5,9``."""
    if "-" in text:
        lo, hi = text.split("-")
        return list(range(int(lo), int(hi) + 1))
    return [int(s) for s in text.split(",")]


def _config(
    gyro: str,
    device: Any,
    options: dict,
    experiment: dict,
    start: list[float],
    model: dict,
    electrodes: int = 2,
    iterations: int = 4,
    pair: bool = True,
) -> dict:
    tuning = {
        "criterion": "degenerate",
        "electrodes": list(device.electrodes[: max(electrodes, 2)]),
        "pair": pair,
        "start_bias": start,
        "acceptance_hz": ACCEPTANCE,
        "max_iterations": iterations,
    }
    if gyro == "random":
        experiment = {"bias_step": 3.0, **experiment}
        model = {"structure": device.structure, **model}  # its own, as in docs/random-gyro.md
    return {
        "device": {"name": device.name, **{k: v for k, v in options.items() if k != "bench"}},
        "tuning": tuning,
        **({"model": model} if model else {}),
        **({"experiment": experiment} if experiment else {}),
    }


def _device(gyro: str, seed: int, tones: int, bench_seed: int, draw: int = 0) -> tuple[Any, dict]:
    bench = {"clock": True, "seed": bench_seed + DRAW_STRIDE * draw, "tones": tones, **GOOD_LAB}
    options: dict = {"seed": seed, "bench": bench}
    name = "cloverleaf" if gyro == "cloverleaf" else "random-gyro"
    if draw and gyro == "cloverleaf":
        options["seed"] = seed + DRAW_STRIDE * draw  # its seed draws the noise only
    elif draw:
        options["noise_seed"] = draw  # the same gyro, another noise
    return get_registry().device(name, **options), options


@dataclass(frozen=True)
class Population:
    """What every run of one population shares (the command line's options)."""

    gyro: str
    tones: int
    out: Path
    experiment: dict = field(default_factory=dict)
    model: dict = field(default_factory=dict)
    draw: int = 0
    electrodes: int = 2
    iterations: int = 4
    verbose: bool = False
    pair: bool = True

    def config(self, device: Any, options: dict, start: list[float]) -> dict:
        """The run's configuration for ``device`` from ``start``."""
        return _config(
            self.gyro,
            device,
            options,
            self.experiment,
            start,
            self.model,
            self.electrodes,
            self.iterations,
            self.pair,
        )


def prior_model(pop: Population, seed: int) -> Path:
    """A previous run on the same gyro (other noise, other drift, from 0 V): its last model."""
    device, options = _device(pop.gyro, seed, pop.tones, seed + 1000, pop.draw)
    config = pop.config(device, options, [0.0] * len(device.electrodes))
    folder = pop.out / f"prior{seed}"
    shutil.rmtree(folder, ignore_errors=True)
    result = tune(config, folder, plots=False, device=device)
    return folder / f"iter{result.iterations:02d}" / "model.nc"


def one(pop: Population, seed: int, from_model: bool = False) -> dict:
    """Tune one gyro; its record."""
    prior = prior_model(pop, seed) if from_model else None
    device, options = _device(pop.gyro, seed, pop.tones, seed, pop.draw)
    if pop.gyro == "cloverleaf":
        rng = np.random.default_rng(seed)
        start = [float(v) for v in np.round(rng.uniform(-9, 9, 2), 3)] + [0.0]
    else:
        start = [0.0] * len(device.electrodes)
    recorder = Recorder(device)
    config = pop.config(device, options, start)
    folder = pop.out / f"run{seed}"
    shutil.rmtree(folder, ignore_errors=True)
    try:
        say = (lambda line: print(line, file=sys.stderr)) if pop.verbose else None
        result = tune(config, folder, plots=False, device=recorder, from_model=prior, progress=say)
    except SysidError as exc:
        return {"seed": seed, "error": str(exc)}
    answers = [r.verified_bias for r in result.history]
    to_target = None
    for bias, t, split in recorder.log:
        if split <= TARGET_HZ and any(np.allclose(bias, a) for a in answers):
            to_target = t
            break
    clock = float(device.time_s)
    summary = json.loads((folder / "summary.json").read_text())
    dwell = float(getattr(device, "dwell_s", None) or np.nan)
    return {
        "seed": seed,
        "start": start,
        "true_end_split_hz": float(device.true_split_hz(result.bias)),
        "measured_split_hz": result.split_hz,
        "converged": result.converged,
        "iterations": result.iterations,
        "points": result.points,
        "measurements": len(recorder.log),
        "clock_s": clock,
        "time_to_target_s": to_target,
        "reported_bench_time_s": result.bench_time_s,
        "bench_time_source": result.bench_time_source,
        "dwell_s": dwell,
        "bench_time_by_purpose_s": summary.get("bench_time_by_purpose_s"),
        "bench_time_split_s": summary.get("bench_time_split_s"),
    }


def progress(record: dict, done: int, total: int, what: str = "gyro") -> str:
    """One line per finished run, for the terminal (the table comes at the end)."""
    head = f"[{done}/{total}] {what} {record['seed']}:"
    if "error" in record:
        return f"{head} error: {record['error']}"
    t = record["time_to_target_s"]
    reached = "never reached 1 mHz" if t is None else f"1 mHz after {t / 60:.1f} min"
    return (
        f"{head} {reached}, {record['true_end_split_hz'] * 1e3:.3g} mHz at the end "
        f"({'converged' if record['converged'] else 'not converged'}), "
        f"{record['clock_s'] / 60:.1f} min in all"
    )


def _minutes(x: float) -> str:
    return "never" if not np.isfinite(x) else f"{x:.1f}"


def row(label: str, records: list[dict]) -> str:
    """The table row (a run that never reached 1 mHz counts as never: an infinite time)."""
    ok = [r for r in records if "error" not in r]
    minutes = np.array(
        [np.inf if r["time_to_target_s"] is None else r["time_to_target_s"] / 60 for r in ok]
        or [np.nan]
    )
    reached = sum(r["time_to_target_s"] is not None for r in ok)
    end = np.array([r["true_end_split_hz"] * 1e3 for r in ok] or [np.nan])
    points = np.median([r["points"] for r in ok]) if ok else np.nan
    p50, p90 = np.percentile(minutes, [50, 90], method="lower")
    e50, e90 = np.percentile(end, [50, 90])
    clock = np.median([r["clock_s"] / 60 for r in ok]) if ok else np.nan
    return (
        f"| {label} | {reached}/{len(records)} | {_minutes(p50)} / {_minutes(p90)} / "
        f"{_minutes(minutes.max())} | {clock:.1f} | {points:.0f} | {e50:.3f} / {e90:.3f} / "
        f"{end.max():.3f} | {sum(e <= TARGET_HZ * 1e3 for e in end)}/{len(records)} | "
        f"{len(records) - len(ok)} |"
    )


def dwells(records: list[dict]) -> str:
    """Where the clock went, in the gyro's own time: medians of dwells (bench clock / dwell_s)."""
    ok = [r for r in records if "error" not in r and np.isfinite(r.get("dwell_s", np.nan))]
    if not ok:
        return "dwells: no run states its dwell"
    total = np.median([r["clock_s"] / r["dwell_s"] for r in ok])
    parts = [f"dwells (bench clock / dwell_s), medians: {total:.0f} in all"]
    for key in ("bench_time_by_purpose_s", "bench_time_split_s"):
        names = sorted({k for r in ok for k in (r.get(key) or {})})
        for name in names:
            v = [(r.get(key) or {}).get(name, 0.0) / r["dwell_s"] for r in ok]
            parts.append(f"{name} {np.median(v):.1f}")
    return "; ".join(parts)


def main() -> None:
    """Parse the arguments, tune every gyro, print the row."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--gyro", choices=["cloverleaf", "random"], default="cloverleaf")
    parser.add_argument("--tones", type=int, default=1)
    parser.add_argument("--starts", type=int, default=12, help="cloverleaf: starts 1..N")
    parser.add_argument("--seeds", default="201-224", help="random: gyro seeds")
    parser.add_argument("--experiment", default="{}", help="an [experiment] table as JSON")
    parser.add_argument("--model", default="{}", help="a [model] table as JSON")
    parser.add_argument(
        "--from-model", action="store_true", help="start from a previous run's model of the gyro"
    )
    parser.add_argument(
        "--draw",
        type=int,
        default=0,
        help="another draw of the noise and the drift for the same gyros and starts (0: their own)",
    )
    parser.add_argument(
        "--electrodes",
        type=int,
        default=2,
        help="tune with the first N electrodes (B1, B2, ...; a gyro with fewer uses all it has)",
    )
    parser.add_argument("--iterations", type=int, default=4, help="max_iterations (4)")
    parser.add_argument(
        "--every-electrode",
        action="store_true",
        help="tune every electrode given from the start ([tuning] pair = false)",
    )
    parser.add_argument(
        "--verbose", action="store_true", help="every run's progress lines on stderr"
    )
    parser.add_argument("--label", default=None)
    parser.add_argument("--out", type=Path, default=Path("runs/clock-population"))
    parser.add_argument("--table", nargs="+", type=Path, help="rows of earlier outputs")
    args = parser.parse_args()
    if args.draw < 0:
        parser.error(f"--draw must be a non-negative integer, got {args.draw}")
    if args.electrodes < 2:
        parser.error(
            f"--electrodes must be at least 2 (degenerate modes need two), got {args.electrodes}"
        )
    if args.iterations < 1:
        parser.error(f"--iterations must be at least 1, got {args.iterations}")
    if args.table:
        for folder in args.table:
            lines = (folder / "runs.jsonl").read_text().splitlines()
            records = [json.loads(line) for line in lines]
            print(row(folder.name, records))
            print(dwells(records))
        return
    args.out.mkdir(parents=True, exist_ok=True)
    tables = {}
    for flag in ("experiment", "model"):
        try:
            tables[flag] = json.loads(getattr(args, flag))
        except json.JSONDecodeError as exc:
            parser.error(
                f'--{flag} must be a JSON object such as \'{{"stiffness": "linear"}}\': {exc}'
            )
        if not isinstance(tables[flag], dict):
            parser.error(f"--{flag} must be a JSON object, got {getattr(args, flag)}")
    experiment, model = tables["experiment"], tables["model"]
    which = list(range(1, args.starts + 1)) if args.gyro == "cloverleaf" else seeds(args.seeds)
    pop = Population(
        args.gyro,
        args.tones,
        args.out,
        experiment,
        model,
        args.draw,
        args.electrodes,
        args.iterations,
        args.verbose,
        not args.every_electrode,
    )
    records = []
    with (args.out / "runs.jsonl").open("w") as log:
        for seed in which:
            records.append(one(pop, seed, args.from_model))
            log.write(json.dumps(records[-1]) + "\n")
            log.flush()
            what = "start" if args.gyro == "cloverleaf" else "gyro"
            line = progress(records[-1], len(records), len(which), what)
            print(line, file=sys.stderr, flush=True)
    label = args.label or (
        f"{args.gyro}, {args.tones} tone(s){', from a model' if args.from_model else ''}"
    )
    print(
        "| run | reached 1 mHz | minutes to 1 mHz: median / 90 % / max | minutes in all "
        "(median) | points (median) | true end split median / 90 % / max (mHz) | end within "
        "1 mHz | errors |"
    )
    print("|---|---|---|---|---|---|---|---|")
    print(row(label, records))
    print(dwells(records))


if __name__ == "__main__":
    main()
