"""Device plugin ``cloverleaf``: a simulated JPL-Boeing cloverleaf MEMS gyro.

The device of Kim & M'Closkey (2006), Section III: a cloverleaf plate with a central post whose
two rocking modes near 4.4 kHz are tuned by three bias electrodes E_B1..E_B3 (here ``B1``, ``B2``,
``B3``). The two-mode truth is a :class:`sysid_core.device.simulation.GyroTruth` (kept as the
device's ``truth`` attribute); :class:`sysid_simgyro.SimulatedGyro` adds noise, feedthrough,
out-of-band modes and DAC quantisation.

Calibration source
------------------
``docs/cloverleaf.md``: a least-squares fit of a 2-DOF model (M = I,
three nearly rank-one softening electrodes, ``v_p = v_gyro − δv_p``) to every number Section III
of the paper publishes. In the table, "calib." marks its fitted figures, "paper" values the paper
states directly, and "design" the design choices of the calibration note (values the paper does
not constrain).

Parameters (unit modal mass; K in (rad/s)², shown divided by (2π)² in Hz²)
---------------------------------------------------------------------------
======================  =============================================================  ========
parameter               value                                                          source
======================  =============================================================  ========
``v_gyro``              +15.58 V (so every δv in ±10 V has ``v_p > 0``)                 calib.
``K0 / (2π)²``          [[19706390.62, 21303.38], [21303.38, 19724860.06]] Hz²         calib.
``K_p``                 −(2π)² g_p (n_p n_pᵀ + 0.05 m_p m_pᵀ), n_p at angle θ_p        calib.
B1                      θ = 0°, g = 290.39 Hz²/V²                                       calib.
B2                      θ = 45°, g = 368.39 Hz²/V²                                      calib.
B3                      θ = 90.51°, g = 299.44 Hz²/V²                                   calib.
``C``                   ω_ref U diag(1/45 000, 1/60 000) Uᵀ, U at 60°,                  design
                        ω_ref = 2π·4427 rad/s
``R`` (pick-off)        [[0.97, 0.23], [−0.15, 1.04]], velocity pick-off                design
``B`` (actuators)       identity                                                        design
``H_out``               first-order low-passes: 20 kHz gain 1.0; 18 467.37 Hz gain      design
                        0.97 (corner solved so channel 2 lags by exactly 1.000° at
                        4430 Hz, the paper's "about 1°")
``band_hz``             (4385, 4445) Hz, the paper's measurement band                   paper
``bias_limits``         (−10, 10) V, the DAC range                                      paper
======================  =============================================================  ========

Resulting ground truth (no noise): native modes 4423.955 and 4428.955 Hz (split 4.9998 Hz),
Q 47 216 and 56 445; the exact two-electrode degenerate bias (B3 at 0 V) is
[2.0407, 4.3882, 0] V at 4430.044 Hz.

Effects outside the model class (keyword options of the factory, i.e. of ``[device]``)
-------------------------------------------------------------------------------------
``noise`` = 1e-4
    Complex Gaussian noise per response entry and frequency point with ``E|n|² = (noise·peak)²``,
    ``peak`` = 1.4967 (V/V) being the largest ``|response|`` entry of the native state (all
    biases 0 V). Independent draws on every :meth:`measure` call.
``feedthrough`` = 0.0125
    Parasitic capacitive coupling ``jω C_par`` (∝ frequency, the trend of the paper's Fig. 2),
    ``C_par`` ∝ [[1.0, 0.35], [0.55, 0.8]] (design choice), scaled so its largest entry at
    4415 Hz is 1.25 % of ``peak``. It passes through ``H_out`` like the motional signal. Near the
    band edges it is larger than the motional response, and it makes the anti-resonance notches
    ("charge cancellation") of real data.
``extra_modes`` = true
    Three out-of-band modes (design choice after Fig. 2), each ``jω a r bᵀ / (ω_m² − ω² + jωω_m/Q)``
    with its size at the band centre relative to ``peak``: translation along the post 2.7 kHz,
    Q 3000, 0.3 % (its own peak is ≈ 9× the gyro modes'); flexural modes at 5.6 kHz (Q 2000,
    0.1 %) and 6.3 kHz (Q 2000, 0.06 %). See :data:`sysid_cloverleaf.params.CLOVERLEAF_EXTRA_MODES`.
``dac_bits`` = 16
    The applied bias is the nearest code of a 16-bit bipolar DAC over ±10 V (step 0.305 mV; 0 V
    exact; +10 V applies 10 V − 1 step). ``0`` applies biases exactly. ``applied_bias(bias)``
    returns it; ``true_modal_frequencies_hz`` uses it too.
``seed`` = 0
    Seed of the noise generator (``None``: fresh entropy). The same seed gives identical
    measurement sequences.
``params``
    Python only: another :class:`CloverleafParameters`.

Unknown options raise :class:`sysid_core.errors.ConfigError` naming the option; ``measure``
refuses (``BiasLimitError``) a bias outside ±10 V or with other than three values.
"""

from __future__ import annotations

from sysid_cloverleaf.device import CloverleafGyro
from sysid_cloverleaf.params import CLOVERLEAF_EXTRA_MODES, CloverleafParameters

__all__ = ["CLOVERLEAF_EXTRA_MODES", "CloverleafGyro", "CloverleafParameters"]
