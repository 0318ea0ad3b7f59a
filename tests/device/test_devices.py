"""The built-in simulated devices: calibration, realistic effects, safety and registration."""

from __future__ import annotations

import numpy as np
import pytest
from sysid_cloverleaf import CloverleafGyro, CloverleafParameters
from sysid_post_resonator import PostResonatorGyro
from sysid_simgyro import SimulatedGyro
from sysid_simgyro.physics import differential_phase_deg

from sysid_core.errors import BiasLimitError, ConfigError
from sysid_core.plugin.options import build
from sysid_core.plugin.registry import Registry
from sysid_core.tuning.criteria import degenerate_bias as core_degenerate_bias

TWO_PI = 2 * np.pi
LSB = 20.0 / 2**16


def ideal_cloverleaf(**options: object) -> CloverleafGyro:
    """The cloverleaf with every effect outside the model class switched off."""
    settings: dict[str, object] = {
        "noise": 0.0,
        "feedthrough": 0.0,
        "extra_modes": False,
        "dac_bits": 0,
    }
    settings.update(options)
    return CloverleafGyro(**settings)


def degenerate_bias(device: SimulatedGyro, pair: tuple[int, int]) -> tuple[np.ndarray, float]:
    """Solve K(w) = λ M for the squared potentials of ``pair`` (others at 0 V): (bias, f Hz)."""
    truth = device.truth
    bias = core_degenerate_bias(truth.K0, truth.Kp, truth.M, truth.structure_potential, pair)
    # K(w) = lam M there: lam is the mean generalized eigenvalue of (K(w), M)
    lam = np.linalg.eigvals(np.linalg.solve(truth.M, truth.stiffness(bias))).real.mean()
    return bias, float(np.sqrt(lam) / TWO_PI)


# ----------------------------------------------------------------- calibration
def test_cloverleaf_protocol_attributes() -> None:
    device = CloverleafGyro()
    assert device.electrodes == ("B1", "B2", "B3")
    assert device.bias_limits == (-10.0, 10.0)
    assert device.structure_potential == 15.58
    assert device.band_hz == (4385.0, 4445.0)
    assert device.truth.velocity_pickoff


def test_cloverleaf_native_modes_match_calibration() -> None:
    device = CloverleafGyro()
    f = device.true_modal_frequencies_hz([0.0, 0.0, 0.0])
    np.testing.assert_allclose(f, [4423.95, 4428.95], atol=0.01)
    assert device.true_split_hz([0.0, 0.0, 0.0]) == pytest.approx(5.000, abs=1e-3)
    _, _, q = device.true_modal_analysis([0.0, 0.0, 0.0])
    np.testing.assert_allclose(q, [47216, 56445], rtol=1e-4)


def _rotation(angle_deg: float) -> np.ndarray:
    a = np.radians(angle_deg)
    return np.array([[np.cos(a), -np.sin(a)], [np.sin(a), np.cos(a)]])


def test_cloverleaf_matrices_match_calibration_table() -> None:
    """The truth is the calibration (``CloverleafParameters``) through the documented formulas
    (docs/cloverleaf.md), written out here independently of ``sysid_simgyro.physics``."""
    params = CloverleafParameters()
    truth = CloverleafGyro().truth
    np.testing.assert_allclose(truth.K0 / TWO_PI**2, params.k0_hz2, rtol=1e-12, atol=1e-6)
    # K_p = -(2 pi)^2 g_p (n_p n_p^T + minor m_p m_p^T), n_p at angle theta_p, m_p its normal
    table = []
    for g, theta in zip(params.electrode_gains_hz2, params.electrode_angles_deg, strict=True):
        n, m = _rotation(theta).T
        table.append(-(TWO_PI**2) * g * (np.outer(n, n) + params.minor * np.outer(m, m)))
    np.testing.assert_allclose(truth.Kp, table, rtol=1e-12, atol=1e-9)
    # C = omega_ref U diag(1/Q1, 1/Q2) U^T, U the rotation by the damping axis
    u = _rotation(params.damping_axis_deg)
    c = TWO_PI * params.omega_ref_hz * u @ np.diag(1.0 / np.asarray(params.q)) @ u.T
    np.testing.assert_allclose(truth.C, c, rtol=1e-12)
    np.testing.assert_allclose(truth.R, params.pickoff)
    for kp in truth.Kp:
        assert np.linalg.eigvalsh(kp).max() <= 0.0
    assert np.linalg.eigvalsh(truth.K0).min() > 0.0


