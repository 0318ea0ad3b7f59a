"""Step 4 of the paper's loop, with evidence: verify a tuning by measuring at its bias.

:func:`verify` runs the sweeps in order: the window around the predicted modes (skipped when
the predicted split is wider than it); if it shows both modes but too coarsely (a lean run's
window around an uncertain prediction: only the resolution and the model's unsampled peak fail,
:meth:`~sysid_core.measure.evidence.WindowAssessment.too_coarse`), a fine window around them, and
one more, sized by the bandwidths its fit measured, if that is still too coarse; if it fails,
the whole band, whose fit locates the modes (a lean run's band is followed, where it fails, by
windows around the modes its fit placed and by denser bands, as the run's first locating sweep
is: a verification that sees no modes teaches the model nothing, and the next answer would
land where the last did); then, if they are close, a narrow window around
the located modes (with its fine windows). A window too coarse to resolve the modes stands
without its fine windows when its split is over :data:`COARSE_ENOUGH` times the acceptance.
Each sweep is judged by
:func:`sysid_core.measure.evidence.assess_window`. A split from a whole-band sweep is reported as
*located* (coarse); only a narrow window that passes every check *verifies* a split, and only a
verified split can make a run converge.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
import xarray as xr

from sysid_core.errors import ModelError
from sysid_core.identification.objective import Progress
from sysid_core.measure.evidence import WindowAssessment
from sysid_core.measure.sweeps import SweepPlan
from sysid_core.model.fitted import FittedModel
from sysid_core.model.modal import ModalReport
from sysid_core.tuning.criteria import TuningResult

__all__ = [
    "COARSE_ENOUGH",
    "MAX_FINE",
    "Band",
    "Sweep",
    "Verification",
    "Window",
    "modes_at",
    "verify",
]

#: Measures a sweep at the verified bias and fits it: ``(frequencies, file name, whole band?)``
#: to ``(sweep, single-bias model, evidence)``.
Sweep = Callable[[np.ndarray, str, bool], tuple[xr.Dataset, FittedModel, WindowAssessment]]
#: Chooses a window's frequencies: ``(center, split, around a prediction?, bandwidths a sweep's
#: fit has just measured there or None)`` to frequencies.
Window = Callable[[float, float, bool, np.ndarray | None], np.ndarray]
#: Locates the modes over the plan's band when a window around the predicted ones missed them:
#: appends the evidence of every sweep it measures to the list given and returns the last sweep
#: (the one that showed both modes, if any did).
Band = Callable[
    [SweepPlan, list[WindowAssessment]], tuple[xr.Dataset, FittedModel, WindowAssessment]
]
#: Fine windows measured in a row while each finds both modes but too coarsely.
MAX_FINE = 2
#: A window too coarse to resolve the modes stands when its split is over this many times the
#: acceptance: a fine window would change the split by a few percent, not the verdict (the
#: protocol's sweep applies it, :meth:`~sysid_core.measure.evidence.WindowAssessment.enough`).
COARSE_ENOUGH = 10.0


@dataclass
class Verification:
    """What the verification of one iteration established.

    Attributes
    ----------
    status : str
        ``"verified"`` (a narrow window showed both modes: the split is measured),
        ``"located"`` (only a whole-band sweep found them: the split is approximate) or
        ``"failed"`` (no sweep showed both modes).
    frequencies_hz : ndarray or None
        The measured (or located) modal frequencies.
    windows : list of WindowAssessment
        Every sweep of the verification with its evidence.
    sweep : xarray.Dataset
        The last sweep.
    model : FittedModel
        The single-bias model of the last sweep.
    """

    status: str
    frequencies_hz: np.ndarray | None
    windows: list[WindowAssessment]
    sweep: xr.Dataset
    model: FittedModel

    @property
    def verified(self) -> bool:
        """Both modes were seen in a narrow window."""
        return self.status == "verified"

    @property
    def split_hz(self) -> float | None:
        """The measured split, or None when no sweep showed both modes."""
        f = self.frequencies_hz
        return None if f is None else float(f[1] - f[0])

    @property
    def frequency_hz(self) -> float | None:
        """Mean measured modal frequency, or None."""
        return None if self.frequencies_hz is None else float(np.mean(self.frequencies_hz))

    def describe(self) -> str:
        """One line for people."""
        f, split = self.frequencies_hz, self.split_hz
        if self.status == "verified":
            assert split is not None  # "verified" and "located" always come with frequencies
            coarse = " by a coarse window (far over)" if self.windows[-1].coarse else ""
            return f"measured split {split * 1e3:.3g} mHz at {self.frequency_hz:.3f} Hz{coarse}"
        if self.status == "located":
            assert f is not None
            return (
                f"modes located by a whole-band sweep near {f[0]:.2f} and {f[1]:.2f} Hz "
                f"(split about {split:.3g} Hz, not verified by a narrow window)"
            )
        return "no sweep showed both modes: " + self.windows[-1].failures()


def modes_at(model: FittedModel, w: np.ndarray) -> ModalReport | None:
    """The model's modes at the tuned biases ``w``, or None where none of them oscillates.

    A model extrapolated far from its sweeps can answer at a bias where its stiffness is not
    positive definite (a fit that never saw both modes at 60 dB predicted modes of 0 and
    1436 Hz); the band then has to find the modes (:func:`verify`).
    """
    try:
        return model.modal(w)
    except ModelError:
        return None


def verify(
    predicted_modes: ModalReport | None,
    predicted: TuningResult,
    plan: SweepPlan,
    sweep: Sweep,
    say: Progress,
    lean: Window | None = None,
    band: Band | None = None,
) -> Verification:
    """Verify a tuning at its bias with evidence (see the module docstring).

    Parameters
    ----------
    predicted_modes : ModalReport or None
        The identified model's modes at the bias (their bandwidths size the first window);
        None where the model has no oscillating modes there: the band locates them.
    predicted : TuningResult
        The criterion's answer (predicted frequencies and split).
    plan : SweepPlan
        The run's sweeps (span, resolution, band).
    sweep : callable
        Measures and fits one sweep (see :data:`Sweep`).
    say : callable
        Receives progress lines.
    lean : callable, optional
        Chooses the windows' points instead of the plan's even grid (a lean run's
        :func:`~sysid_core.measure.lean.mode_grid`): ``(center, split, predicted, seen)`` to
        frequencies, ``predicted`` false for a window around modes a sweep has just found,
        ``seen`` the bandwidths that sweep's fit measured (or None).
    band : callable, optional
        Locates the modes over the band instead of one whole-band sweep (a lean run's: a
        failed band is followed by windows and denser bands, as the run's first locating
        sweep is, :func:`~sysid_core.measure.locating.locate`); see :data:`Band`.
    """
    rep = predicted_modes
    # the modes are measured where the model puts them, inside the band or not
    plan = plan.following(
        predicted.frequencies_hz, max(plan.verify_span_hz, plan.refine_span_hz / 2)
    )
    bw = rep.bandwidth_hz if rep is not None else np.full(2, np.nan)
    bw_min = float(np.min(bw)) if np.all(np.isfinite(bw) & (bw > 0)) else np.inf
    bw_max = float(np.max(bw)) if np.isfinite(bw_min) else 0.0

    def window(
        center: float, split: float, predicted: bool = True, seen: np.ndarray | None = None
    ) -> np.ndarray:
        if lean is not None:
            return lean(center, split, predicted, seen)
        span = max(plan.verify_span_hz, 2 * split + 6 * bw_max)
        narrowest = bw_min if seen is None else min(bw_min, float(np.min(seen)))
        return plan.window(center, span, min(plan.verify_resolution_hz, narrowest))

    windows: list[WindowAssessment] = []

    def narrow(freqs: np.ndarray, stem: str) -> tuple[xr.Dataset, FittedModel, WindowAssessment]:
        return _narrow(freqs, stem, sweep, window, say, windows)

    if rep is None:
        say("verification: the model has no oscillating modes at this bias; sweeping the band")
    elif predicted.split_hz < plan.verify_span_hz:
        swept, vmodel, ev = narrow(window(predicted.frequency_hz, predicted.split_hz), "verify")
        if ev.ok:
            return Verification("verified", ev.frequencies_hz, windows, swept, vmodel)
        say(
            "verification: the window around the predicted modes does not show both modes "
            f"({ev.failures()}); sweeping the whole band to locate them"
        )
    else:  # far from a tuning even by the model: only locate the modes
        say(
            f"verification: predicted split {predicted.split_hz:.3g} Hz; sweeping the whole "
            "band to locate the modes"
        )
    swept, vmodel, ev = (band or _whole_band(sweep))(plan, windows)
    if not ev.ok:
        return Verification("failed", None, windows, swept, vmodel)
    located = ev.frequencies_hz
    if ev.split_hz >= plan.verify_span_hz:
        return Verification("located", located, windows, swept, vmodel)
    say(
        f"verification: modes located near {located[0]:.3f} / {located[1]:.3f} Hz; "
        "measuring a window around them"
    )
    swept2, vmodel2, ev2 = narrow(window(ev.center_hz, ev.split_hz, False), "verify-2")
    if ev2.ok:
        return Verification("verified", ev2.frequencies_hz, windows, swept2, vmodel2)
    return Verification("located", located, windows, swept, vmodel)


def _whole_band(sweep: Sweep) -> Band:
    """One sweep of the plan's band (a run that does not locate further)."""

    def band(
        plan: SweepPlan, windows: list[WindowAssessment]
    ) -> tuple[xr.Dataset, FittedModel, WindowAssessment]:
        found = sweep(plan.band(), "verify-band.nc", True)
        windows.append(found[2])
        return found

    return band


