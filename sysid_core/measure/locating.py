"""Locating the modes: a coarse probe of the band first, then only what it did not find.

A lean run's first sweep only has to find the modes; the mode grids measure them. With one
tone every point costs a dwell (10 s on the cloverleaf: 10 minutes for the 61 points of
``locate_points``), and a sweep of a quarter of them finds the modes as well where they are not
much narrower than its step.

So on a bench with a clock (``[experiment] probe = "auto"``, the default: the device states its
dwell per acquisition, :func:`probe_first`), or with ``probe = true``, the run measures a *probe*
first, every fourth point of the locating sweep (:func:`probe_points`: 16 of 61). A probe that
shows both modes stands as the locating sweep. One that does not is followed by windows around
the modes its fit placed, as a failed locating sweep is (:mod:`sysid_core.measure.zoom`), when
they take fewer points than the locating sweep, and by the locating sweep if they do not show
the modes either; the probe is kept with every other sweep. A probe that showed both modes has
measured that its step shows this gyro's modes on this bench, its noise included: scouts step
as the probe did, and a later sweep that misses them (a scout whose electrode moved them further
than it reached) falls back first to a band at the probe's step, then to the locating sweep
(:class:`~sysid_core.run.lean_protocol.LeanProtocol`).
The probe's measured noise (:func:`bench_noise`) decides the first design
(:meth:`~sysid_core.run.context.RunContext.design`): under :data:`QUIET_NOISE` of its response
(a *quiet* bench), under the ``auto`` stiffness law, the first design is one-sided (``n + 1``
biases), the designs after it two-sided, and scouts hold at least 6 points
(:data:`~sysid_core.measure.lean.QUIET_SCOUT_POINTS`); otherwise the first design is two-sided
too and scouts hold at least 8.

Measured (docs/studies/dwells.md): on random gyros of a good lab with 8 tones and 2 electrodes,
keeping a noisy probe that shows both modes cuts the median from 37 to 30 dwells and from 199 to
148 points, as many runs ending within 1 mHz (22 of 24); in the uncontrolled lab (60 dB) 46 of 48
end within 2 mHz against 44. Earlier, a noisy probe was followed by the whole locating sweep,
because the fits of fast gyros at 60 dB lean on the far response that sweep measures; one such
run (a first answer at the bias limit) still pays for the probe alone. A device without a clock
(nothing says what a point costs) keeps the whole locating sweep first.

Why the whole locating sweep rather than the probe's missing three quarters, where one is needed:
completed by a second pass interleaved with the first, the points around a mode come from two
times a quarter of an hour apart on a slow gyro, between which a drifting bench moves the mode;
a locating sweep made so lost lab gyros (72 of 96 within 2 mHz against 77, the cause not
isolated).
"""

from __future__ import annotations

import dataclasses
from collections.abc import Callable
from pathlib import Path

import numpy as np
import xarray as xr

from sysid_core.clock.benchtime import stated_dwell
from sysid_core.data.schema import measured_mask
from sysid_core.device.capabilities import Capabilities
from sysid_core.measure.evidence import WindowAssessment, noise_share
from sysid_core.measure.lean import denser_plan, locate_plan
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
    "verify_tries",
]

#: A bench is quiet when the probe's noise is under this share of its response (the measured
#: noise's norm over the response's, :func:`bench_noise`); it decides only the first design.
#: Measured on one-tone probes: 12 of 72 random gyros over it at 80 dB (median 0.8 %), 93 of 96
#: at 60 dB (median 6-10 %).
QUIET_NOISE = 0.02
#: The probe measures every this many points of the locating sweep,
PROBE_EVERY = 4
#: but at least this many: two whole acquisitions of an eight-tone lock-in. A sparser probe
#: saves a dwell a point with one tone but misses the modes of more gyros, and what follows a
#: miss costs more than the points saved (every third, fourth and sixth point measured:
#: docs/studies/dwells.md, "A probe of a quarter of the locating points").
PROBE_MIN_POINTS = 16

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


def verify_tries(
    plan: SweepPlan, finest_hz: float, probe_stood: bool, locate_points: int
) -> tuple[list[tuple[str, np.ndarray]], int]:
    """The bands a verification's locating tries in turn, and the points of the denser band.

    The band at the probe's step first when the run's probe showed both modes (``probe_stood``:
    that step showed this gyro's modes on this bench, as after an identification sweep that
    missed them), then the locating band of ``plan`` (the plan the verification follows), the
    band four times as dense and the band at ``finest_hz`` (the run's ``resolution_hz``); each
    one that does not show both modes is followed by windows around those its fit placed
    (:func:`locate`).
    """
    denser = denser_plan(plan, finest_hz)
    every = dataclasses.replace(plan, resolution_hz=finest_hz)
    tries = [("", plan.band()), ("-locate4", denser.band()), ("-all", every.band())]
    if probe_stood:
        tries.insert(0, ("-probe", locate_plan(plan, probe_points(locate_points)).band()))
    return tries, denser.band().size


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
    ``probe``: measured first, as ``path`` itself; it ends the search if it shows both modes,
    else the tries follow, first windows around the modes its fit placed when they take fewer
    points than the first try (:func:`~sysid_core.measure.zoom.zoom_grid`). The return says
    whether the first sweep measured showed both modes on a quiet bench (:data:`QUIET_NOISE`);
    without a probe it is judged only if ``judge`` (the run's first look at the band), else
    False.
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
