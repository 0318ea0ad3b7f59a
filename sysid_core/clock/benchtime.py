"""Bench time: how many frequency points a run measured, and how long they took on a bench.

On a real bench the fit takes milliseconds and the measurement takes hours: a stepped-sine
analyzer waits at every frequency point for the response to settle, a few time constants
``2Q/ω`` of a high-Q mode, and the gyro needs a few more after every bias change. A run counts
its ``points`` (frequency points of every sweep, times the device's ``points_per_frequency``
when it measures its inputs or outputs one after the other), its ``acquisitions`` (each
measures up to ``tones`` frequencies at once: a lock-in with several demodulators, a
multisine) and its bias changes, and estimates ``bench_time_s = acquisitions × dwell_s +
bias changes × settle_s``. Each figure comes from, in this order:

* the device's own attribute (``dwell_s`` seconds per acquisition, ``tones``, ``settle_s``),
  read and checked once (:mod:`sysid_core.device.capabilities`);
* the configuration's ``[experiment] dwell_s``, ``tones``, ``settle_s``;
* estimated from the data: the dwell ``5 Q/ω`` of the sharpest mode of the last fitted model
  (2.5 time constants; 8.1 s for Q = 45 000 at 4.4 kHz); one tone; the settling ``3 × 2Q/ω``
  of its slowest mode (9.8 s there).

When every measurement carries time stamps the device's clock is the truth instead
(:mod:`sysid_core.run.summary`).
"""

from __future__ import annotations

import math

import numpy as np

from sysid_core.device.capabilities import Capabilities
from sysid_core.model.fitted import FittedModel

__all__ = [
    "DWELL_TIME_CONSTANTS",
    "SETTLE_TIME_CONSTANTS",
    "acquisitions",
    "dwell",
    "points_per_frequency",
    "settle",
    "stated_dwell",
    "tones",
]

#: The estimated dwell is this many ``Q/ω`` (2.5 time constants ``2Q/ω``).
DWELL_TIME_CONSTANTS = 5.0
#: The estimated settling after a bias change is this many time constants ``2Q/ω`` of the
#: slowest mode (the response to a step is then within 5 % of its end).
SETTLE_TIME_CONSTANTS = 3.0


def points_per_frequency(caps: Capabilities) -> int:
    """How many measurements a device makes per frequency point (default 1).

    The device's ``points_per_frequency``, e.g. 2 for an analyzer that drives the two inputs one
    after the other.
    """
    return caps.per_frequency


def tones(caps: Capabilities, cfg_tones: int | None = None) -> int:
    """How many frequencies one acquisition of the device measures (default 1).

    The device's ``tones`` (the bench clock's acquisition capability), else the configuration's
    ``[experiment] tones``, else 1.
    """
    if caps.tones is not None:
        return caps.tones
    return int(cfg_tones) if cfg_tones is not None and cfg_tones >= 1 else 1


def acquisitions(n_frequencies: int, tones: int) -> int:
    """Acquisitions of one sweep of ``n_frequencies``, ``tones`` at a time."""
    return -(-int(n_frequencies) // max(int(tones), 1))


def settle(
    caps: Capabilities, cfg_settle: float | None = None, model: FittedModel | None = None
) -> tuple[float | None, str | None]:
    """Seconds the gyro needs after a bias change and where they come from.

    The device's ``settle_s`` (``"device"``), else the configuration's ``[experiment]
    settle_s`` (``"config"``), else :data:`SETTLE_TIME_CONSTANTS` time constants ``2Q/ω`` of
    the slowest mode of ``model`` (``"estimated 3 τ"``); ``(None, None)`` if nothing says.
    """
    if caps.settle_s is not None:
        return caps.settle_s, "device"
    if cfg_settle is not None:
        return float(cfg_settle), "config"
    modes = _fitted_modes(model)
    if modes is None:
        return None, None
    f, q = modes
    tau = float(np.max(q / (math.pi * f)))  # 2Q/ω of the slowest mode
    return SETTLE_TIME_CONSTANTS * tau, "estimated 3 τ"


def _fitted_modes(model: FittedModel | None) -> tuple[np.ndarray, np.ndarray] | None:
    """The frequencies (Hz) and Q of ``model``'s modes at its fit's bias, or None.

    Only modes with a finite positive frequency and Q; None without a model or such a mode.
    """
    if model is None:
        return None
    try:
        fitted = model.facts.fit_bias
        report = model.modal(np.zeros(model.n_electrodes) if fitted is None else fitted[0])
    except Exception:  # a model without modes there: nothing to estimate from
        return None
    f = np.asarray(report.frequencies_hz, dtype=float)
    q = np.asarray(report.q, dtype=float)
    ok = np.isfinite(q) & (q > 0) & np.isfinite(f) & (f > 0)
    return (f[ok], q[ok]) if np.any(ok) else None


def stated_dwell(caps: Capabilities) -> float | None:
    """The dwell per acquisition the device states itself (``dwell_s``), or ``None``.

    A device that states one has a clock: each acquisition costs that many seconds.
    """
    return caps.dwell_s


def dwell(
    caps: Capabilities, cfg_dwell: float | None, model: FittedModel | None
) -> tuple[float | None, str | None]:
    """The dwell per acquisition (seconds) and where it comes from.

    The source is ``"device"``, ``"config"`` or ``"estimated 5 Q/ω"``; ``(None, None)`` if
    nothing says (no model to estimate from).
    """
    own = caps.dwell_s
    if own is not None:
        return own, "device"
    if cfg_dwell is not None:
        return float(cfg_dwell), "config"
    modes = _fitted_modes(model)
    if modes is None:
        return None, None
    f, q = modes
    # the sharpest mode's Q over the lowest frequency: the longest a point can need
    return DWELL_TIME_CONSTANTS * float(q.max()) / (2 * math.pi * float(f.min())), "estimated 5 Q/ω"
