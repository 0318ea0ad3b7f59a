"""The ``random-gyro`` device: determinism, documented ranges, exact tunability, bias law, tuning.

Every check is against known truth: the drawn parameters, the documented ranges of
``sysid_random_gyro.generator`` (and ``docs/random-gyro.md``), the exact degenerate bias the
stiffness was built from, and the noise stream ``np.random.default_rng([seed, 1])``.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Callable
from pathlib import Path

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from sysid_random_gyro import RandomGyro, RandomGyroParameters, draw_parameters
from sysid_random_gyro import generator as gen
from sysid_simgyro.physics import TWO_PI, differential_phase_deg, rotation
from truths import cloverleaf_truth, write_toml

from sysid_core.api import tune
from sysid_core.device.protocol import SimulatedDevice, check_device
from sysid_core.device.simulation import GyroTruth
from sysid_core.errors import ConfigError
from sysid_core.plugin.interfaces import Device
from sysid_core.plugin.options import build
from sysid_core.plugin.registry import Registry
from sysid_core.testing import DeviceContract
from sysid_core.tuning.criteria import degenerate_bias as closed_form_degenerate_bias

SEEDS = range(200)
#: Every seed's parameters, drawn once (about 0.1 s for all).
DRAWS: dict[int, RandomGyroParameters] = {seed: draw_parameters(seed) for seed in SEEDS}
REDUCED = {"resolution_hz": 1.0, "verify_resolution_hz": 0.02}


def ideal(seed: int) -> RandomGyro:
    """The seed's gyro without noise, feedthrough, extra modes or quantisation."""
    return RandomGyro(seed=seed, noise=0.0, feedthrough=0.0, extra_modes=False, dac_bits=0)


def inside(value: float, bounds: tuple[float, float]) -> bool:
    return bounds[0] <= value <= bounds[1]


# ------------------------------------------------------------------------------ determinism
def test_same_seed_same_gyro_and_same_measurements() -> None:
    a, b = RandomGyro(seed=5), RandomGyro(seed=5)
    assert a.params == b.params
    np.testing.assert_array_equal(a.truth.K0, b.truth.K0)
    f = np.linspace(*a.band_hz, 40)
    bias = [0.0] * len(a.electrodes)
    a1, a2 = a.measure(bias, f).values, a.measure(bias, f).values
    b1, b2 = b.measure(bias, f).values, b.measure(bias, f).values
    np.testing.assert_array_equal(a1, b1)
    np.testing.assert_array_equal(a2, b2)
    assert not np.array_equal(a1, a2)  # new noise on every call


def test_different_seeds_give_different_gyros() -> None:
    f0 = [p.f0_hz for p in DRAWS.values()]
    k0 = {p.k0 for p in DRAWS.values()}
    assert len(set(f0)) == len(DRAWS) and len(k0) == len(DRAWS)
    assert RandomGyro(seed=1).params != RandomGyro(seed=2).params


def test_noise_is_its_own_stream() -> None:
    """Noise = ``noise_std / √2 · (z_re + j z_im)`` from ``default_rng([seed, 1])``, whatever the
    parameters (here: other dynamics and feedthrough), and the parameters do not depend on it."""
    seed = 11
    f = np.linspace(*DRAWS[seed].band_hz, 25)
    for options in ({}, {"dynamics": "input"}, {"dynamics": "output", "feedthrough": 0.0}):
        device = RandomGyro(seed=seed, **options)  # type: ignore[arg-type]
        bias = [0.0] * len(device.electrodes)
        noise = device.measure(bias, f).values - device.noiseless_response(bias, f)
        rng = np.random.default_rng([seed, 1])
        z = rng.standard_normal(noise.shape) + 1j * rng.standard_normal(noise.shape)
        np.testing.assert_allclose(noise, device.noise_std / np.sqrt(2) * z, rtol=1e-6, atol=0)
        assert device.noise_std == pytest.approx(1e-4 * device.peak_magnitude)


