"""Locating the modes: a coarse probe of the band first, the whole locating sweep where it is noisy.

A lean run's first sweep only has to find the modes; the mode grids measure them. With one
tone every point costs a dwell (10 s on the cloverleaf: 10 minutes for the 61 points of
``locate_points``), and at the devices' default noise (80 dB) a sweep of a third of them finds
the modes as well. At 60 dB it does not serve as well: the fits of the fast gyros lean on the
far response that the locating sweep measures, and its points are few to average the noise.

So on a bench with a clock (``[experiment] probe = "auto"``, the default: the device states its
dwell per acquisition, :func:`probe_first`), or with ``probe = true``, the run measures a *probe*
first, every third point of the locating sweep (:func:`probe_points`: 21 of 61), and keeps it as
the locating sweep when it shows both modes and its measured noise is under :data:`QUIET_NOISE` of
its response (:func:`bench_noise`): the bench is then *quiet*. Otherwise the whole locating sweep
follows at the same bias, as without a probe, and the probe is kept with every other sweep; a
probe whose fit failed is first followed by windows around the modes it placed, as a failed
locating sweep is (:mod:`sysid_core.measure.zoom`), when they take fewer points. The
same measurement decides the first design (:meth:`~sysid_core.run.context.RunContext.design`): on a
quiet bench, under the ``auto`` stiffness law, the first design is one-sided (``n + 1`` biases),
the designs after it two-sided; and scouts step as the probe did.

Measured with a clock (docs/studies/bench-time-lab.md): the cloverleaf, whose electrodes follow
``v²``, reaches a true split of 1 mHz in a median of 14.4 minutes with one tone instead of 30.0, and
4.4 with 8 tones instead of 5.1. Random gyros, whose laws are not ``v²``, pay for the one-sided
first design about what the shorter locating sweep saves them (as many end within 1 mHz, 222
of 240). In the uncontrolled lab (60 dB, where nearly every probe is noisy, 24 iterations) it
ends 282 of 288 runs within 2 mHz on draws never used while developing, against 274 without.
A device without a clock (nothing says what a point costs) keeps the whole locating sweep
first, as before.

Why the whole locating sweep again rather than the probe's missing two thirds: completed by a
second pass interleaved with the first, the points around a mode come from two times a quarter
of an hour apart on a slow gyro, between which a drifting bench moves the mode; a locating
sweep made so lost lab gyros (72 of 96 within 2 mHz against 77, the cause not isolated).
"""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path

import numpy as np
import xarray as xr

from sysid_core.clock.benchtime import stated_dwell
from sysid_core.data.schema import measured_mask
from sysid_core.device.capabilities import Capabilities
from sysid_core.measure.evidence import WindowAssessment, noise_share
from sysid_core.measure.sweeps import SweepPlan
from sysid_core.measure.zoom import zoom_grid
from sysid_core.model.fitted import FittedModel

__all__ = [
    "PROBE_EVERY",
    "PROBE_MIN_POINTS",
    "QUIET_NOISE",
    "bench_noise",
    "locate",
    "probe_first",
    "probe_points",
]

#: A bench is quiet when the probe's noise is under this share of its response (the measured
#: noise's norm over the response's, :func:`bench_noise`). Measured on one-tone probes: 12 of
#: 72 random gyros over it at 80 dB (median 0.8 %), 93 of 96 at 60 dB (median 6-10 %).
QUIET_NOISE = 0.02
#: The probe measures every this many points of the locating sweep,
PROBE_EVERY = 3
#: but at least this many: a 21-point locating sweep cost nothing measurable at 80 dB.
PROBE_MIN_POINTS = 21

#: One sweep at the run's bias: frequencies, file, whole band or not -> data, model, evidence.
SweepAt = Callable[[np.ndarray, Path, bool], tuple[xr.Dataset, FittedModel, WindowAssessment]]


def probe_first(setting: bool | str, caps: Capabilities) -> bool:
    """Whether a run's first look at the band is a probe (``[experiment] probe``).

    ``True`` and ``False`` say so; ``"auto"`` probes when the device states its own dwell per
    acquisition (``caps``: a bench with a clock, where a point costs seconds).
    """
    if setting != "auto":
        return bool(setting)
    return stated_dwell(caps) is not None


