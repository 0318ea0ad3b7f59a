"""Device plugin ``random-gyro``: a seeded generator of random simulated gyros.

Each seed gives a different, plausible electrostatically tuned two-mode gyro: mode frequency,
damping, number and layout of bias electrodes, structure potential of either sign, a bias law
that deviates from ``v²``, feedthrough, out-of-band modes and input or output signal
conditioning are drawn from ``np.random.default_rng([seed, 0])``; the measurement noise comes
from ``np.random.default_rng([seed, 1])``. The same seed gives the same gyro and the same noise
sequence. Every gyro is tunable by construction: its mechanical stiffness ``K0`` is made so that
B1 and B2 make the modes exactly degenerate at a drawn bias ``b*`` inside ±6 V
(:meth:`RandomGyro.true_degenerate_bias`).

It is meant for testing the toolkit on many gyros it was not tuned on (studies over seeds), not
as a model of any particular device. The distributions are in ``docs/random-gyro.md`` and in
:mod:`sysid_random_gyro.generator`; the device is :class:`RandomGyro`, built on
:class:`sysid_simgyro.ParametrizedGyro` like ``cloverleaf`` and ``post-resonator``.

Factory options (``[device]`` table): ``seed = 0``, ``noise = 1e-4``, ``dac_bits = 16``,
``dynamics = "random"`` (or ``"output"``, ``"input"``), ``feedthrough`` (the drawn level unless
given), ``extra_modes = true``.
"""

from __future__ import annotations

from sysid_random_gyro.device import RandomGyro
from sysid_random_gyro.generator import RandomGyroParameters, draw_parameters

__all__ = ["RandomGyro", "RandomGyroParameters", "draw_parameters"]