@given(seed=st.integers(0, 10**6), draw=st.integers(0, 10**6))
@settings(max_examples=20, deadline=None)
def test_noise_seed_draws_other_noise_for_the_same_gyro(seed: int, draw: int) -> None:
    """``noise_seed`` is the stream ``default_rng([seed, 2, noise_seed])``: the same gyro (its
    noiseless response, its exact degenerate bias), other noise, and the same again for the same
    draw."""
    f = np.linspace(*draw_parameters(seed).band_hz, 9)
    own, other, again = (
        RandomGyro(seed=seed, **o) for o in ({}, {"noise_seed": draw}, {"noise_seed": draw})
    )
    assert own.params == other.params and other.noise_seed == draw and own.noise_seed is None
    bias = [0.0] * len(own.electrodes)
    np.testing.assert_array_equal(
        own.noiseless_response(bias, f), other.noiseless_response(bias, f)
    )
    np.testing.assert_array_equal(own.true_degenerate_bias(), other.true_degenerate_bias())
    first = other.measure(bias, f).values
    noise = first - other.noiseless_response(bias, f)
    rng = np.random.default_rng([seed, 2, draw])
    z = rng.standard_normal(noise.shape) + 1j * rng.standard_normal(noise.shape)
    np.testing.assert_allclose(noise, other.noise_std / np.sqrt(2) * z, rtol=1e-6, atol=0)
    np.testing.assert_array_equal(again.measure(bias, f).values, first)  # the same draw again
    assert not np.array_equal(own.measure(bias, f).values, first)  # the seed's own differs


def test_dynamics_option_changes_nothing_else() -> None:
    for seed in range(20):
        drawn = DRAWS[seed]
        for dynamics in ("output", "input"):
            chosen = draw_parameters(seed, dynamics)
            assert chosen == dataclasses.replace(drawn, dynamics=dynamics)
        device = RandomGyro(seed=seed, dynamics="input")
        assert device.dynamics == "input" and device.structure == "sen"
        assert device.truth.h_out is None and device.truth.h_in is not None
        device = RandomGyro(seed=seed, dynamics="output")
        assert device.dynamics == "output" and device.structure == "act"
        assert device.truth.h_in is None and device.truth.h_out is not None


# ---------------------------------------------------------------------------- the ranges
def test_every_drawn_parameter_is_inside_its_documented_range() -> None:
    for seed, p in DRAWS.items():
        n = len(p.electrodes)
        assert p.seed == seed
        assert inside(p.f0_hz, gen.F0_RANGE_HZ)
        assert all(inside(q, gen.Q_RANGE) for q in p.q)
        assert 0.0 <= p.damping_axis_deg < 180.0 and p.omega_ref_hz == p.f0_hz
        assert inside(n, gen.ELECTRODE_COUNT_RANGE)
        assert p.electrodes == tuple(f"B{k}" for k in range(1, n + 1))
        # axes in [0, 180), each within the jitter of its even spacing from B1's
        angles = np.asarray(p.electrode_angles_deg)
        assert np.all((angles >= 0.0) & (angles < 180.0))
        spacing = 45.0 if n == 2 else 180.0 / n
        offsets = (angles - angles[0] - spacing * np.arange(n) + 90.0) % 180.0 - 90.0
        assert np.all(np.abs(offsets) <= 2 * gen.ELECTRODE_JITTER_DEG + 1e-9)
        # B1 and B2 do not act on the same anisotropy direction
        assert gen.pair_margin_deg(angles[0], angles[1]) >= gen.PAIR_MARGIN_DEG
        assert all(inside(m, gen.MINOR_RANGE) for m in p.electrode_minors)
        assert all(inside(s, gen.SHIFT_RANGE) for s in p.electrode_shifts)
        np.testing.assert_allclose(
            p.electrode_gains_hz2,
            np.asarray(p.electrode_shifts) * p.f0_hz**2 / (10 * abs(p.structure_potential)),
            rtol=1e-12,
        )
        assert inside(abs(p.structure_potential), gen.V_GYRO_RANGE)
        assert abs(p.structure_potential) > max(abs(x) for x in p.bias_limits)  # v_p keeps its sign
        assert all(inside(abs(b), gen.BIAS_LAW_RANGE) for b in p.bias_law)
        assert all(abs(b) <= gen.TARGET_BIAS_MAX for b in p.degenerate_bias[:2])
        assert all(b == 0.0 for b in p.degenerate_bias[2:])
        split = p.native_modes_hz[1] - p.native_modes_hz[0]
        assert split >= gen.MIN_NATIVE_SPLIT * p.f0_hz
        assert inside(p.feedthrough_level, gen.FEEDTHROUGH_RANGE)
        assert np.all(np.abs(p.feedthrough_shape) <= 1.0)
        assert inside(len(p.extra_modes), gen.EXTRA_MODE_COUNT_RANGE)
        for mode in p.extra_modes:
            ratio = mode.frequency_hz / p.f0_hz
            assert inside(ratio, gen.EXTRA_BELOW_RANGE) or inside(ratio, gen.EXTRA_ABOVE_RANGE)
            assert not inside(mode.frequency_hz, p.band_hz)
            assert inside(mode.q, gen.EXTRA_Q_RANGE)
            assert inside(mode.level, gen.EXTRA_LEVEL_RANGE)
            assert np.all(np.abs([*mode.pickoff, *mode.actuation]) <= 1.0)
        assert p.dynamics in gen.DYNAMICS
        assert inside(p.corner_hz / p.f0_hz, gen.CORNER_RATIO_RANGE)
        assert inside(p.differential_phase_deg, gen.DIFFERENTIAL_PHASE_RANGE_DEG)
        assert differential_phase_deg(p.output_lowpass(), p.f0_hz) == pytest.approx(
            p.differential_phase_deg, abs=1e-9
        )
        assert all(inside(g, gen.GAIN_RANGE) for g in p.gains)
        assert np.all(np.abs(np.asarray(p.pickoff) - np.eye(2)) <= gen.PICKOFF_SPREAD)
        assert p.velocity_pickoff and p.bias_limits == gen.BIAS_LIMITS
        # the band: both native modes and f0, each with the documented margin
        half = max(gen.BAND_SPLITS * split, gen.BAND_BANDWIDTHS * p.f0_hz / min(p.q))
        low, high = p.band_hz
        assert low <= min(p.native_modes_hz[0], p.f0_hz) - half
        assert high >= max(p.native_modes_hz[1], p.f0_hz) + half
        span = max(p.native_modes_hz[1], p.f0_hz) - min(p.native_modes_hz[0], p.f0_hz)
        assert high - low <= span + 2 * half + 0.2 + 1e-9  # rounded outward to 0.1 Hz


