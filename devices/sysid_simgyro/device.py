"""A simulated gyro: the exact truth model plus what real hardware adds to a measurement."""

from __future__ import annotations

import hashlib
from collections.abc import Mapping, Sequence
from typing import Any, ClassVar

import numpy as np
import xarray as xr

from sysid_core.device.simulation import GyroTruth
from sysid_core.errors import BiasLimitError, ConfigError, FrequencyGridError
from sysid_core.model.modal import modal_analysis
from sysid_simgyro.bench import Bench, BenchSettings
from sysid_simgyro.effects import ExtraMode, peak_magnitude, quantize_bias
from sysid_simgyro.options import (
    COMMON_OPTIONS,
    as_bool,
    as_dac_bits,
    as_fraction,
    as_seed,
)
from sysid_simgyro.params import GyroParameterSet
from sysid_simgyro.physics import TWO_PI

__all__ = ["NOISE_SUBSAMPLES", "ParametrizedGyro", "SimulatedGyro"]

#: Sub-integrations per acquisition from whose spread the reported ``noise_var`` is estimated
#: (as a lock-in estimates it from its sample buffer).
NOISE_SUBSAMPLES = 16
#: Mixed into the seed of each measurement's noise-estimate generator
#: (:meth:`SimulatedGyro.noise_estimate`), which is derived from the response noise
#: generator's state without drawing from it.
NOISE_ESTIMATE_STREAM = 2