def test_cloverleaf_differential_phase_is_one_degree_at_4430_hz() -> None:
    h_out = CloverleafGyro().truth.h_out
    assert h_out is not None
    assert h_out.corner_hz[0] == 20000.0
    assert h_out.corner_hz[1] == pytest.approx(18467.37, abs=0.01)
    assert h_out.gain == (1.0, 0.97)
    assert differential_phase_deg(h_out, 4430.0) == pytest.approx(1.0, abs=1e-9)


def test_cloverleaf_two_electrode_degenerate_bias() -> None:
    device = ideal_cloverleaf()
    bias, freq = degenerate_bias(device, (0, 1))
    np.testing.assert_allclose(bias, [2.040, 4.388, 0.0], atol=1e-3)
    assert freq == pytest.approx(4430.04, abs=0.01)
    assert device.true_split_hz(bias) < 1e-6
    # the rounded published-precision bias and the 16-bit DAC's nearest codes stay under 1 mHz
    assert device.true_split_hz([2.040, 4.388, 0.0]) < 1e-3
    assert CloverleafGyro().true_split_hz(bias) < 1e-3


# ------------------------------------------------------------ realistic effects
def test_default_effects_are_realistic() -> None:
    for device in (CloverleafGyro(), PostResonatorGyro()):
        assert device.noise >= 1e-4
        assert device.feedthrough >= 0.005
        assert len(device.extra_modes) == 3
        assert device.dac_bits == 16
        assert device.seed == 0


def test_same_seed_same_measurements_and_new_noise_each_call() -> None:
    f = np.linspace(4420.0, 4432.0, 50)
    a, b, c = CloverleafGyro(seed=7), CloverleafGyro(seed=7), CloverleafGyro(seed=8)
    a1, a2 = a.measure([0, 0, 0], f).values, a.measure([0, 0, 0], f).values
    b1, b2 = b.measure([0, 0, 0], f).values, b.measure([0, 0, 0], f).values
    np.testing.assert_array_equal(a1, b1)
    np.testing.assert_array_equal(a2, b2)
    assert not np.array_equal(a1, a2)
    assert not np.array_equal(a1, c.measure([0, 0, 0], f).values)


def test_noise_level_is_as_documented() -> None:
    device = CloverleafGyro(feedthrough=0.0, extra_modes=False, seed=11)
    assert device.peak_magnitude == pytest.approx(1.49668, rel=1e-4)
    assert device.noise_std == pytest.approx(1e-4 * device.peak_magnitude)
    f = np.linspace(4385.0, 4445.0, 4000)
    noise = device.measure([0, 0, 0], f).values - device.noiseless_response([0, 0, 0], f)
    rms = np.sqrt(np.mean(np.abs(noise) ** 2))
    assert rms == pytest.approx(device.noise_std, rel=0.03)
    assert np.std(noise.real) == pytest.approx(np.std(noise.imag), rel=0.05)
    assert abs(np.mean(noise)) < 0.05 * device.noise_std


def test_peak_magnitude_is_the_native_resonant_peak() -> None:
    device = ideal_cloverleaf()
    fine = np.linspace(4423.5, 4429.5, 60001)
    sampled = np.abs(device.truth.response([0, 0, 0], fine)).max()
    assert sampled <= device.peak_magnitude * (1 + 1e-9)
    assert sampled == pytest.approx(device.peak_magnitude, rel=1e-4)


def test_feedthrough_is_proportional_to_frequency() -> None:
    device = CloverleafGyro(noise=0.0, extra_modes=False)
    f = np.array([1000.0, 2500.0, 4385.0, 4415.0, 4445.0, 9000.0])
    extra = device.measure([0, 0, 0], f).values - device.truth.response([0, 0, 0], f)
    h_out = device.truth.h_out
    assert h_out is not None
    raw = np.linalg.solve(h_out(TWO_PI * f), extra)  # undo the pick-off conditioning
    per_hz = raw / (1j * TWO_PI * f[:, None, None])
    np.testing.assert_allclose(per_hz, np.broadcast_to(per_hz[0], per_hz.shape), rtol=1e-9)
    np.testing.assert_allclose(per_hz[0], device.parasitic_capacitance, rtol=1e-9)
    at_ref = np.abs(device.feedthrough_response(np.array([4415.0]))).max()
    assert at_ref == pytest.approx(0.0125 * device.peak_magnitude, rel=1e-12)
    assert np.all(device.parasitic_capacitance >= 0.0)  # capacitances


