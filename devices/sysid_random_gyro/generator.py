"""Drawing a random gyro from a seed: the ranges, the parameter set and :func:`draw_parameters`.

Every range below is a module constant, used by the drawing and checked by the tests; the table
of ``docs/random-gyro.md`` lists the same values. All stiffness is per unit modal mass, in
(rad/s)²; electrode gains are quoted in Hz²/V² (multiplied by (2π)²), as in
:mod:`sysid_simgyro.physics`.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from sysid_simgyro.effects import ExtraMode
from sysid_simgyro.params import GyroParameterSet
from sysid_simgyro.physics import TWO_PI, softening_stiffness

from sysid_core.device.simulation import GyroTruth

__all__ = [
    "BAND_BANDWIDTHS",
    "BAND_SPLITS",
    "BIAS_LAW_RANGE",
    "BIAS_LIMITS",
    "CORNER_RATIO_RANGE",
    "DIFFERENTIAL_PHASE_RANGE_DEG",
    "DYNAMICS",
    "ELECTRODE_COUNT_RANGE",
    "ELECTRODE_JITTER_DEG",
    "EXTRA_ABOVE_RANGE",
    "EXTRA_BELOW_RANGE",
    "EXTRA_LEVEL_RANGE",
    "EXTRA_MODE_COUNT_RANGE",
    "EXTRA_Q_RANGE",
    "F0_RANGE_HZ",
    "FEEDTHROUGH_RANGE",
    "GAIN_RANGE",
    "MINOR_RANGE",
    "MIN_NATIVE_SPLIT",
    "PAIR_MARGIN_DEG",
    "PICKOFF_SPREAD",
    "Q_RANGE",
    "SHIFT_RANGE",
    "TARGET_BIAS_MAX",
    "V_GYRO_RANGE",
    "RandomGyroParameters",
    "draw_parameters",
    "pair_margin_deg",
]

#: Degenerate frequency ``f0`` (Hz), log-uniform.
F0_RANGE_HZ: tuple[float, float] = (1_000.0, 30_000.0)
#: Quality factor of each principal damping axis, log-uniform.
Q_RANGE: tuple[float, float] = (5_000.0, 100_000.0)
#: Number of bias electrodes B1..Bn, uniform over the integers (inclusive).
ELECTRODE_COUNT_RANGE: tuple[int, int] = (2, 8)
#: Uniform jitter of each electrode axis around its even spacing (± degrees).
ELECTRODE_JITTER_DEG: float = 10.0
#: Least distance (degrees) of the B1-B2 axis difference from a multiple of 90°: electrodes 90°
#: apart act on the same anisotropy direction, so the pair could not tune every split.
PAIR_MARGIN_DEG: float = 20.0
#: Cross-axis softening ratio of each electrode (``minor`` of ``softening_stiffness``), uniform.
MINOR_RANGE: tuple[float, float] = (0.02, 0.08)
#: Shift of the mode along an electrode's axis per 10 V of its bias (linearised at 0 V), as a
#: fraction of ``f0``, uniform: ``g_p = s_p f0² / (10 |v_gyro|)`` Hz²/V².
SHIFT_RANGE: tuple[float, float] = (0.001, 0.005)
#: ``|v_gyro|`` (V), uniform; the sign is + or − with equal probability.
V_GYRO_RANGE: tuple[float, float] = (12.0, 20.0)
#: ``|β_p|`` (1/V²) of the bias law ``K_p w_p (1 + β_p δv_p²)``, uniform; random sign.
BIAS_LAW_RANGE: tuple[float, float] = (1e-3, 5e-3)
#: The degenerate bias ``b*`` of B1 and B2 is uniform in ``[-TARGET_BIAS_MAX, TARGET_BIAS_MAX]`` V
#: by default (a ``reach`` of 0.6 of the bias limits).
TARGET_BIAS_MAX: float = 6.0
#: Least native split (all biases 0 V) as a fraction of ``f0``; ``b*`` is re-drawn below it.
MIN_NATIVE_SPLIT: float = 2e-4
#: Capacitive feedthrough at the band centre relative to the native peak, log-uniform.
FEEDTHROUGH_RANGE: tuple[float, float] = (1e-3, 3e-2)
#: Number of out-of-band modes, uniform over the integers (inclusive).
EXTRA_MODE_COUNT_RANGE: tuple[int, int] = (0, 3)
#: Frequency of an extra mode below the band, as a multiple of ``f0`` (uniform).
EXTRA_BELOW_RANGE: tuple[float, float] = (0.5, 0.85)
#: Frequency of an extra mode above the band, as a multiple of ``f0`` (uniform).
EXTRA_ABOVE_RANGE: tuple[float, float] = (1.2, 2.5)
#: Quality factor of an extra mode, log-uniform.
EXTRA_Q_RANGE: tuple[float, float] = (1_000.0, 10_000.0)
#: Size of an extra mode at the band centre relative to the native peak, log-uniform.
EXTRA_LEVEL_RANGE: tuple[float, float] = (3e-4, 3e-3)
#: Corner of channel 1 of the signal-conditioning low-pass as a multiple of ``f0`` (uniform).
CORNER_RATIO_RANGE: tuple[float, float] = (5.0, 20.0)
#: Phase lag of channel 2 relative to channel 1 at ``f0`` (degrees), uniform.
DIFFERENTIAL_PHASE_RANGE_DEG: tuple[float, float] = (0.2, 1.5)
#: DC gain of each low-pass channel, uniform.
GAIN_RANGE: tuple[float, float] = (0.95, 1.05)
#: Pick-off matrix ``R = I + E`` with the entries of ``E`` uniform in ``±PICKOFF_SPREAD``.
PICKOFF_SPREAD: float = 0.2
#: Bias limits (V), also the DAC's range.
BIAS_LIMITS: tuple[float, float] = (-10.0, 10.0)
#: The band reaches this many native splits beyond the modes ...
BAND_SPLITS: float = 10.0
#: ... or this many half-power bandwidths ``f0 / Q_min``, whichever is more.
BAND_BANDWIDTHS: float = 30.0
#: Where the signal-conditioning low-pass sits: on the pick-offs or on the actuators.
DYNAMICS: tuple[str, str] = ("output", "input")


def _log_uniform(rng: np.random.Generator, bounds: tuple[float, float]) -> float:
    return float(np.exp(rng.uniform(np.log(bounds[0]), np.log(bounds[1]))))


def pair_margin_deg(angle_a_deg: float, angle_b_deg: float) -> float:
    """Distance (degrees) of ``angle_b - angle_a`` from the nearest multiple of 90°.

    Two nearly rank-one electrodes change the anisotropy along the directions ``2θ``; the pair
    can cancel any anisotropy (the rank condition) iff this is not 0. 45° is the best pair.
    """
    d = (angle_b_deg - angle_a_deg) % 90.0
    return float(min(d, 90.0 - d))


@dataclass(frozen=True)
class RandomGyroParameters(GyroParameterSet):
    """A drawn gyro: every physical parameter, in the units of :mod:`sysid_simgyro.physics`.

    Built by :func:`draw_parameters` (its docstring and ``docs/random-gyro.md`` give the
    distributions); frozen, so two draws compare equal field by field.

    Parameters
    ----------
    seed : int
        The seed it was drawn from.
    f0_hz : float
        Frequency of both modes at the degenerate bias ``b*`` (Hz).
    structure_potential : float
        ``v_gyro`` (V), either sign.
    electrodes : tuple of str
        ``B1``..``Bn``.
    electrode_angles_deg, electrode_gains_hz2, electrode_minors : tuple of float
        ``θ_p``, ``g_p`` and cross-axis ratio of ``K_p = −(2π)² g_p (n_p n_pᵀ + minor_p m_p m_pᵀ)``.
    electrode_shifts : tuple of float
        ``s_p``: the shift per 10 V each gain was set from (fraction of ``f0``).
    bias_law : tuple of float
        ``β_p`` (1/V²): electrode ``p`` adds ``K_p w_p (1 + β_p δv_p²)``.
    degenerate_bias : tuple of float
        ``b*`` (V), one per electrode (0 V except B1 and B2).
    k0 : 2×2 tuple
        ``K0`` ((rad/s)²), made so that ``K(b*) = (2π f0)² I``.
    q, damping_axis_deg, omega_ref_hz
        Principal quality factors, first principal damping axis, reference frequency (``f0``).
    pickoff, velocity_pickoff
        ``R``; velocity pick-off (always true).
    dynamics : str
        ``"output"`` (low-pass on the pick-offs, ``H_out``) or ``"input"`` (on the actuators,
        ``H_in``).
    corner_hz, gains, differential_phase_deg, phase_reference_hz
        The low-pass: channel 1 corner, DC gains, lag of channel 2 at ``phase_reference_hz``
        (``f0``).
    band_hz, bias_limits
        Band of the two modes (Hz); bias limits (V).
    feedthrough_level : float
        Drawn capacitive feedthrough at the band centre relative to the native peak.
    feedthrough_shape, feedthrough_reference_hz
        Relative parasitic capacitances (entries in [−1, 1]); where the level is given.
    extra_modes : tuple of ExtraMode
        Drawn out-of-band modes.
    native_modes_hz : pair of float
        Undamped modes with every bias at 0 V (derived, for reports and checks).
    """

    seed: int
    f0_hz: float
    structure_potential: float
    electrodes: tuple[str, ...]
    electrode_angles_deg: tuple[float, ...]
    electrode_gains_hz2: tuple[float, ...]
    electrode_minors: tuple[float, ...]
    electrode_shifts: tuple[float, ...]
    bias_law: tuple[float, ...]
    degenerate_bias: tuple[float, ...]
    k0: tuple[tuple[float, float], tuple[float, float]]
    q: tuple[float, float]
    damping_axis_deg: float
    omega_ref_hz: float
    pickoff: tuple[tuple[float, float], tuple[float, float]]
    velocity_pickoff: bool
    dynamics: str
    corner_hz: float
    gains: tuple[float, float]
    differential_phase_deg: float
    phase_reference_hz: float
    band_hz: tuple[float, float]
    bias_limits: tuple[float, float]
    feedthrough_level: float
    feedthrough_shape: tuple[tuple[float, float], tuple[float, float]]
    feedthrough_reference_hz: float
    extra_modes: tuple[ExtraMode, ...]
    native_modes_hz: tuple[float, float]

    def stiffness(self) -> np.ndarray:
        """``K0`` in (rad/s)²."""
        return np.asarray(self.k0, dtype=float)

    def electrode_stiffness(self) -> np.ndarray:
        """``K_p`` in (rad/s)²/V², shape ``(n_e, 2, 2)``, each with its own cross-axis ratio."""
        return np.array(
            [
                softening_stiffness(g, th, minor)
                for g, th, minor in zip(
                    self.electrode_gains_hz2,
                    self.electrode_angles_deg,
                    self.electrode_minors,
                    strict=True,
                )
            ]
        )

    def truth(self) -> GyroTruth:
        """The exact two-mode model (``B = I``, bias law ``β``, the low-pass where drawn)."""
        lowpass = self.output_lowpass()
        return GyroTruth(
            M=np.eye(2),
            C=self.damping(),
            K0=self.stiffness(),
            Kp=self.electrode_stiffness(),
            structure_potential=self.structure_potential,
            electrodes=self.electrodes,
            R=np.asarray(self.pickoff, dtype=float),
            B=np.eye(2),
            velocity_pickoff=self.velocity_pickoff,
            h_out=lowpass if self.dynamics == "output" else None,
            h_in=lowpass if self.dynamics == "input" else None,
            bias_law=np.asarray(self.bias_law, dtype=float),
        )


def _pair(values: np.ndarray) -> tuple[float, float]:
    return float(values[0]), float(values[1])


def _matrix(values: np.ndarray) -> tuple[tuple[float, float], tuple[float, float]]:
    return _pair(values[0]), _pair(values[1])


def _electrode_angles(rng: np.random.Generator, n: int) -> np.ndarray:
    """Axes spread over [0°, 180°) with a random offset and jitter; B1-B2 well conditioned."""
    offset = rng.uniform(0.0, 180.0)
    # Evenly spaced over [0°, 180°); two electrodes go 45° apart instead (90° apart they would
    # act on the same anisotropy direction).
    spacing = 45.0 if n == 2 else 180.0 / n
    while True:
        jitter = rng.uniform(-ELECTRODE_JITTER_DEG, ELECTRODE_JITTER_DEG, n)
        angles = (offset + spacing * np.arange(n) + jitter) % 180.0
        if pair_margin_deg(angles[0], angles[1]) >= PAIR_MARGIN_DEG:
            return angles


def _extra_modes(rng: np.random.Generator, f0: float) -> tuple[ExtraMode, ...]:
    count = int(rng.integers(EXTRA_MODE_COUNT_RANGE[0], EXTRA_MODE_COUNT_RANGE[1] + 1))
    modes = []
    for k in range(count):
        below = bool(rng.random() < 0.5)
        ratio = rng.uniform(*(EXTRA_BELOW_RANGE if below else EXTRA_ABOVE_RANGE))
        q = _log_uniform(rng, EXTRA_Q_RANGE)
        pickoff = _pair(rng.uniform(-1.0, 1.0, 2))
        actuation = _pair(rng.uniform(-1.0, 1.0, 2))
        level = _log_uniform(rng, EXTRA_LEVEL_RANGE)
        side = "below" if below else "above"
        modes.append(
            ExtraMode(
                float(ratio * f0), q, pickoff, actuation, level, f"extra mode {k + 1} ({side})"
            )
        )
    return tuple(modes)


def draw_parameters(
    seed: int, dynamics: str = "random", reach: float | None = None
) -> RandomGyroParameters:
    """Draw the gyro of ``seed`` (every value from ``np.random.default_rng([seed, 0])``).

    The draws, in this order (ranges are the module constants):

    1. ``f0`` log-uniform in :data:`F0_RANGE_HZ`; ``Q₁, Q₂`` log-uniform in :data:`Q_RANGE`;
       the damping axis uniform in [0°, 180°).
    2. ``n`` uniform in :data:`ELECTRODE_COUNT_RANGE`; axes evenly spaced over [0°, 180°)
       (45° apart if ``n = 2``) from a uniform offset, each jittered by
       ±:data:`ELECTRODE_JITTER_DEG`, the jitter re-drawn until B1 and B2 are at least
       :data:`PAIR_MARGIN_DEG` from acting on the same anisotropy direction
       (:func:`pair_margin_deg`); cross-axis ratios uniform in :data:`MINOR_RANGE`.
    3. ``v_gyro``: random sign, magnitude uniform in :data:`V_GYRO_RANGE`; shifts ``s_p``
       uniform in :data:`SHIFT_RANGE`, gains ``g_p = s_p f0² / (10 |v_gyro|)`` Hz²/V²; bias law
       ``β_p`` of random sign with magnitude uniform in :data:`BIAS_LAW_RANGE`.
    4. ``b*`` on B1, B2 uniform in ±:data:`TARGET_BIAS_MAX` (others 0 V), or in ``±reach``
       times the bias limit;
       ``K0 = λ I − Σ_p K_p w_p(b*) (1 + β_p b*_p²)`` with ``λ = (2π f0)²``, re-drawn until the
       native split is at least :data:`MIN_NATIVE_SPLIT` ``· f0``.
    5. Feedthrough level log-uniform in :data:`FEEDTHROUGH_RANGE`, shape uniform in [−1, 1];
       :data:`EXTRA_MODE_COUNT_RANGE` extra modes (see :func:`_extra_modes`); the pick-off
       ``R = I ± PICKOFF_SPREAD``.
    6. Dynamics: a uniform number decides output or input (always drawn, so that choosing
       ``dynamics`` changes nothing else); corner ratio, differential phase and gains.

    Parameters
    ----------
    seed : int
        Non-negative seed.
    dynamics : {"random", "output", "input"}
        Where the signal-conditioning low-pass sits; ``"random"`` uses the drawn choice.
    reach : float, optional
        How far into its bias limits the gyro's degenerate bias may lie (0 < reach <= 1; default
        :data:`TARGET_BIAS_MAX` over the limit, 0.6). The same seed with another reach is the
        same gyro but for ``b*`` (the same uniform draws, scaled) and ``K0``.

    Returns
    -------
    RandomGyroParameters
    """
    if dynamics not in ("random", *DYNAMICS):
        raise ValueError(f"dynamics must be 'random', 'output' or 'input', got {dynamics!r}")
    if reach is not None and not 0.0 < reach <= 1.0:
        raise ValueError(f"reach must be in (0, 1], got {reach!r}")
    far = TARGET_BIAS_MAX if reach is None else float(reach) * BIAS_LIMITS[1]
    rng = np.random.default_rng([seed, 0])

    f0 = _log_uniform(rng, F0_RANGE_HZ)
    q = (_log_uniform(rng, Q_RANGE), _log_uniform(rng, Q_RANGE))
    damping_axis = float(rng.uniform(0.0, 180.0))

    n = int(rng.integers(ELECTRODE_COUNT_RANGE[0], ELECTRODE_COUNT_RANGE[1] + 1))
    angles = _electrode_angles(rng, n)
    minors = rng.uniform(*MINOR_RANGE, n)

    v_sign = 1.0 if rng.random() < 0.5 else -1.0
    v_gyro = v_sign * float(rng.uniform(*V_GYRO_RANGE))
    shifts = rng.uniform(*SHIFT_RANGE, n)
    gains_hz2 = shifts * f0**2 / (10.0 * abs(v_gyro))
    beta = np.where(rng.random(n) < 0.5, -1.0, 1.0) * rng.uniform(*BIAS_LAW_RANGE, n)

    kp = np.array(
        [softening_stiffness(g, th, m) for g, th, m in zip(gains_hz2, angles, minors, strict=True)]
    )
    lam = (TWO_PI * f0) ** 2
    while True:
        target = np.zeros(n)
        target[:2] = rng.uniform(-far, far, 2)
        w = (v_gyro - target) ** 2 * (1.0 + beta * target**2)
        k0 = lam * np.eye(2) - np.tensordot(w, kp, axes=1)
        k0 = 0.5 * (k0 + k0.T)
        native = np.sqrt(np.linalg.eigvalsh(k0 + v_gyro**2 * kp.sum(axis=0))) / TWO_PI
        if native[1] - native[0] >= MIN_NATIVE_SPLIT * f0:
            break

    feedthrough = _log_uniform(rng, FEEDTHROUGH_RANGE)
    feedthrough_shape = rng.uniform(-1.0, 1.0, (2, 2))
    extra = _extra_modes(rng, f0)
    pickoff = np.eye(2) + rng.uniform(-PICKOFF_SPREAD, PICKOFF_SPREAD, (2, 2))

    drawn = DYNAMICS[0] if rng.random() < 0.5 else DYNAMICS[1]
    corner = float(rng.uniform(*CORNER_RATIO_RANGE)) * f0
    phase = float(rng.uniform(*DIFFERENTIAL_PHASE_RANGE_DEG))
    lp_gains = _pair(rng.uniform(*GAIN_RANGE, 2))

    split = float(native[1] - native[0])
    half = max(BAND_SPLITS * split, BAND_BANDWIDTHS * f0 / min(q))
    low = np.floor(10.0 * (min(native[0], f0) - half)) / 10.0
    high = np.ceil(10.0 * (max(native[1], f0) + half)) / 10.0

    return RandomGyroParameters(
        seed=int(seed),
        f0_hz=f0,
        structure_potential=v_gyro,
        electrodes=tuple(f"B{p + 1}" for p in range(n)),
        electrode_angles_deg=tuple(float(a) for a in angles),
        electrode_gains_hz2=tuple(float(g) for g in gains_hz2),
        electrode_minors=tuple(float(m) for m in minors),
        electrode_shifts=tuple(float(s) for s in shifts),
        bias_law=tuple(float(b) for b in beta),
        degenerate_bias=tuple(float(b) for b in target),
        k0=_matrix(k0),
        q=q,
        damping_axis_deg=damping_axis,
        omega_ref_hz=f0,
        pickoff=_matrix(pickoff),
        velocity_pickoff=True,
        dynamics=drawn if dynamics == "random" else dynamics,
        corner_hz=corner,
        gains=lp_gains,
        differential_phase_deg=phase,
        phase_reference_hz=f0,
        band_hz=(float(low), float(high)),
        bias_limits=BIAS_LIMITS,
        feedthrough_level=feedthrough,
        feedthrough_shape=_matrix(feedthrough_shape),
        feedthrough_reference_hz=float(0.5 * (low + high)),
        extra_modes=extra,
        native_modes_hz=_pair(native),
    )
