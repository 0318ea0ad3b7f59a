"""The ``random-gyro`` device: a simulated gyro drawn from a seed."""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any, ClassVar

import numpy as np
from sysid_simgyro.device import ParametrizedGyro
from sysid_simgyro.options import as_bool, as_dac_bits, as_fraction, as_seed

from sysid_core.errors import ConfigError
from sysid_random_gyro.generator import DYNAMICS, RandomGyroParameters, draw_parameters

__all__ = ["RandomGyro"]

#: The model structure that matches each kind of dynamics (Kim & M'Closkey, eq. 7 and 10).
STRUCTURES: dict[str, str] = {"output": "act", "input": "sen"}


class RandomGyro(ParametrizedGyro):
    """A simulated gyro drawn from ``seed``: the same seed, the same gyro and the same noise.

    The parameters come from ``np.random.default_rng([seed, 0])`` (see
    :func:`sysid_random_gyro.generator.draw_parameters` and ``docs/random-gyro.md``), the
    measurement noise from a separate stream, ``np.random.default_rng([seed, 1])``: drawing the
    gyro does not depend on the noise, nor the noise on the options. ``noise_seed`` selects
    another draw of the noise for the same gyro (``default_rng([seed, 2, noise_seed])``): the
    spread of a population's result over draws is what a comparison of two codes must beat.

    What is drawn (ranges in :mod:`sysid_random_gyro.generator`):

    * degenerate frequency ``f0`` log-uniform in 1-30 kHz; unit modal mass; ``Q`` of the two
      principal damping axes log-uniform in 5e3-1e5, damping axis uniform in [0°, 180°);
    * 2-8 bias electrodes B1..Bn (uniform count), axes evenly spaced over [0°, 180°) (45° apart
      for two) from a random offset with ±10° jitter each, B1 and B2 at least 20° from acting
      on the same anisotropy direction (their axis difference at least 20° from a multiple of
      90°); nearly rank-one softening ``K_p`` with cross-axis ratio 0.02-0.08; gains such that
      10 V on one electrode moves the mode along its axis by 0.1-0.5 % of ``f0`` (linearised at
      0 V): ``g_p = s_p f0² / (10 |v_gyro|)`` Hz²/V²;
    * ``v_gyro`` of random sign, ``|v_gyro|`` uniform in 12-20 V (the bias limits are ±10 V, so
      ``v_p = v_gyro − δv_p`` never crosses 0);
    * a bias law off ``v²``: electrode ``p`` adds ``K_p w_p (1 + β_p δv_p²)``,
      ``w_p = (v_gyro − δv_p)²``, ``β_p`` of random sign with ``|β_p|`` uniform in
      1e-3-5e-3 /V²;
    * the degenerate bias ``b*`` of B1 and B2 uniform in ±6 V (others 0 V; option ``reach``:
      in ± ``reach`` × 10 V, the same gyro otherwise), and
      ``K0 = λ I − Σ_p K_p w_p(b*) (1 + β_p b*_p²)``, ``λ = (2π f0)²``: both modes are at ``f0``
      at ``b*``. ``b*`` is re-drawn until the native split (all biases 0 V) is at least 0.02 %
      of ``f0``;
    * capacitive feedthrough at the band centre log-uniform in 0.1-3 % of the native peak, shape
      uniform in [−1, 1] per entry;
    * 0-3 out-of-band modes at 0.5-0.85 or 1.2-2.5 × ``f0``, Q log-uniform 1e3-1e4, random
      pick-off and actuation shapes, level log-uniform 3e-4-3e-3 of the native peak;
    * dynamics: first-order low-passes on the pick-offs (``"output"``, ``H_out``) or on the
      actuators (``"input"``, ``H_in``), 50/50; channel 1 corner 5-20 × ``f0``, channel 2
      lagging by 0.2-1.5° at ``f0``, DC gains 0.95-1.05;
    * pick-off ``R = I + E``, entries of ``E`` uniform in ±0.2; velocity pick-off; ``B = I``;
    * ``band_hz``: from ``min(native, f0) − h`` to ``max(native, f0) + h`` with
      ``h = max(10 × native split, 30 f0 / min Q)``, rounded outward to 0.1 Hz.

    Parameters
    ----------
    seed : int, default 0
        Non-negative: selects the gyro and the noise sequence.
    noise_seed : int or None, default None
        Non-negative: another noise sequence for the same gyro; ``None`` keeps the seed's.
    noise : float, default 1e-4
        Complex measurement noise per point, relative to the native resonant peak.
    dac_bits : int, default 16
        Bias DAC resolution over ±10 V; 0 applies biases exactly.
    dynamics : {"random", "output", "input"}, default "random"
        Where the low-pass sits; ``"random"`` keeps the seed's draw. Nothing else changes.
    feedthrough : float or None, default None
        Feedthrough level relative to the native peak; ``None`` keeps the seed's draw.
    extra_modes : bool, default True
        Add the seed's out-of-band modes.
    bench : table, optional
        ``[device.bench]``: a clock and slow drifts (:mod:`sysid_simgyro.bench`).
    reach : float, optional
        How far into the ±10 V limits the degenerate bias of B1 and B2 may lie (0 < reach <= 1;
        default 0.6: ±6 V). A far reach asks a run to extrapolate its first model further.

    Attributes
    ----------
    params : RandomGyroParameters
        Everything drawn.
    dynamics : str
        ``"output"`` or ``"input"``.
    structure : str
        The model structure that matches: ``"act"`` for output dynamics, ``"sen"`` for input.

    Raises
    ------
    ConfigError
        For an unknown option (named in the message) or a bad value.
    """

    name: ClassVar[str] = "random-gyro"
    description: ClassVar[str] = (
        "Seeded random simulated gyro (1-30 kHz, 2-8 electrodes, non-v² law)"
    )
    parameters_class: ClassVar[type[RandomGyroParameters]] = RandomGyroParameters
    options: ClassVar[tuple[str, ...]] = (
        "seed",
        "noise_seed",
        "noise",
        "dac_bits",
        "dynamics",
        "feedthrough",
        "extra_modes",
        "bench",
        "reach",
    )

    def __init__(
        self,
        *,
        seed: int = 0,
        noise_seed: int | None = None,
        noise: float = 1e-4,
        dac_bits: int = 16,
        dynamics: str = "random",
        feedthrough: float | None = None,
        extra_modes: bool = True,
        bench: Mapping[str, Any] | None = None,
        reach: float | None = None,
    ) -> None:
        checked_seed = as_seed(self.name, "seed", seed)
        if checked_seed is None:
            raise ConfigError(
                f"option 'seed' of device {self.name!r} must be a non-negative integer (it "
                "selects the gyro), got None"
            )
        if not isinstance(dynamics, str) or dynamics not in ("random", *DYNAMICS):
            raise ConfigError(
                f"option 'dynamics' of device {self.name!r} must be 'random', 'output' or "
                f"'input', got {dynamics!r}"
            )
        checked_noise_seed = as_seed(self.name, "noise_seed", noise_seed)
        as_fraction(self.name, "noise", noise)
        as_dac_bits(self.name, "dac_bits", dac_bits)
        as_bool(self.name, "extra_modes", extra_modes)
        if feedthrough is not None:
            as_fraction(self.name, "feedthrough", feedthrough)
        if reach is not None and not (
            isinstance(reach, (int, float)) and not isinstance(reach, bool) and 0 < reach <= 1
        ):
            raise ConfigError(
                f"option 'reach' of device {self.name!r} must be a number in (0, 1] (how far into "
                f"its bias limits the degenerate bias may lie), got {reach!r}"
            )
        params = draw_parameters(checked_seed, dynamics, reach)
        super().__init__(
            noise=noise,
            feedthrough=params.feedthrough_level if feedthrough is None else feedthrough,
            extra_modes=extra_modes,
            dac_bits=dac_bits,
            seed=checked_seed,
            bench=bench,
            params=params,
        )
        self.params: RandomGyroParameters = params
        #: Where the low-pass sits: ``"output"`` or ``"input"``.
        self.dynamics: str = params.dynamics
        #: The model structure that matches the dynamics (``act`` or ``sen``).
        self.structure: str = STRUCTURES[params.dynamics]
        # The noise stream, separate from the parameters' stream default_rng([seed, 0]).
        # Another draw has its own stream: numpy seeds [s, 1, 0] as [s, 1].
        own = checked_noise_seed is None
        stream = [checked_seed, 1] if own else [checked_seed, 2, checked_noise_seed]
        self._rng = np.random.default_rng(stream)
        #: The noise draw (None: the seed's own).
        self.noise_seed: int | None = checked_noise_seed
        self._degenerate: np.ndarray | None = None

    @property
    def f0_hz(self) -> float:
        """Frequency of both modes at the degenerate bias (Hz)."""
        return self.params.f0_hz

    def true_degenerate_bias(self) -> np.ndarray:
        """The exact degenerate bias of B1 and B2, every other electrode at 0 V (volts).

        Solved from the truth (:meth:`sysid_core.device.simulation.GyroTruth.degenerate_bias` on
        electrodes (0, 1)); equal to the drawn ``params.degenerate_bias`` to solver precision.
        A copy: changing it changes nothing.
        """
        if self._degenerate is None:
            self._degenerate = self.truth.degenerate_bias((0, 1))
        return self._degenerate.copy()

    def describe(self) -> str:
        """One line: f0, electrodes, v_gyro, dynamics, feedthrough level, extra modes."""
        p = self.params
        native = p.native_modes_hz[1] - p.native_modes_hz[0]
        return (
            f"random-gyro seed {p.seed}: f0 = {p.f0_hz:.3f} Hz, {len(p.electrodes)} electrodes "
            f"({p.electrodes[0]}-{p.electrodes[-1]}), v_gyro = {p.structure_potential:+.3f} V, "
            f"{self.dynamics} dynamics (structure {self.structure!r}), feedthrough "
            f"{100 * self.feedthrough:.3g} % of the peak, {len(self.extra_modes)} extra "
            f"mode(s), native split {native:.4g} Hz, band {p.band_hz[0]:g}-{p.band_hz[1]:g} Hz"
        )

    def __repr__(self) -> str:
        return (
            f"RandomGyro(seed={self.seed}, noise={self.noise}, dac_bits={self.dac_bits}, "
            f"dynamics={self.dynamics!r}): f0={self.params.f0_hz:.3f} Hz, "
            f"{len(self.electrodes)} electrodes, v_gyro={self.structure_potential:+.3f} V, "
            f"{self.dynamics} dynamics, feedthrough={self.feedthrough:.3g}, "
            f"{len(self.extra_modes)} extra mode(s)"
        )