def test_feedthrough_option_scales_and_disables() -> None:
    f = np.linspace(4385.0, 4445.0, 7)
    off = CloverleafGyro(noise=0.0, extra_modes=False, feedthrough=0.0)
    np.testing.assert_array_equal(
        off.measure([0, 0, 0], f).values, off.truth.response([0, 0, 0], f)
    )
    small = CloverleafGyro(noise=0.0, extra_modes=False, feedthrough=0.005)
    big = CloverleafGyro(noise=0.0, extra_modes=False, feedthrough=0.01)
    np.testing.assert_allclose(big.parasitic_capacitance, 2 * small.parasitic_capacitance)


def test_extra_modes_give_a_small_slowly_varying_background() -> None:
    with_modes = CloverleafGyro(noise=0.0, feedthrough=0.0)
    f = np.linspace(4385.0, 4445.0, 61)
    background = with_modes.measure([0, 0, 0], f).values - with_modes.truth.response([0, 0, 0], f)
    size = np.abs(background).max(axis=(1, 2)) / with_modes.peak_magnitude
    assert np.all((size > 1e-3) & (size < 1e-2))
    assert np.ptp(size) < 0.05 * size.mean()
    assert [m.frequency_hz for m in with_modes.extra_modes] == [2700.0, 5600.0, 6300.0]
    # each is a resonance of its own outside the band
    for mode in with_modes.extra_modes:
        near = with_modes.background_response(np.array([mode.frequency_hz]))
        assert np.abs(near).max() > 0.5 * with_modes.peak_magnitude
    without = CloverleafGyro(noise=0.0, feedthrough=0.0, extra_modes=False)
    np.testing.assert_array_equal(
        without.measure([0, 0, 0], f).values, without.truth.response([0, 0, 0], f)
    )


def test_measurement_schema() -> None:
    device = CloverleafGyro()
    f = np.array([4400.0, 4410.5, 4426.25])
    result = device.measure([1.0, -2.0, 0.5], f)
    assert result.dims == ("frequency", "output", "input")
    assert np.iscomplexobj(result.values)
    np.testing.assert_array_equal(result["frequency"].values, f)
    assert list(result["output"].values) == ["y1", "y2"]
    assert list(result["input"].values) == ["u1", "u2"]
    assert result.attrs["device"] == "cloverleaf"
    assert result.attrs["bias"] == [1.0, -2.0, 0.5]
    assert result.attrs["applied_bias"] == device.applied_bias([1.0, -2.0, 0.5]).tolist()


# ------------------------------------------------------------------ quantisation
def test_dac_quantises_the_applied_bias() -> None:
    device = CloverleafGyro()
    requested = np.array([0.1234567, -3.3333333, 9.87654321])
    applied = device.applied_bias(requested)
    codes = (applied + 10.0) / LSB
    np.testing.assert_allclose(codes, np.round(codes), atol=1e-6)
    assert np.all(np.abs(applied - requested) <= LSB / 2 + 1e-12)
    assert np.any(applied != requested)
    np.testing.assert_array_equal(device.applied_bias([0.0, 0.0, 0.0]), [0.0, 0.0, 0.0])
    np.testing.assert_allclose(device.applied_bias([10.0, -10.0, 0.0]), [10.0 - LSB, -10.0, 0.0])
    exact = CloverleafGyro(dac_bits=0)
    np.testing.assert_array_equal(exact.applied_bias(requested), requested)
    coarse = CloverleafGyro(dac_bits=8)
    assert np.abs(coarse.applied_bias(requested) - requested).max() > 1e-3


def test_truth_uses_the_applied_bias() -> None:
    device = CloverleafGyro(dac_bits=8)  # coarse, so the difference is visible
    bias = [2.0407, 4.3882, 0.0]
    applied = device.applied_bias(bias)
    np.testing.assert_array_equal(
        device.true_modal_frequencies_hz(bias), device.truth.modal_frequencies_hz(applied)
    )
    assert device.true_split_hz(bias) != pytest.approx(device.truth.split_hz(bias), abs=1e-6)
    f = np.linspace(4425.0, 4435.0, 5)
    noiseless = CloverleafGyro(dac_bits=8, noise=0.0)
    np.testing.assert_allclose(
        noiseless.measure(bias, f).values - noiseless.background_response(f),
        noiseless.truth.response(applied, f),
        rtol=1e-12,
    )


# ----------------------------------------------------------- options and safety
@pytest.mark.parametrize("factory", [CloverleafGyro, PostResonatorGyro])
def test_unknown_option_is_a_config_error_naming_it(factory: type[SimulatedGyro]) -> None:
    with pytest.raises(ConfigError, match="'noize'"):  # built as a [device] table is
        build("device", factory.name, factory, {"noize": 1e-3})