def _narrow(
    freqs: np.ndarray,
    stem: str,
    sweep: Sweep,
    window: Window,
    say: Progress,
    windows: list[WindowAssessment],
) -> tuple[xr.Dataset, FittedModel, WindowAssessment]:
    """A window; while it finds both modes too coarsely, a finer one around them.

    The first fine window resolves the model's bandwidths; a second one (at most
    :data:`MAX_FINE` in all), the narrowest bandwidth the first one's fit measured, when that
    asks for more points (fitted bandwidths scatter, and near degenerate modes one of them
    narrows). Every window's evidence is appended to ``windows``.
    """
    swept, vmodel, ev = sweep(freqs, f"{stem}.nc", False)
    windows.append(ev)
    for k in range(MAX_FINE):
        if ev.ok or not ev.too_coarse():
            break
        finer = window(ev.center_hz, ev.split_hz, False, ev.bandwidth_hz if k else None)
        if k and finer.size <= freqs.size:  # no finer than the last: it would fail alike
            break
        say(
            f"verification: modes found near {ev.frequencies_hz[0]:.3f} / "
            f"{ev.frequencies_hz[1]:.3f} Hz by a coarse window; measuring a fine one"
        )
        freqs = finer
        name = f"{stem}-fine.nc" if k == 0 else f"{stem}-fine{k + 1}.nc"
        swept, vmodel, ev = sweep(freqs, name, False)
        windows.append(ev)
    return swept, vmodel, ev
