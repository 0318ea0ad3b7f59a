"""What each shape of mode grid tells about the split, per point and per second of bench clock.

For a few guesses of two modes (apart or near degenerate, known or uncertain), every shape of
``sysid_core.measure.modegrid.SHAPES``: its points, its information about the split
(``sysid_core.measure.information.split_information``, unit noise), and that per second of a
bench whose settling takes 1.2 acquisitions (3 τ against 5 Q/ω), with one tone and with eight;
the shape ``mode_grid`` chooses (the cheapest, then the most per second) is marked. A graded
shape differs from its even twin only where two modes' cores overlap with different steps.
The table of ``docs/studies/information.md``::

    python examples/grid_information.py
"""

from __future__ import annotations

import dataclasses

from sysid_core.measure.information import per_second, split_information
from sysid_core.measure.modegrid import SHAPES, ModeGuess, mode_grid, shaped_grid
from sysid_core.measure.sweeps import SweepPlan

PLAN = SweepPlan((4385.0, 4445.0), 0.5, 6.0, 0.05, 1.0, 0.01, 20_000)
SETTLE = 1.2  # acquisitions: 3 τ of settling against 5 Q/ω per acquisition
GUESSES = {
    "apart (5 Hz), known": ModeGuess.of([4424.0, 4429.0], [0.1, 0.1]),
    "apart, uncertain (σ = bw/2)": ModeGuess.of([4424.0, 4429.0], [0.1, 0.1], 0.05),
    "0.5 mHz apart, bw 0.1 / 0.05": ModeGuess.of([4430.0, 4430.0005], [0.1, 0.05]),
    "0.3 Hz apart, bw 0.18 / 0.05, σ 0.03": ModeGuess.of([4430.0, 4430.3], [0.18, 0.05], 0.03),
}


def main() -> None:
    """Print the table."""
    names = " | ".join(
        f"core {s.core:g}, {s.anchors} far{', graded' if s.graded else ''}" for s in SHAPES
    )
    print(f"| modes | tones | {names} |")
    print("|---|---|" + "---|" * len(SHAPES))
    for label, guess in GUESSES.items():
        for tones in (1, 8):
            plan = dataclasses.replace(PLAN, tones=tones)

            def cost(n: int, tones: int = tones) -> float:
                return SETTLE + -(-n // tones)

            chosen = mode_grid(guess, plan, resolve=True, cost_s=cost)
            cells = []
            for shape in SHAPES:
                points = shaped_grid(guess, plan, resolve=True, shape=shape)
                info = split_information(
                    points, guess.frequencies_hz, guess.bandwidth_hz, guess.uncertainty_hz
                )
                mark = (
                    " **chosen**" if points.size == chosen.size and (points == chosen).all() else ""
                )
                value = per_second(info, points.size, tones, cost)
                cells.append(
                    f"{points.size} points, {info / points.size:.3g} / point, {value:.3g} / s{mark}"
                )
            print(f"| {label} | {tones} | " + " | ".join(cells) + " |")


if __name__ == "__main__":
    main()
