"""How often a run that looks again and again passes a split it should not: the spent levels.

    python examples/repeated_looks.py --looks 100 --draws 2000

Synthetic runs whose true split vector has a fixed length (in units of the goal) and whose
windows, one every 15 s, each read it with a noise of ``--noise`` goals per component; after
every window the filter of :mod:`sysid_core.identification.splittrend` (the stated trend,
:data:`~sysid_core.identification.splittrend.LAB_TREND`) forecasts the split at the window's
end, and the run passes at the first look whose bound is under the goal. Two ways to bound:
every look at 95 % (``plain``) and the k-th look at its spent level
(:func:`sysid_core.drift.looks.look_level`, ``spent``). One row per true split: the share of
runs that pass within ``--looks`` looks and the median look at which they pass. The table of
docs/studies/repeated-looks.md is this script's output.
"""

from __future__ import annotations

import argparse

import numpy as np
from scipy.stats import rice

from sysid_core.drift.looks import look_level
from sysid_core.identification.splittrend import LAB_TREND, forecast_weights

MHZ = 1e-3


def weights(looks: int, noise_hz: float) -> tuple[list[np.ndarray], np.ndarray]:
    """The forecast at each look as weights on the windows so far, and its σ per component."""
    t = np.cumsum(np.full(looks, 15.0))
    found = [
        forecast_weights(t[:k], [noise_hz**2] * k, t[k - 1], LAB_TREND) for k in range(1, looks + 1)
    ]
    return [w for w, _ in found], np.array([sigma for _, sigma in found])


def passes(
    truth_hz: float,
    spent: bool,
    draws: int,
    seed: int,
    w: list[np.ndarray],
    sigma: np.ndarray,
    noise_hz: float,
    goal_hz: float,
) -> tuple[float, float]:
    """The share of runs that pass, and the median look of those that do."""
    rng = np.random.default_rng(seed)
    looks = len(w)
    y = np.array([truth_hz, 0.0]) + rng.normal(0.0, noise_hz, (draws, looks, 2))
    first = np.full(draws, np.inf)
    for k in range(looks, 0, -1):
        split = np.hypot(*np.einsum("i,dic->cd", w[k - 1], y[:, :k]))
        level = look_level(k if spent else 1)
        bound = rice.ppf(1.0 - level, split / sigma[k - 1], scale=sigma[k - 1])
        first[bound < goal_hz] = k
    passed = np.isfinite(first)
    return float(passed.mean()), float(np.median(first[passed])) if passed.any() else np.inf


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--looks", type=int, default=100)
    parser.add_argument("--draws", type=int, default=2000)
    parser.add_argument("--noise", type=float, default=0.35, help="per component, in goals")
    parser.add_argument("--truths", default="0.4,0.7,0.9,1.0,1.064,1.2", help="in goals")
    args = parser.parse_args()
    goal = 1.0 * MHZ
    w, sigma = weights(args.looks, args.noise * goal)
    print(f"{args.looks} looks, windows of {args.noise:g} goals per component, {args.draws} runs")
    print("| true split / goal | plain: pass | median look | spent: pass | median look |")
    print("|---|---|---|---|---|")
    for i, truth in enumerate(float(x) for x in args.truths.split(",")):
        row = [f"{truth:g}"]
        for spent in (False, True):
            share, look = passes(
                truth * goal, spent, args.draws, i, w, sigma, args.noise * goal, goal
            )
            row += [f"{share:.3f}", f"{look:g}"]
        print("| " + " | ".join(row) + " |")


if __name__ == "__main__":
    main()
