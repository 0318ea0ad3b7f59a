"""Device plugin ``post-resonator``: a simulated JPL post-resonator MEMS gyro.

The JPL post-resonator gyro (PRG) of Bae, Hayworth, Yee, Shcheglov and Wiberg, "High performance
MEMS micro-gyroscope", Proc. SPIE 4755 (2002): a silicon plate with a bonded central post whose two
rocking modes are degenerate by design and tuned electrostatically by bias electrodes under the
plate. Same protocol and same simulated hardware effects as the ``cloverleaf`` device
(:class:`sysid_simgyro.SimulatedGyro`).

Source of the parameters: ASSUMED
---------------------------------
The paper's figures (mode frequency, Q, native split, electrode count and structure potential)
could not be found in the sources available to us (searches of documentation, web pages, issue
trackers and code returned nothing on this paper). Every value below is therefore an assumption,
chosen to be plausible for a post-resonator gyro of this family and to exercise the toolkit in
ways the cloverleaf does not (four electrodes, a lower band, lower Q, a smaller native split). Do
not quote them as the paper's.

==========================  ==========================================================  ========
parameter                   value                                                       source
==========================  ==========================================================  ========
``v_gyro``                  12 V (above the DAC range: ``v_p > 0`` for every bias)       assumed
native modes                3318.4 and 3321.6 Hz (split 3.2 Hz), stiffer one along 22°  assumed
``K0``                      ``K_native − v_gyro² Σ K_p`` (mechanical modes 3326.6 and   derived
                            3329.7 Hz)
bias electrodes             four, B1..B4 at 0.3°, 45.8°, 89.6°, 135.4°                   assumed
``K_p``                     −(2π)² g_p (n_p n_pᵀ + 0.05 m_p m_pᵀ), g = 180, 172, 185,     assumed
                            176 Hz²/V²
``C``                       Q 18 000 and 22 000 along axes at −15°, ω_ref = 2π·3320      assumed
``R`` (pick-off)            [[1.02, −0.12], [0.18, 0.95]], velocity pick-off             assumed
``H_out``                   25 kHz gain 1.0; 23 431.26 Hz gain 0.98 (0.5° lag at 3320    assumed
                            Hz)
``band_hz``                 (3290, 3350) Hz                                             assumed
``bias_limits``             (−10, 10) V, 16-bit DAC                                      assumed
feedthrough shape           [[0.9, 0.3], [0.25, 1.0]], level given at 3320 Hz            assumed
extra modes                 translation 2150 Hz (Q 2500, 0.3 %), flexural 4450 Hz       assumed
                            (Q 2000, 0.15 %) and 5150 Hz (Q 2000, 0.08 %)
==========================  ==========================================================  ========

Tunability (checked by the tests): the exact two-electrode degenerate biases, the other electrodes
at 0 V, lie well inside ±10 V for the four non-collinear pairs: B1+B2 [−3.355, −3.276] V at
3317.48 Hz, B1+B4 [−3.316, 4.471] V at 3319.93 Hz, B2+B3 [−3.353, 4.608] V at 3320.06 Hz,
B3+B4 [4.528, 4.623] V at 3322.54 Hz. B1+B3 and B2+B4 act on the same anisotropy direction and
cannot tune the device.

Factory options (``[device]`` table) and their defaults are those of the ``cloverleaf``:
``noise = 1e-4``, ``feedthrough = 0.0125`` (at 3320 Hz), ``extra_modes = true``,
``dac_bits = 16``, ``seed = 0``, and ``params`` (Python only, a
:class:`PostResonatorParameters`). The native resonant peak is 0.7648 (V/V).
"""

from __future__ import annotations

from sysid_post_resonator.device import PostResonatorGyro
from sysid_post_resonator.params import POST_RESONATOR_EXTRA_MODES, PostResonatorParameters

__all__ = ["POST_RESONATOR_EXTRA_MODES", "PostResonatorGyro", "PostResonatorParameters"]