def probe_points(locate_points: int) -> int:
    """Points of the probe: every :data:`PROBE_EVERY` th point of ``locate_points``.

    At least :data:`PROBE_MIN_POINTS`; a locating sweep of no more than that has no probe, and
    is judged quiet or not itself.
    """
    return max((int(locate_points) - 1) // PROBE_EVERY + 1, PROBE_MIN_POINTS)


def bench_noise(sweep: xr.Dataset, model: FittedModel) -> float:
    """How noisy a one-experiment sweep is, relative to its response.

    The measured noise's norm over the response's (:func:`~sysid_core.measure.evidence.noise_share`)
    when the sweep carries ``noise_var``; otherwise the relative error of its own fit ``model``,
    which holds the noise and whatever the model does not explain.
    """
    mask = measured_mask(sweep)[0]
    psi = np.asarray(sweep["response"].values[0])[mask]
    if "noise_var" in sweep:
        return noise_share(sweep, mask, psi)
    f = np.asarray(sweep["frequency"].values, dtype=float)[mask]
    norm = float(np.linalg.norm(psi))
    if norm <= 0:
        return float("inf")
    return float(np.linalg.norm(model.response(f, []) - psi)) / norm


def locate(
    sweep: SweepAt,
    say: Callable[[str], None],
    path: Path,
    tries: list[tuple[str, np.ndarray]],
    plan: SweepPlan,
    denser_points: int,
    probe: np.ndarray | None = None,
    judge: bool = False,
) -> bool:
    """Measure ``tries`` in turn at one bias until a sweep shows both modes; True if quiet.

    ``tries``: ``(suffix, frequencies)``, the file of each ``path`` with the suffix; one that
    repeats a sweep already made is skipped. The first whole-band sweep that fails is followed
    by windows around the modes its fit placed (:func:`~sysid_core.measure.zoom.zoom_grid`), and
    so is each denser whole-band sweep that fails, before the next one: a denser sweep places
    the modes closer, and its windows cost a few dozen points where the next fallback costs
    hundreds or thousands.
    ``probe``: measured first, as ``path`` itself; it ends the search if it shows both modes
    and the bench is quiet (:data:`QUIET_NOISE`), else the tries follow; one that does not show
    them is followed first by windows around the modes its fit placed, when they take fewer
    points than the first try (:func:`~sysid_core.measure.zoom.zoom_grid`). The return says
    whether the first sweep measured showed both modes on a quiet bench; without a probe it
    is judged only if ``judge`` (the run's first look at the band), else False.
    """
    if probe is not None:
        data, model, evidence = sweep(probe, path, True)
        noise = bench_noise(data, model)
        if evidence.ok:
            quiet = noise < QUIET_NOISE
            say(
                f"{path.parent.name}/{path.name}: a probe of {probe.size} points over the band "
                f"shows both modes and stands as the locating sweep; its noise is {noise:.2%} "
                f"of the response: {'a quiet' if quiet else 'not a quiet'} bench"
            )
            return quiet
        why = f"it does not show both modes: {evidence.failures()}"
        then = "measuring the locating band"
        zoom = zoom_grid(probe, evidence, plan, tries[0][1].size)
        if zoom is not None:  # windows around the modes it placed, if cheaper than the band
            tries.insert(0, ("-zoom", zoom))
            f = evidence.frequencies_hz
            then = f"windows around {f[0]:.3f} / {f[1]:.3f} Hz first"
        say(
            f"{path.parent.name}/{path.name}: a probe of {probe.size} points over the band; "
            f"{why}; {then}"
        )
    done: list[np.ndarray] = []
    names: list[str] = []
    while tries:
        suffix, freqs = tries.pop(0)
        if any(d.size == freqs.size and np.allclose(d, freqs) for d in done):
            continue
        name = f"{path.stem}{suffix}.nc"
        names.append(suffix)
        data, model, evidence = sweep(freqs, path.with_name(name), True)
        if evidence.ok:
            first = judge and probe is None and not done
            return first and bench_noise(data, model) < QUIET_NOISE
        done.append(freqs)
        zoom = zoom_grid(freqs, evidence, plan, denser_points)
        then = ""
        if zoom is not None:  # windows around the modes its fit placed roughly
            zooms = sum(n.startswith("-zoom") for n in names)
            tries.insert(0, ("-zoom" if not zooms else f"-zoom{zooms + 1}", zoom))
            f = evidence.frequencies_hz
            then = f"; windows around {f[0]:.3f} / {f[1]:.3f} Hz"
        say(
            f"{path.parent.name}/{name}: the sweep does not show both modes "
            f"({evidence.failures()}){then}"
        )
    return False