def test_both_signs_both_dynamics_and_every_electrode_count_occur() -> None:
    draws = DRAWS.values()
    assert {np.sign(p.structure_potential) for p in draws} == {-1.0, 1.0}
    assert {p.dynamics for p in draws} == {"output", "input"}
    assert {len(p.electrodes) for p in draws} == set(range(2, 9))
    assert {len(p.extra_modes) for p in draws} == {0, 1, 2, 3}
    assert {np.sign(b) for p in draws for b in p.bias_law} == {-1.0, 1.0}


def test_the_matrices_are_physical() -> None:
    for seed in range(50):
        truth = DRAWS[seed].truth()
        for kp in truth.Kp:  # electrostatic springs soften
            assert np.linalg.eigvalsh(kp).max() < 0.0
        low, high = DRAWS[seed].bias_limits
        for corner in ([low, low], [low, high], [high, low], [high, high]):
            bias = corner + [0.0] * (truth.n_electrodes - 2)
            assert np.linalg.eigvalsh(truth.stiffness(bias)).min() > 0.0


def test_gains_move_a_mode_by_the_drawn_shift_per_10_volts() -> None:
    """``n_pᵀ dK/dδv_p n_p · 10 V / (2 (2π f0)²)`` at 0 V is the drawn shift ``s_p``."""
    for seed in range(30):
        p = DRAWS[seed]
        truth = p.truth()
        zero = np.zeros(truth.n_electrodes)
        lam = (TWO_PI * p.f0_hz) ** 2
        for k, (theta, shift) in enumerate(
            zip(p.electrode_angles_deg, p.electrode_shifts, strict=True)
        ):
            n = rotation(theta)[:, 0]
            h = 1e-3
            up, down = zero.copy(), zero.copy()
            up[k], down[k] = h, -h
            slope = n @ (truth.stiffness(up) - truth.stiffness(down)) @ n / (2 * h)
            assert abs(slope) * 10.0 / (2 * lam) == pytest.approx(shift, rel=1e-6)


# ------------------------------------------------------------ exact degeneracy, bias law
def test_degenerate_bias_is_the_drawn_one_and_exact() -> None:
    for seed in range(50):
        p = DRAWS[seed]
        truth = p.truth()
        bias = truth.degenerate_bias((0, 1))
        np.testing.assert_allclose(bias, p.degenerate_bias, rtol=0, atol=1e-9)
        assert truth.split_hz(bias) < 1e-9 * p.f0_hz
        assert truth.split_hz(list(p.degenerate_bias)) < 1e-6  # the drawn b* itself
        np.testing.assert_allclose(truth.modal_frequencies_hz(bias), p.f0_hz, rtol=1e-12)
        device = ideal(seed)
        np.testing.assert_array_equal(device.true_degenerate_bias(), bias)
        assert device.true_split_hz(bias) < 1e-6
        f = device.true_modal_frequencies_hz(bias)
        low, high = device.band_hz
        assert low < f[0] <= f[1] < high
        native = device.true_modal_frequencies_hz([0.0] * len(device.electrodes))
        np.testing.assert_allclose(native, p.native_modes_hz, rtol=1e-12)
        assert low < native[0] < native[1] < high