@pytest.mark.parametrize(
    ("option", "value"),
    [
        ("noise", -1.0),
        ("noise", "high"),
        ("noise", float("nan")),
        ("feedthrough", True),
        ("extra_modes", "yes"),
        ("dac_bits", 40),
        ("dac_bits", 12.5),
        ("seed", -3),
        ("params", {"structure_potential": 15.0}),
    ],
)
def test_bad_option_values_are_config_errors(option: str, value: object) -> None:
    with pytest.raises(ConfigError, match=option):
        CloverleafGyro(**{option: value})


def test_params_option_builds_another_device() -> None:
    device = CloverleafGyro(params=CloverleafParameters(structure_potential=16.0))
    assert device.structure_potential == 16.0


def test_registry_lists_and_builds_the_devices() -> None:
    registry = Registry()
    for name in ("cloverleaf", "post-resonator"):
        component = registry.get("device", name)
        assert component.distribution == "sysid-toolkit"
        assert component.description
    device = registry.create("device", "cloverleaf", noise=0.0, seed=5)
    assert isinstance(device, CloverleafGyro)
    with pytest.raises(ConfigError, match="'bogus'"):
        registry.create("device", "post-resonator", bogus=1)


@pytest.mark.parametrize(
    "bias",
    [
        [10.001, 0.0, 0.0],
        [0.0, -10.5, 0.0],
        [0.0, 0.0, float("nan")],
        [0.0, 0.0],
        [0.0, 0.0, 0.0, 0.0],
        [[0.0, 0.0, 0.0]],
        ["a", 0.0, 0.0],
    ],
)
def test_device_refuses_forbidden_biases(bias: list[object]) -> None:
    device = CloverleafGyro()
    f = np.array([4420.0, 4430.0])
    for call in (
        lambda: device.measure(bias, f),  # type: ignore[arg-type]
        lambda: device.applied_bias(bias),  # type: ignore[arg-type]
        lambda: device.true_modal_frequencies_hz(bias),  # type: ignore[arg-type]
    ):
        with pytest.raises(BiasLimitError):
            call()


def test_bias_limits_themselves_are_allowed() -> None:
    device = CloverleafGyro()
    result = device.measure([10.0, -10.0, 10.0], np.array([4420.0]))
    assert np.all(np.isfinite(result.values))


# --------------------------------------------------------------- post-resonator
def test_post_resonator_sanity() -> None:
    device = PostResonatorGyro(noise=0.0, feedthrough=0.0, extra_modes=False, dac_bits=0)
    assert device.electrodes == ("B1", "B2", "B3", "B4")
    assert device.bias_limits == (-10.0, 10.0)
    assert device.structure_potential == 12.0
    f = device.true_modal_frequencies_hz([0.0] * 4)
    np.testing.assert_allclose(f, [3318.4, 3321.6], atol=1e-6)
    assert 1.0 < device.true_split_hz([0.0] * 4) < 5.0
    low, high = device.band_hz
    assert low < f[0] < f[1] < high
    _, _, q = device.true_modal_analysis([0.0] * 4)
    assert np.all((q > 1.5e4) & (q < 2.5e4))
    for kp in device.truth.Kp:
        assert np.linalg.eigvalsh(kp).max() <= 0.0
    assert np.linalg.eigvalsh(device.truth.K0).min() > 0.0


@pytest.mark.parametrize("pair", [(0, 1), (0, 3), (1, 2), (2, 3)])
def test_post_resonator_tunes_to_degeneracy_inside_its_limits(pair: tuple[int, int]) -> None:
    device = PostResonatorGyro()
    bias, freq = degenerate_bias(device, pair)
    low, high = device.bias_limits
    assert np.all((bias > low + 1.0) & (bias < high - 1.0))  # with margin
    assert device.band_hz[0] < freq < device.band_hz[1]
    assert device.true_split_hz(bias) < 1e-3  # at the DAC's nearest codes


def test_post_resonator_collinear_pair_cannot_tune() -> None:
    device = PostResonatorGyro()
    bias, _ = degenerate_bias(device, (0, 2))  # B1 and B3 act on the same anisotropy axis
    assert np.abs(bias).max() > device.bias_limits[1]


def test_post_resonator_measures_its_band() -> None:
    device = PostResonatorGyro(seed=2)
    f = np.linspace(*device.band_hz, 601)
    magnitude = np.abs(device.measure([0.0] * 4, f).values).max(axis=(1, 2))
    assert magnitude.max() > 20 * max(magnitude[0], magnitude[-1])
    assert device.peak_magnitude == pytest.approx(0.76484, rel=1e-4)
