"""Which biases and frequencies a tuning run measures, and the limits checked before it starts.

* :func:`design_experiments`: eq. (18), the start bias and one electrode stepped at a time.
* :func:`grid`: an evenly spaced sweep over ``[lo, hi]``.
* :class:`SweepPlan`: the identification, refinement and verification sweeps of a run, from the
  ``[experiment]`` table and the device's band, each checked against :data:`MIN_POINTS` and the
  ``max_points`` limit before anything is measured.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from sysid_core.errors import ConfigError

__all__ = [
    "MIN_POINTS",
    "SweepPlan",
    "acquisition_grid",
    "design_experiments",
    "fewest_points",
    "grid",
    "second_side",
]

#: Fewest points in any sweep: a single-bias fit has 25 unknowns (8 real equations per point),
#: and a resonance needs several points to show its shape.
MIN_POINTS = 11
#: Most points of a verification window (wider windows get a coarser step).
MAX_WINDOW_POINTS = 401


def design_experiments(
    start: np.ndarray,
    tuned_index: Sequence[int],
    step: float,
    limits: tuple[float, float],
    two_sided: bool = False,
) -> np.ndarray:
    """Eq. (18): the start bias and one electrode stepped at a time (down if up would leave).

    ``two_sided``: each electrode stepped up and down in turn (``2 n + 1`` experiments), what
    the quadratic stiffness law needs; where one side would leave the limits, the electrode
    takes a second step on the other side (``+step, +2 step``) instead.
    """
    low, high = limits
    design = [np.array(start, dtype=float)]
    for p in tuned_index:
        base = float(start[p])
        if two_sided:
            if base - step >= low and base + step <= high:
                offsets = [step, -step]
            elif base + 2 * step <= high:
                offsets = [step, 2 * step]
            elif base - 2 * step >= low:
                offsets = [-step, -2 * step]
            else:
                offsets = []
        elif base + step <= high:
            offsets = [step]
        elif base - step >= low:
            offsets = [-step]
        else:
            offsets = []
        if not offsets:
            raise ConfigError(
                f"[experiment] bias_step = {step} V does not fit inside the bias limits "
                f"{limits} V{' (two-sided: twice the step)' if two_sided else ''}; use a "
                "smaller step"
            )
        for off in offsets:
            b = np.array(start, dtype=float)
            b[p] += off
            design.append(b)
    return np.array(design)


def second_side(
    design: np.ndarray,
    tuned_index: Sequence[int],
    answer: np.ndarray | None,
    step: float,
    region: np.ndarray | None = None,
) -> np.ndarray:
    """A two-sided first design whose second step of each electrode goes to ``answer``.

    ``design``: :func:`design_experiments`' two-sided rows (the start, then each electrode's two
    steps); ``answer``: the tuned electrodes' bias that the first steps' law makes degenerate,
    ``region`` its interval per electrode (rows ``[low, high]``; default: the answer alone). An
    electrode whose whole interval lies beyond its first design's span (more than ``step`` from
    the start, on one side) takes its second step to the answer, so that the law fitted on the
    design spans the voltage the answer needs; the others keep theirs. Unchanged without an
    answer.
    """
    out = np.array(design, dtype=float)
    if answer is None or len(out) != 2 * len(tuned_index) + 1:
        return out
    box = np.column_stack([answer, answer]) if region is None else np.asarray(region, float)
    start, reach = out[0], step * (1 + 1e-9)
    for k, p in enumerate(tuned_index):
        low, high = float(box[k, 0]) - float(start[p]), float(box[k, 1]) - float(start[p])
        if low > reach or high < -reach:
            out[2 * k + 2, p] = float(answer[k])
    return out


def n_points(lo: float, hi: float, step: float) -> int:
    """Points of an evenly spaced sweep from ``lo`` to at most ``hi`` with ``step``."""
    return math.floor((hi - lo) / step + 1e-9) + 1


def grid(lo: float, hi: float, step: float) -> np.ndarray:
    """``lo, lo + step, ...`` up to ``hi`` (inclusive within rounding)."""
    return lo + step * np.arange(n_points(lo, hi, step))


def fewest_points(tones: int = 1, least: int = MIN_POINTS) -> int:
    """Fewest points of a lean sweep: ``least`` in the nearest whole acquisitions.

    An acquisition costs the same with one point as with all its ``tones``: with ``least`` =
    :data:`MIN_POINTS`, 11 points with one tone, 8 with eight (one acquisition), 12 with four.
    """
    tones = max(int(tones), 1)
    return tones * max(1, math.floor(int(least) / tones + 0.5))


def acquisition_grid(
    windows: Sequence[tuple[float, float]], step: float, tones: int = 1, fewest: int | None = None
) -> np.ndarray:
    """Points over ``windows`` (low, high; ascending, apart) at ``step``, in whole acquisitions.

    At least :data:`MIN_POINTS`, or ``fewest`` when given (a scout's floor), in the nearest whole
    acquisitions (:func:`fewest_points`). On a device that measures ``tones`` points per
    acquisition, as many as fill the nearest whole number of acquisitions, evenly over each
    window in proportion to its width: an acquisition costs the same with one point as with all
    its tones, so the last one is filled, or dropped when only a few points would spill into it
    (25 points with 8 tones are 24: three acquisitions instead of four; 11 are 8).
    """
    n = sum(n_points(lo, hi, step) for lo, hi in windows)
    tones = max(int(tones), 1)
    least = fewest_points(tones, MIN_POINTS if fewest is None else fewest)
    target = max(tones * math.floor(n / tones + 0.5), least)
    if target == n:
        return np.concatenate([grid(lo, hi, step) for lo, hi in windows])
    if tones == 1:  # too few: evenly over the span of the windows
        return np.linspace(windows[0][0], windows[-1][1], target)
    widths = np.array([hi - lo for lo, hi in windows])
    counts = np.maximum(2, np.round(target * widths / widths.sum()).astype(int))
    counts[int(np.argmax(widths))] += target - int(counts.sum())  # the widest takes the rest
    return np.concatenate(
        [np.linspace(lo, hi, k) for (lo, hi), k in zip(windows, counts, strict=True)]
    )


@dataclass(frozen=True)
class SweepPlan:
    """The sweeps of a run (Hz).

    Parameters
    ----------
    band_hz : (float, float)
        The identification band (the ``[experiment] band_hz``, or the device's band).
    resolution_hz : float
        Step of the band sweep.
    refine_span_hz, refine_resolution_hz : float
        Span and step of later identifications around the measured modes (span 0: the band).
    verify_span_hz, verify_resolution_hz : float
        Span and step of the verification window around the predicted modes.
    max_points : int
        Most points of any sweep.
    tones : int
        Frequencies one acquisition of the device measures: a lean sweep fills its
        acquisitions (:mod:`sysid_core.measure.lean`).
    motion_ppm_per_h : float
        How fast the modes may move on a bench with a clock (ppm per hour,
        ``[experiment] motion_ppm_per_h``): how far a window around modes found earlier reaches.
    """

    band_hz: tuple[float, float]
    resolution_hz: float
    refine_span_hz: float
    refine_resolution_hz: float
    verify_span_hz: float
    verify_resolution_hz: float
    max_points: int
    tones: int = 1
    motion_ppm_per_h: float = 60.0

    def check(self, device_band_hz: tuple[float, float]) -> SweepPlan:
        """Check the plan against the device's band and the point limits; return it.

        Raises
        ------
        ConfigError
            Naming the ``[experiment]`` key and the fix.
        """
        lo, hi = self.band_hz
        dlo, dhi = device_band_hz
        if hi <= dlo or lo >= dhi:
            raise ConfigError(
                f"[experiment] band_hz = [{lo}, {hi}] Hz does not overlap the device's band "
                f"[{dlo}, {dhi}] Hz, where its modes are; use a band inside it (or leave "
                "band_hz out to use the device's)"
            )
        sweeps = [("band_hz / resolution_hz", "resolution_hz", hi - lo, self.resolution_hz)]
        if self.refine_span_hz > 0:
            span = min(self.refine_span_hz, hi - lo)
            sweeps.append(
                (
                    "refine_span_hz / refine_resolution_hz",
                    "refine_resolution_hz",
                    span,
                    self.refine_resolution_hz,
                )
            )
        sweeps.append(
            (
                "verify_span_hz / verify_resolution_hz",
                "verify_resolution_hz",
                self.verify_span_hz,
                self.verify_resolution_hz,
            )
        )
        for what, key, span, step in sweeps:
            n = n_points(0.0, span, step)
            if n > self.max_points:
                raise ConfigError(
                    f"[experiment] {what} = {span:g} / {step:g} Hz gives {n} points per sweep, "
                    f"more than max_points = {self.max_points}; use a coarser {key} (or raise "
                    "max_points if you really mean it)"
                )
            if key == "resolution_hz" and n < MIN_POINTS:
                raise ConfigError(
                    f"[experiment] {what} = {span:g} / {step:g} Hz gives {n} point(s) per sweep; "
                    f"a fit needs at least {MIN_POINTS}: use a finer {key} or a wider band"
                )
            if key == "refine_resolution_hz" and n < MIN_POINTS:
                raise ConfigError(
                    f"[experiment] {what} = {span:g} / {step:g} Hz gives {n} point(s) per sweep; "
                    f"a fit needs at least {MIN_POINTS}: use a finer {key} or a wider span"
                )
        return self

    def band(self) -> np.ndarray:
        """The band sweep."""
        return grid(*self.band_hz, self.resolution_hz)

    def following(
        self, frequencies_hz: Sequence[float] | np.ndarray, margin_hz: float
    ) -> SweepPlan:
        """The plan with its band widened to hold ``frequencies_hz ± margin_hz``.

        The band says where to look for modes nobody has located yet (the device's
        ``band_hz``, or ``[experiment] band_hz``). Modes that a model predicts, or a sweep
        located, outside it are measured where they are: a lab declares the band around the
        modes it saw, and a tuning moves them (a target frequency, or the softening of every
        electrode at the answer's bias). The band follows them; it never shrinks. Its sweep keeps
        its number of points (the step grows with the band): a model that puts the modes far
        away costs a window there and a coarser band, never a band sweep of more points.
        """
        f = np.asarray(frequencies_hz, dtype=float).ravel()
        f = f[np.isfinite(f) & (f > 0)]
        if f.size == 0:
            return self
        lo, hi = self.band_hz
        wide = (
            min(lo, max(float(f.min()) - margin_hz, 0.5 * float(f.min()))),
            max(hi, float(f.max()) + margin_hz),
        )
        if wide == (lo, hi):
            return self
        step = self.resolution_hz * (wide[1] - wide[0]) / (hi - lo)
        return dataclasses.replace(self, band_hz=wide, resolution_hz=step)

    def refine(self, center_hz: float | None, split_hz: float = 0.0) -> np.ndarray:
        """The identification sweep: the band, or a window around ``center_hz``.

        The window is wide enough for both measured modes with a margin
        (``max(refine_span/2, 1.5 split)`` each side), clipped to the band; if its step would
        give more than ``max_points``, the step is coarsened.
        """
        if center_hz is None or self.refine_span_hz <= 0:
            return self.band()
        half = max(self.refine_span_hz / 2, 1.5 * split_hz)
        blo, bhi = self.following([center_hz], half).band_hz
        lo, hi = max(blo, center_hz - half), min(bhi, center_hz + half)
        if hi - lo < self.refine_span_hz / 2:  # the modes sit at the band's edge
            return self.band()
        step = max(self.refine_resolution_hz, (hi - lo) / (self.max_points - 1))
        return grid(lo, hi, step)

    def window(self, center_hz: float, span_hz: float, step_hz: float) -> np.ndarray:
        """A verification window: ``span_hz`` around ``center_hz`` inside the band.

        At least 21 points; at most :data:`MAX_WINDOW_POINTS` (the step is coarsened).
        """
        blo, bhi = self.band_hz
        lo, hi = max(center_hz - span_hz / 2, blo), min(center_hz + span_hz / 2, bhi)
        if hi <= lo:
            lo, hi = blo, bhi
        step = max(step_hz, (hi - lo) / (MAX_WINDOW_POINTS - 1))
        n = max(round((hi - lo) / step) + 1, 21)
        return np.linspace(lo, hi, n)