def test_without_bias_law_the_closed_form_is_unchanged() -> None:
    for seed in range(20):
        truth = dataclasses.replace(DRAWS[seed].truth(), bias_law=None)
        expected = closed_form_degenerate_bias(
            truth.K0, truth.Kp, truth.M, truth.structure_potential, (0, 1)
        )
        np.testing.assert_array_equal(truth.degenerate_bias((0, 1)), expected)
    clover = cloverleaf_truth()
    assert clover.bias_law is None
    np.testing.assert_array_equal(
        clover.degenerate_bias(),
        closed_form_degenerate_bias(clover.K0, clover.Kp, clover.M, clover.structure_potential),
    )
    # the numerical solve agrees with the closed form when the law is v² (β = 0)
    zero_law = dataclasses.replace(clover, bias_law=np.zeros(clover.n_electrodes))
    np.testing.assert_allclose(zero_law.degenerate_bias(), clover.degenerate_bias(), atol=1e-9)


def test_the_bias_law_moves_the_degenerate_bias() -> None:
    """The law matters: the v² closed form of a drawn gyro is not its degenerate bias."""
    moved = []
    for seed in range(20):
        truth = DRAWS[seed].truth()
        pure = dataclasses.replace(truth, bias_law=None)
        bias = truth.degenerate_bias()
        moved.append(np.abs(bias - pure.degenerate_bias()).max())
        assert truth.split_hz(bias) < 1e-9 * DRAWS[seed].f0_hz
    assert np.median(moved) > 0.01


def test_degenerate_bias_that_does_not_exist_is_a_clear_error() -> None:
    clover = cloverleaf_truth()
    kp = np.array([clover.Kp[0], 1.1 * clover.Kp[0]])  # one anisotropy direction for both
    truth = dataclasses.replace(clover, Kp=kp, bias_law=np.array([1e-3, -2e-3]))
    with pytest.raises(RuntimeError, match="no exact degenerate bias found for electrodes B1, B2"):
        truth.degenerate_bias()
    with pytest.raises(ValueError, match="3 bias-law coefficients for 2 K_p"):
        dataclasses.replace(clover, bias_law=np.zeros(3))


@settings(max_examples=60, deadline=None)
@given(
    v_gyro=st.floats(-25.0, 25.0),
    bias=st.lists(st.floats(-10.0, 10.0), min_size=3, max_size=3),
    beta=st.lists(st.floats(-5e-3, 5e-3), min_size=3, max_size=3),
    seed=st.integers(0, 2**32 - 1),
)
def test_stiffness_follows_the_bias_law(
    v_gyro: float, bias: list[float], beta: list[float], seed: int
) -> None:
    """β = 0 is the v² law bit for bit; otherwise ``K0 + Σ K_p (v − δv)² (1 + β δv²)``."""
    rng = np.random.default_rng(seed)
    k0 = rng.standard_normal((2, 2)) * 1e8
    kp = rng.standard_normal((3, 2, 2)) * 1e4
    pure = GyroTruth(
        M=np.eye(2),
        C=np.zeros((2, 2)),
        K0=k0,
        Kp=kp,
        structure_potential=v_gyro,
        electrodes=("B1", "B2", "B3"),
    )
    zero = dataclasses.replace(pure, bias_law=np.zeros(3))
    law = dataclasses.replace(pure, bias_law=np.array(beta))
    np.testing.assert_array_equal(zero.stiffness(bias), pure.stiffness(bias))
    expected_pure = k0 + sum((v_gyro - b) ** 2 * k for b, k in zip(bias, kp, strict=True))
    np.testing.assert_allclose(pure.stiffness(bias), expected_pure, rtol=1e-12, atol=1e-3)
    expected = k0 + sum(
        (v_gyro - b) ** 2 * (1 + c * b**2) * k for b, c, k in zip(bias, beta, kp, strict=True)
    )
    np.testing.assert_allclose(law.stiffness(bias), expected, rtol=1e-12, atol=1e-3)