class SimulatedGyro:
    """A simulated two-mode gyro that follows the :class:`~sysid_core.plugin.interfaces.Device`
    protocol.

    A measurement at bias ``dv`` and frequency ``ω`` is

    .. math::

        ψ(ω) = G(ω; Q(dv)) + H_{out}(ω)\\Big(jωC_{par} + \\sum_m \\text{extra mode}_m(ω)\\Big)
               H_{in}(ω) + n,

    where ``G`` is the exact two-mode response of :attr:`truth`, ``Q(dv)`` the bias the DAC really
    applies, ``C_par`` the parasitic capacitive feedthrough, the extra modes are out-of-band
    structural resonances (:class:`~sysid_simgyro.effects.ExtraMode`) and ``n`` complex Gaussian
    noise. Feedthrough and extra modes pass through the same signal conditioning as the motional
    signal, as they do in hardware.

    Parameters
    ----------
    truth : GyroTruth
        The exact physical model; kept as :attr:`truth`.
    band_hz : pair of float
        Where the two modes are (Hz).
    bias_limits : pair of float
        Allowed bias (volts), also the DAC's range.
    noise : float
        Standard deviation of the complex noise per response entry and point, relative to
        :attr:`peak_magnitude`: ``E|n|² = (noise · peak)²``, real and imaginary parts independent
        with equal variance.
    feedthrough : float
        Size of ``jωC_par`` at ``feedthrough_reference_hz``: its largest entry is ``feedthrough``
        times :attr:`peak_magnitude`.
    feedthrough_shape : array_like, shape (2, 2)
        Relative parasitic capacitances (real; scaled to a largest entry of 1).
    feedthrough_reference_hz : float, optional
        Where ``feedthrough`` is specified; default the band centre.
    extra_modes : sequence of ExtraMode
        Out-of-band modes to add (empty for none).
    dac_bits : int
        Resolution of the bias DAC over ``bias_limits``; 0 applies the bias exactly.
    seed : int or None
        Seed of the noise generator: the same seed gives identical measurement sequences;
        successive :meth:`measure` calls draw new noise. The reported noise variances
        (``noise_var``) come from a generator of their own (:meth:`noise_estimate`): the
        responses are those of a device that reports none.
    bench : mapping or BenchSettings, optional
        The ``[device.bench]`` table: a clock and slow drifts (:mod:`sysid_simgyro.bench`).
        Default: a frozen bench (no time, no drift), as a simulation without a bench.
    """

    #: Device name used in configuration files.
    name: ClassVar[str] = "simulated-gyro"
    #: One line for ``sysid plugins``.
    description: ClassVar[str] = "A simulated two-mode gyro"

    def __init__(
        self,
        truth: GyroTruth,
        *,
        band_hz: tuple[float, float],
        bias_limits: tuple[float, float] = (-10.0, 10.0),
        noise: float = 1e-4,
        feedthrough: float = 0.0125,
        feedthrough_shape: Sequence[Sequence[float]] | np.ndarray = ((1.0, 0.0), (0.0, 1.0)),
        feedthrough_reference_hz: float | None = None,
        extra_modes: Sequence[ExtraMode] = (),
        dac_bits: int = 16,
        seed: int | None = 0,
        bench: Mapping[str, Any] | BenchSettings | None = None,
    ) -> None:
        self.truth = truth
        self.electrodes: tuple[str, ...] = tuple(str(e) for e in truth.electrodes)
        self.bias_limits: tuple[float, float] = (float(bias_limits[0]), float(bias_limits[1]))
        self.structure_potential: float = float(truth.structure_potential)
        self.band_hz: tuple[float, float] = (float(band_hz[0]), float(band_hz[1]))
        self.noise = as_fraction(self.name, "noise", noise)
        self.feedthrough = as_fraction(self.name, "feedthrough", feedthrough)
        self.dac_bits = as_dac_bits(self.name, "dac_bits", dac_bits)
        self.seed = as_seed(self.name, "seed", seed)
        self.extra_modes: tuple[ExtraMode, ...] = tuple(extra_modes)
        self._rng = np.random.default_rng(self.seed)

        low, high = self.bias_limits
        #: The native state: every electrode at 0 V (mid-range if 0 V is not allowed).
        self.native_bias = np.full(
            len(self.electrodes), 0.0 if low <= 0.0 <= high else 0.5 * (low + high)
        )
        #: Largest |response| entry of the two gyro modes in the native state (response units).
        self.peak_magnitude = peak_magnitude(truth, self.applied_bias(self.native_bias))
        #: Standard deviation of the complex noise per entry and point (response units).
        self.noise_std = self.noise * self.peak_magnitude
        self._make_bench(BenchSettings.from_options(self.name, bench))

        centre = 0.5 * (self.band_hz[0] + self.band_hz[1])
        self.feedthrough_reference_hz = float(feedthrough_reference_hz or centre)
        shape = np.asarray(feedthrough_shape, dtype=float)
        shape = shape / np.abs(shape).max()
        #: The parasitic capacitance matrix: ``jω C_par`` is the feedthrough (response · s/rad).
        self.parasitic_capacitance = (
            self.feedthrough
            * self.peak_magnitude
            / (TWO_PI * self.feedthrough_reference_hz)
            * shape
        )
        omega_c = np.array([TWO_PI * centre])
        #: The residue matrix of each extra mode (response · rad/s), in :attr:`extra_modes` order.
        self.extra_mode_residues: tuple[np.ndarray, ...] = tuple(
            mode.level
            * self.peak_magnitude
            / abs(complex(mode.transfer(omega_c)[0]))
            * mode.shape()
            for mode in self.extra_modes
        )

    def _make_bench(self, settings: BenchSettings) -> None:
        """The bench in time (a clock) when ``settings.clock``, with the device attributes of
        the bench clock: ``tones``, ``settle_s`` and ``dwell_s``."""
        self.bench_settings = settings
        self.bench: Bench | None = None
        #: Frequencies one acquisition measures (the device protocol's ``tones``).
        self.tones = settings.tones
        if not settings.clock:
            return
        _, damped, q = modal_analysis(
            self.truth.M, self.truth.C, self.truth.stiffness(self.applied_bias(self.native_bias))
        )
        omega = TWO_PI * np.asarray(damped)
        slowest = int(np.argmax(np.asarray(q) / omega))
        q_over_omega = float(q[slowest] / omega[slowest])
        self.bench = Bench(settings, 2.0 * q_over_omega, q_over_omega, len(self.electrodes))
        #: Seconds to settle after a bias change and per acquisition (the bench clock of the
        #: device protocol).
        self.settle_s = self.bench.settle_s
        self.dwell_s = self.bench.dwell_s

    @property
    def time_s(self) -> float | None:
        """The bench clock now (seconds since the device was made), or ``None`` without one."""
        return None if self.bench is None else self.bench.now_s

    def _drifted_stiffness(self, applied: np.ndarray, times_s: np.ndarray) -> np.ndarray:
        """The true stiffness at each of ``times_s`` for the DAC's ``applied`` bias: ``(N, 2,
        2)``, with the bench's temperature and charging then."""
        assert self.bench is not None
        delta_t = self.bench.temperature_k(times_s)
        biases = applied[None, :] + self.bench.charge_v(times_s)
        k = np.array([self.truth.stiffness(b.tolist()) for b in biases])
        k = self.bench.stiffness_scale(delta_t)[:, None, None] * k
        if self.bench.settings.split_tempco_ppm_per_k:
            native = self.truth.stiffness(self.applied_bias(self.native_bias).tolist())
            k = k + self.bench.split_term(delta_t, native, self.truth.M)
        return k

    # ------------------------------------------------------------------ bias
    def check_bias(self, bias: Sequence[float]) -> np.ndarray:
        """``bias`` as a float array, or :class:`BiasLimitError` if it must not be applied.

        Refused: the wrong number of values, non-finite values, values outside
        :attr:`bias_limits`.
        """
        try:
            values = np.array(bias, dtype=float)
        except (TypeError, ValueError) as exc:
            raise BiasLimitError(
                f"{self.name}: bias {bias!r} is not a list of volts: {exc}"
            ) from exc
        if values.ndim != 1 or values.size != len(self.electrodes):
            raise BiasLimitError(
                f"{self.name}: got {values.size} bias value(s) of shape {values.shape}; expected "
                f"one per electrode ({', '.join(self.electrodes)})"
            )
        low, high = self.bias_limits
        bad = [
            f"{name} = {v!r} V"
            for name, v in zip(self.electrodes, values.tolist(), strict=True)
            if not (low <= v <= high)
        ]
        if bad:
            raise BiasLimitError(
                f"{self.name}: refusing to apply a bias outside the limits [{low}, {high}] V: "
                f"{', '.join(bad)}"
            )
        return values

    @property
    def bias_resolution(self) -> float | None:
        """The DAC's step (volts per code), or ``None`` without quantisation (``dac_bits = 0``)."""
        if self.dac_bits == 0:
            return None
        low, high = self.bias_limits
        return float(high - low) / 2**self.dac_bits

    def applied_bias(self, bias: Sequence[float]) -> np.ndarray:
        """The bias the DAC really applies for the requested ``bias`` (volts, quantised).

        Raises
        ------
        BiasLimitError
            If ``bias`` has the wrong length or a value outside :attr:`bias_limits`.
        """
        return quantize_bias(self.check_bias(bias), self.bias_limits, self.dac_bits)

    # ------------------------------------------------------------ responses
    @staticmethod
    def _check_frequencies(frequencies_hz: np.ndarray | Sequence[float]) -> np.ndarray:
        f = np.asarray(frequencies_hz, dtype=float)
        if f.ndim != 1 or f.size == 0:
            raise FrequencyGridError(
                f"frequencies must be a non-empty 1-D array, got shape {f.shape}"
            )
        if not np.all(np.isfinite(f)) or np.any(f <= 0):
            i = int(np.flatnonzero(~np.isfinite(f) | (f <= 0))[0])
            raise FrequencyGridError(
                f"frequency[{i}] = {f[i]} Hz: frequencies must be finite and > 0"
            )
        return f

    def _condition(self, omega: np.ndarray, x: np.ndarray) -> np.ndarray:
        if self.truth.h_out is not None:
            x = self.truth.h_out(omega) @ x
        if self.truth.h_in is not None:
            x = x @ self.truth.h_in(omega)
        return x

    def feedthrough_response(self, frequencies_hz: np.ndarray) -> np.ndarray:
        """The parasitic path ``jω C_par``, ``(N, 2, 2)``, before signal conditioning."""
        omega = TWO_PI * self._check_frequencies(frequencies_hz)
        return 1j * omega[:, None, None] * self.parasitic_capacitance

    def extra_mode_response(self, frequencies_hz: np.ndarray) -> np.ndarray:
        """The sum of the extra modes' terms, ``(N, 2, 2)``, before signal conditioning."""
        omega = TWO_PI * self._check_frequencies(frequencies_hz)
        out = np.zeros((omega.size, 2, 2), dtype=complex)
        for mode, residue in zip(self.extra_modes, self.extra_mode_residues, strict=True):
            out += mode.transfer(omega)[:, None, None] * residue
        return out

    def background_response(self, frequencies_hz: np.ndarray) -> np.ndarray:
        """Feedthrough plus extra modes, after signal conditioning, ``(N, 2, 2)``."""
        f = self._check_frequencies(frequencies_hz)
        raw = self.feedthrough_response(f) + self.extra_mode_response(f)
        return self._condition(TWO_PI * f, raw)

    def noiseless_response(self, bias: Sequence[float], frequencies_hz: np.ndarray) -> np.ndarray:
        """What :meth:`measure` returns without the noise, ``(N, 2, 2)`` complex."""
        f = self._check_frequencies(frequencies_hz)
        return self.truth.response(self.applied_bias(bias), f) + self.background_response(f)

    def measure(self, bias: Sequence[float], frequencies_hz: np.ndarray) -> xr.DataArray:
        """Apply ``bias`` (volts, one per electrode) and measure the MIMO frequency response.

        Returns
        -------
        xarray.DataArray
            Complex, dims ``("frequency", "output", "input")``, coordinates ``frequency`` (Hz,
            exactly the requested values), ``output`` ``["y1", "y2"]``, ``input``
            ``["u1", "u2"]``, on a bench with a clock ``time_s`` (seconds, each point's
            time stamp) and, with noise, ``noise_var`` (dims ``frequency``, ``output``,
            ``input``: each entry's noise variance as measured, :meth:`noise_estimate`);
            attributes ``device``, ``units``, ``bias`` and ``applied_bias``.

        Raises
        ------
        BiasLimitError
            If ``bias`` has the wrong length or a value outside :attr:`bias_limits`; nothing is
            applied then.
        FrequencyGridError
            If a frequency is not finite and positive.
        """
        requested = self.check_bias(bias)
        f = self._check_frequencies(frequencies_hz).copy()
        applied = self.applied_bias(requested)
        times = None
        if self.bench is None:
            response = self.truth.response(applied, f)
        else:
            self.bench.settle(applied)
            times = self.bench.acquire(f.size, self.tones)
            k = self._drifted_stiffness(applied, times)
            response = self.truth.response(applied, f, stiffness=k)
        response = response + self.background_response(f)
        if self.bench is not None:  # the analyzer's gain and phase: on all it measures
            response = response * self.bench.sweep_factor()
        noise_var = None
        if self.noise_std > 0:
            noise_var = self.noise_estimate(f.size)
            scale = self.noise_std / np.sqrt(2.0) * np.sqrt(self.tones_shared(f.size))
            scale = scale[:, None, None]
            response = response + scale * (
                self._rng.standard_normal(response.shape)
                + 1j * self._rng.standard_normal(response.shape)
            )
        extra: dict[str, Any] = {}
        if times is not None:
            extra["time_s"] = ("frequency", times, {"units": "s"})
        if noise_var is not None:
            extra["noise_var"] = (("frequency", "output", "input"), noise_var, {"units": "(V/V)^2"})
        return xr.DataArray(
            response,
            dims=("frequency", "output", "input"),
            coords={
                "frequency": ("frequency", f, {"units": "Hz"}),
                "output": ["y1", "y2"],
                "input": ["u1", "u2"],
                **extra,
            },
            name="response",
            attrs={
                "device": self.name,
                "units": "V/V",
                "bias": requested.tolist(),
                "applied_bias": applied.tolist(),
            },
        )

    def noise_variance(self, n_points: int) -> np.ndarray:
        """The true variance ``E|n|²`` of each entry's noise at each of ``n_points`` points
        measured together: ``noise_std² · k``, ``k`` from :meth:`tones_shared`."""
        return self.noise_std**2 * self.tones_shared(n_points)

    def noise_estimate(self, n_points: int) -> np.ndarray:
        """Each entry's noise variance as a lock-in measures it, ``(n_points, 2, 2)``.

        A lock-in averages :data:`NOISE_SUBSAMPLES` sub-integrations ``x_j`` per point and
        reports the variance of their mean, ``Σ|x_j − x̄|² / (m (m − 1))``: with complex
        Gaussian noise that is the true variance (:meth:`noise_variance`) times
        ``χ²(2(m − 1)) / (2(m − 1))``, independent of the mean (the response).

        Drawn from a generator seeded by the response noise generator's current state (read,
        not advanced) and :data:`NOISE_ESTIMATE_STREAM`: the responses are exactly those of a
        device that reports no variances, and whoever reseeds the response noise (a test
        that makes it a function of the bias and grid) reseeds the estimates with it.
        """
        state = repr(self._rng.bit_generator.state).encode()
        key = int.from_bytes(hashlib.sha256(state).digest()[:16], "little")
        rng = np.random.default_rng([key, NOISE_ESTIMATE_STREAM])
        dof = 2 * (NOISE_SUBSAMPLES - 1)
        true = self.noise_variance(n_points)[:, None, None]
        return true * rng.chisquare(dof, size=(n_points, 2, 2)) / dof

    def tones_shared(self, n_points: int) -> np.ndarray:
        """How many tones share each point's acquisition (``n_points`` frequencies measured
        :attr:`tones` at a time, consecutively): each tone's noise is ``√k`` times a single
        tone's."""
        per = max(int(self.tones), 1)
        first = (np.arange(n_points) // per) * per
        return np.minimum(per, n_points - first).astype(float)

    # --------------------------------------------------------- ground truth
    def true_modal_analysis(
        self, bias: Sequence[float]
    ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Undamped and damped modal frequencies (Hz, ascending) and Q at the applied ``bias``."""
        applied = self.applied_bias(bias)
        return modal_analysis(self.truth.M, self.truth.C, self.truth.stiffness(applied))

    def true_modal_frequencies_hz(
        self, bias: Sequence[float], at_s: float | None = None
    ) -> np.ndarray:
        """The TRUE undamped modal frequencies at ``bias`` (Hz, ascending).

        Generalized eigenvalues of ``(K(w), M)`` of :attr:`truth` with every electrode, at the
        bias the DAC really applies (:meth:`applied_bias`); on a bench with a clock, with its
        drifts at the time now (:attr:`time_s`), or at ``at_s`` on the bench's clock: a
        replica of a run's device (the same seeds), asked at the run's time stamps in order,
        gives the gyro as the run saw it. The ramp and charging are functions of the clock;
        the temperature's random walk is drawn as times are asked (a time before the last one
        asked gets the walk's latest value), so a replica's walk is another draw. Refuses
        biases it could not apply (:class:`BiasLimitError`); use
        ``truth.modal_frequencies_hz`` for arbitrary values.
        """
        applied = self.applied_bias(bias)
        if self.bench is None:
            return self.truth.modal_frequencies_hz(applied)
        when = self.bench.now_s if at_s is None else float(at_s)
        k = self._drifted_stiffness(applied, np.array([when]))[0]
        return modal_analysis(self.truth.M, self.truth.C, k)[0]

    def true_split_hz(self, bias: Sequence[float], at_s: float | None = None) -> float:
        """The TRUE modal split at ``bias`` (Hz); see :meth:`true_modal_frequencies_hz`."""
        f = self.true_modal_frequencies_hz(bias, at_s)
        return float(f[1] - f[0])

    def __repr__(self) -> str:
        return (
            f"{type(self).__name__}(noise={self.noise}, feedthrough={self.feedthrough}, "
            f"extra_modes={bool(self.extra_modes)}, dac_bits={self.dac_bits}, seed={self.seed})"
        )


class ParametrizedGyro(SimulatedGyro):
    """A :class:`SimulatedGyro` built from a parameter set, configured by keyword options.

    Subclasses set :attr:`name`, :attr:`description` and :attr:`parameters_class`. The keyword
    options are those of a config's ``[device]`` table (see :attr:`options`), checked by the
    registry against this signature (:mod:`sysid_core.plugin.options`); an unknown one
    raises :class:`~sysid_core.errors.ConfigError` naming it.

    Parameters
    ----------
    noise : float, default 1e-4
        Complex noise per point relative to the native resonant peak.
    feedthrough : float, default 0.0125
        Capacitive feedthrough at the reference frequency relative to the native resonant peak.
    extra_modes : bool, default True
        Add the parameter set's out-of-band modes.
    dac_bits : int, default 16
        Bias DAC resolution over ``bias_limits``; 0 applies biases exactly.
    seed : int or None, default 0
        Noise generator seed.
    bench : table, optional
        ``[device.bench]``: a clock and slow drifts (:mod:`sysid_simgyro.bench`).
    params : parameter set, optional
        Another instance of :attr:`parameters_class` (from Python only).
    """

    #: The frozen dataclass of physical parameters; its default instance is the device.
    parameters_class: ClassVar[type[GyroParameterSet]]
    #: Keyword options of the factory.
    options: ClassVar[tuple[str, ...]] = (*COMMON_OPTIONS, "params")

    def __init__(
        self,
        *,
        noise: float = 1e-4,
        feedthrough: float = 0.0125,
        extra_modes: bool = True,
        dac_bits: int = 16,
        seed: int | None = 0,
        bench: Mapping[str, Any] | BenchSettings | None = None,
        params: GyroParameterSet | None = None,
    ) -> None:
        if params is None:
            params = self.parameters_class()
        elif not isinstance(params, self.parameters_class):
            raise ConfigError(
                f"option 'params' of device {self.name!r} must be a "
                f"{self.parameters_class.__name__} (set it from Python, not from a config file), "
                f"got {type(params).__name__}"
            )
        #: The physical parameter set this device was built from.
        self.params = params
        use_modes = as_bool(self.name, "extra_modes", extra_modes)
        super().__init__(
            params.truth(),
            band_hz=params.band_hz,
            bias_limits=params.bias_limits,
            noise=noise,
            feedthrough=feedthrough,
            feedthrough_shape=params.feedthrough_shape,
            feedthrough_reference_hz=params.feedthrough_reference_hz,
            extra_modes=params.extra_modes if use_modes else (),
            dac_bits=dac_bits,
            seed=seed,
            bench=bench,
        )
