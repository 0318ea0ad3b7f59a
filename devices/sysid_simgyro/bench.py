"""The simulated bench: a clock, and the slow drifts a real bench has.

A :class:`SimulatedGyro <sysid_simgyro.device.SimulatedGyro>` with a bench that has a clock
(``[device.bench] clock = true``) measures in time: after each bias change it waits
``settle_tau`` time constants ``τ = Q/(π f)`` for the gyro to settle, each acquisition takes
``dwell_q_over_omega · Q/ω`` seconds, and every point is stamped with the time ``time_s`` at which
it was measured (the device's monotonic clock, zero when the device is made unless
``start_s`` says otherwise). While the clock
runs, the bench may drift (every drift is off by default, so that a bench with a clock but no
drift measures exactly what the frozen bench measures):

* **Temperature**: ``ΔT(t) = ramp · t + W(t)``, ``W`` a random walk of
  ``temperature_walk_k_per_sqrt_h`` K per √h. Both modes move together with the common
  temperature coefficient (``tempco_ppm_per_k``, −30 ppm/K for silicon), and the split by
  ``split_tempco_ppm_per_k`` of the frequency per kelvin (a differential coefficient).
* **Dielectric charging**: each electrode's effective bias drifts by ``charging_v_per_h``
  volts per hour (one value for all electrodes, or one per electrode).
* **Several tones per acquisition** (``tones``, default 1): a lock-in with several
  demodulators or a multisine measures up to ``tones`` of the requested frequencies in one
  acquisition (consecutive ones in the order asked). The drive's amplitude is shared among
  them, so each tone's noise is ``√k`` times that of a single tone, ``k`` the tones of its
  acquisition.
* **Analyzer gain and phase wander**: every acquisition's response is multiplied by
  ``(1 + g) e^{jφ}``, ``g`` and ``φ`` drawn per sweep with standard deviations ``gain_wander``
  (relative) and ``phase_wander_deg``.
* **A later start** (``start_s``, default 0): the clock reads ``start_s`` when the device is
  made, as if the ramp and the charging had been running that long (``ΔT`` and the charging
  offsets start at ``ramp · start_s`` and ``charging_v_per_h · start_s``; the walk starts
  there). The same gyro and drifts, met later: what a run's result owes to where in the
  drifts it started.

Physical ranges (docs/drift.md): a lab without temperature control drifts by 0.5-1.5 K/h, a
vacuum chamber by 0.05-0.3 K/h; charging moves an electrode by millivolts per hour.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass, fields
from typing import Any

import numpy as np

from sysid_core.errors import ConfigError

__all__ = ["Bench", "BenchSettings", "bench_settings"]

_HOUR = 3600.0
#: Settings that may be negative (the others are sizes or durations).
_SIGNED = (
    "temperature_ramp_k_per_h",
    "tempco_ppm_per_k",
    "split_tempco_ppm_per_k",
    "charging_v_per_h",
)


def _number(device: str, key: str, value: Any, low: float | None = 0.0) -> float:
    if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value):
        raise ConfigError(
            f"[device.bench] {key} of device {device!r} must be a finite number, got {value!r}"
        )
    if low is not None and value < low:
        raise ConfigError(
            f"[device.bench] {key} of device {device!r} must be >= {low:g}, got {value!r}"
        )
    return float(value)


@dataclass(frozen=True)
class BenchSettings:
    """How the simulated bench behaves in time (see the module); the defaults are frozen."""

    clock: bool = False
    tones: int = 1
    settle_tau: float = 3.0
    dwell_q_over_omega: float = 5.0
    temperature_ramp_k_per_h: float = 0.0
    temperature_walk_k_per_sqrt_h: float = 0.0
    tempco_ppm_per_k: float = -30.0
    split_tempco_ppm_per_k: float = 0.0
    charging_v_per_h: float | tuple[float, ...] = 0.0
    gain_wander: float = 0.0
    phase_wander_deg: float = 0.0
    start_s: float = 0.0
    seed: int | None = None

    @classmethod
    def from_options(cls, device: str, options: Mapping[str, Any] | None) -> BenchSettings:
        """The settings of a ``[device.bench]`` table; an unknown key or a bad value is a
        :class:`~sysid_core.errors.ConfigError` that names it."""
        if options is None:
            return cls()
        if isinstance(options, BenchSettings):
            return options
        if not isinstance(options, Mapping):
            raise ConfigError(
                f"option 'bench' of device {device!r} must be a table of bench settings, "
                f"got {options!r}"
            )
        known = {f.name for f in fields(cls)}
        unknown = sorted(set(options) - known)
        if unknown:
            raise ConfigError(
                f"[device.bench] of device {device!r}: unknown key {unknown[0]!r}; known: "
                f"{', '.join(sorted(known))}"
            )
        values: dict[str, Any] = {}
        for key, value in options.items():
            if key == "clock":
                if not isinstance(value, bool):
                    raise ConfigError(
                        f"[device.bench] clock of device {device!r} must be true or false, "
                        f"got {value!r}"
                    )
                values[key] = value
            elif key == "tones":
                if isinstance(value, bool) or not isinstance(value, int) or value < 1:
                    raise ConfigError(
                        f"[device.bench] tones of device {device!r} must be an integer >= 1 "
                        f"(frequencies per acquisition), got {value!r}"
                    )
                values[key] = value
            elif key == "seed":
                if value is not None and (
                    isinstance(value, bool) or not isinstance(value, int) or value < 0
                ):
                    raise ConfigError(
                        f"[device.bench] seed of device {device!r} must be a non-negative "
                        f"integer, got {value!r}"
                    )
                values[key] = value
            elif key == "charging_v_per_h" and isinstance(value, (list, tuple)):
                values[key] = tuple(_number(device, key, v, None) for v in value)
            else:
                signed = key in _SIGNED
                values[key] = _number(device, key, value, None if signed else 0.0)
        settings = cls(**values)
        drifting = settings.drifts() + (["start_s"] if settings.start_s else [])
        if drifting and not settings.clock:
            raise ConfigError(
                f"[device.bench] of device {device!r} sets {drifting[0]} but no clock: drifts "
                "happen in time; add clock = true"
            )
        return settings

    def drifts(self) -> list[str]:
        """The names of the drifts that are on."""
        on = []
        if self.temperature_ramp_k_per_h or self.temperature_walk_k_per_sqrt_h:
            on.append(
                "temperature_ramp_k_per_h"
                if self.temperature_ramp_k_per_h
                else "temperature_walk_k_per_sqrt_h"
            )
        if np.any(np.asarray(self.charging_v_per_h, dtype=float) != 0):
            on.append("charging_v_per_h")
        if self.gain_wander or self.phase_wander_deg:
            on.append("gain_wander" if self.gain_wander else "phase_wander_deg")
        return on


class Bench:
    """The state of a simulated bench in time: its clock and the drifts' current values.

    Parameters
    ----------
    settings : BenchSettings
        How the bench behaves.
    tau_s : float
        The gyro's slowest amplitude time constant ``τ = Q/(π f)`` (seconds).
    q_over_omega_s : float
        ``Q/ω`` of the slowest mode (seconds): the unit of the dwell per acquisition.
    n_electrodes : int
        For per-electrode charging.
    """

    def __init__(
        self, settings: BenchSettings, tau_s: float, q_over_omega_s: float, n_electrodes: int
    ) -> None:
        self.settings = settings
        #: Seconds the gyro needs after a bias change, and per acquisition.
        self.settle_s = settings.settle_tau * tau_s
        self.dwell_s = settings.dwell_q_over_omega * q_over_omega_s
        rate = np.asarray(settings.charging_v_per_h, dtype=float).reshape(-1)
        if rate.size == 1:
            rate = np.full(n_electrodes, float(rate[0]))
        if rate.size != n_electrodes:
            raise ConfigError(
                f"[device.bench] charging_v_per_h has {rate.size} values for {n_electrodes} "
                "electrodes: give one value, or one per electrode"
            )
        self.charging_v_per_s = rate / _HOUR
        self._rng = np.random.default_rng(settings.seed)
        #: The clock (seconds since the drifts began: ``start_s`` when the device is made).
        self.now_s = float(settings.start_s)
        self._walk_k = 0.0
        self._walk_at_s = self.now_s
        self._last_bias: np.ndarray | None = None

    # ------------------------------------------------------------------ the clock
    def settle(self, bias: np.ndarray) -> None:
        """Apply ``bias``: the clock waits :attr:`settle_s` when it differs from the last one."""
        if self._last_bias is None or not np.array_equal(bias, self._last_bias):
            self.now_s += self.settle_s
        self._last_bias = np.array(bias, dtype=float)

    def acquire(self, n_points: int, tones: int = 1) -> np.ndarray:
        """Measure ``n_points`` frequencies, ``tones`` per acquisition: each acquisition takes
        :attr:`dwell_s`; returns every point's time stamp (the end of its acquisition)."""
        acquisitions = np.arange(n_points) // max(int(tones), 1)
        times = self.now_s + (acquisitions + 1) * self.dwell_s
        self.now_s = float(times[-1]) if n_points else self.now_s
        return times

    # ------------------------------------------------------------------ the drifts
    def temperature_k(self, times_s: np.ndarray) -> np.ndarray:
        """``ΔT`` (K) at ``times_s`` (ascending, not before the last time asked)."""
        s = self.settings
        times_s = np.asarray(times_s, dtype=float)
        ramp = s.temperature_ramp_k_per_h * times_s / _HOUR
        if s.temperature_walk_k_per_sqrt_h == 0.0:
            return ramp
        walk = np.empty_like(times_s)
        for i, t in enumerate(times_s):
            dt = max(t - self._walk_at_s, 0.0)
            if dt > 0:
                step = s.temperature_walk_k_per_sqrt_h * math.sqrt(dt / _HOUR)
                self._walk_k += step * float(self._rng.standard_normal())
                self._walk_at_s = t
            walk[i] = self._walk_k
        return ramp + walk

    def charge_v(self, times_s: np.ndarray) -> np.ndarray:
        """Each electrode's effective bias offset (V) at ``times_s``: ``(N, n_e)``."""
        return np.asarray(times_s, dtype=float)[:, None] * self.charging_v_per_s[None, :]

    def sweep_factor(self) -> complex:
        """The analyzer's gain and phase for one acquisition sequence (a sweep)."""
        s = self.settings
        if s.gain_wander == 0.0 and s.phase_wander_deg == 0.0:
            return 1.0 + 0.0j
        g = s.gain_wander * float(self._rng.standard_normal())
        phi = math.radians(s.phase_wander_deg) * float(self._rng.standard_normal())
        return complex((1.0 + g) * np.exp(1j * phi))

    def stiffness_scale(self, delta_t_k: np.ndarray) -> np.ndarray:
        """The common factor on the stiffness at ``ΔT``: frequencies scale by its square root."""
        return (1.0 + self.settings.tempco_ppm_per_k * 1e-6 * np.asarray(delta_t_k)) ** 2

    def split_term(self, delta_t_k: np.ndarray, k_ref: np.ndarray, m: np.ndarray) -> np.ndarray:
        """The differential stiffness at ``ΔT``: ``(N, 2, 2)``.

        Along the modes of ``(k_ref, m)`` (the native state), it moves them apart by
        ``split_tempco_ppm_per_k`` of their mean frequency per kelvin (to first order).
        """
        coef = self.settings.split_tempco_ppm_per_k * 1e-6 * np.asarray(delta_t_k, dtype=float)
        lam_m, vec_m = np.linalg.eigh(m)
        root = vec_m @ np.diag(np.sqrt(lam_m)) @ vec_m.T
        inv_root = vec_m @ np.diag(1.0 / np.sqrt(lam_m)) @ vec_m.T
        lam, vec = np.linalg.eigh(inv_root @ k_ref @ inv_root)
        along = vec @ np.diag([-1.0, 1.0]) @ vec.T  # lower mode down, upper mode up
        shape = float(lam.mean()) * (root @ along @ root)
        return coef[:, None, None] * shape[None]


def bench_settings(device: str, bench: Mapping[str, Any] | BenchSettings | None) -> BenchSettings:
    """:meth:`BenchSettings.from_options` (the device factories' option ``bench``)."""
    return BenchSettings.from_options(device, bench)