# ------------------------------------------------------------------- options and protocol
@pytest.mark.parametrize(
    ("option", "value"),
    [
        ("dynamics", "sideways"),
        ("dynamics", 1),
        ("seed", -1),
        ("seed", 1.5),
        ("seed", None),
        ("noise_seed", -1),
        ("noise_seed", 2.5),
        ("noise", -1e-4),
        ("dac_bits", 40),
        ("feedthrough", -0.01),
        ("extra_modes", "yes"),
        ("nosie", 1e-4),
    ],
)
def test_bad_options_are_config_errors_naming_them(option: str, value: object) -> None:
    with pytest.raises(ConfigError, match=f"'{option}'"):  # built as a [device] table is
        build("device", RandomGyro.name, RandomGyro, {option: value})
    if option != "nosie":
        with pytest.raises(ConfigError, match=f"'{option}'"):  # and from Python
            RandomGyro(**{option: value})  # type: ignore[arg-type]


def test_registered_and_follows_the_protocol() -> None:
    registry = Registry()
    component = registry.get("device", "random-gyro")
    assert component.distribution == "sysid-toolkit"
    assert component.description == RandomGyro.description
    device = registry.create("device", "random-gyro", seed=7)
    assert isinstance(device, RandomGyro)
    assert check_device(device, "random-gyro") is device
    assert isinstance(device, SimulatedDevice)
    assert device.params == DRAWS[7]


def test_describe_says_what_was_drawn() -> None:
    device = RandomGyro(seed=7)
    p = device.params
    for text in (device.describe(), repr(device)):
        assert f"{p.f0_hz:.3f}" in text
        assert f"{len(p.electrodes)} electrodes" in text
        assert f"{p.structure_potential:+.3f} V" in text
        assert f"{p.dynamics} dynamics" in text
        assert f"{len(p.extra_modes)} extra mode" in text
    assert f"{100 * p.feedthrough_level:.3g} %" in device.describe()
    assert "seed=7" in repr(device)


class TestRandomGyroContract(DeviceContract):
    checks_bias_limits = True
    band_points = 2001

    def make_device(self) -> Device:
        return RandomGyro(seed=3)

    def device_factory(self) -> Callable[..., Device]:
        return RandomGyro


class TestRandomGyroContractOutputDynamics(TestRandomGyroContract):
    def make_device(self) -> Device:
        return RandomGyro(seed=8)  # output dynamics, negative v_gyro, 6 electrodes, 3 extra modes


# -------------------------------------------------------------------------------- tuning
def test_tuning_reaches_the_exact_degenerate_bias(tmp_path: Path) -> None:
    """``sysid tune`` of a config file, reduced sweeps: seed 3 (1338 Hz, input dynamics)."""
    seed = 3
    device = RandomGyro(seed=seed)  # the same gyro and noise the run builds from the config
    assert device.dynamics == "input"
    n = len(device.electrodes)
    cfg = write_toml(
        tmp_path / "random.toml",
        {
            "device": {"name": "random-gyro", "seed": seed},
            "model": {"structure": device.structure},
            "tuning": {
                "criterion": "degenerate",
                "electrodes": ["B1", "B2"],
                "start_bias": [0.0] * n,
                "max_iterations": 4,
            },
            "experiment": REDUCED,
        },
    )
    summary = tune(cfg, tmp_path / "run", plots=False)
    assert summary.converged and summary.iterations <= 4
    true_split = device.true_split_hz(summary.bias)
    assert true_split < 0.010
    assert summary.split_hz is not None and abs(summary.split_hz - true_split) < 0.002
    np.testing.assert_allclose(summary.bias, device.true_degenerate_bias(), atol=0.02)
    native = device.true_split_hz([0.0] * n)
    assert native > 1.0  # there was something to tune


def test_a_far_reach_moves_only_the_degenerate_bias_and_keeps_it_exact() -> None:
    """``reach`` scales the drawn ``b*`` (the same gyro otherwise) and ``b*`` stays degenerate."""
    near, far = draw_parameters(3), draw_parameters(3, reach=0.9)
    assert far.electrode_angles_deg == near.electrode_angles_deg and far.q == near.q
    assert draw_parameters(3, reach=0.6) == near  # the default reach is the default draw
    assert all(abs(b) <= 9.0 for b in far.degenerate_bias[:2])
    truth = far.truth()
    bias = truth.degenerate_bias((0, 1))
    np.testing.assert_allclose(bias, far.degenerate_bias, rtol=0, atol=1e-9)
    assert truth.split_hz(bias) < 1e-9 * far.f0_hz
    assert RandomGyro(seed=3, reach=0.9).params == far
    with pytest.raises(ConfigError, match="option 'reach'"):
        RandomGyro(seed=3, reach=1.5)
