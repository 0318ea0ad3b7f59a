"""The fitted model: modal figures, python-control conversion, persistence."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from truths import PAPER_FREQS, cloverleaf_truth, simulate

from sysid_core import errors, fit, load_model
from sysid_core.model.modal import modal_analysis, snr_loss_db


@pytest.fixture(scope="module")
def model(request):
    return fit(simulate(cloverleaf_truth(), noise_rel=1e-4, seed=11), "act", 1)


@pytest.fixture(scope="module")
def sen_model():
    return fit(simulate(cloverleaf_truth(), noise_rel=1e-4, seed=12), "sen", 2)


def test_modal_report(model, in_class_truth):
    rep = model.modal([0.0, 0.0])
    np.testing.assert_allclose(
        rep.frequencies_hz, in_class_truth.modal_frequencies_hz([0, 0]), atol=1e-3
    )
    assert rep.split_hz == pytest.approx(4.999, abs=2e-3)
    # Q of the truth's damped modes (45 000 / 60 000 design, unit mass)
    _, _, q_true = modal_analysis(
        in_class_truth.M, in_class_truth.C, in_class_truth.stiffness([0, 0])
    )
    np.testing.assert_allclose(np.sort(rep.q), np.sort(q_true), rtol=0.02)
    # 5 Hz split at Q ~ 5e4 loses about 40 dB (paper, Sec. III-A)
    assert 38 < rep.snr_loss_db < 43
    assert np.all(np.abs(rep.damped_hz - rep.frequencies_hz) < 1e-3)


def test_snr_loss_formula():
    # Paper, Sec. I: Q > 40 000, 4.4 kHz, 1 Hz detuning -> about 25 dB
    assert snr_loss_db(1.0, 4400.0, 40000.0) == pytest.approx(25.2, abs=0.1)
    assert snr_loss_db(0.0, 4400.0, 40000.0) == 0.0


def test_bias_length_checked(model):
    with pytest.raises(errors.DataError, match="2 electrodes"):
        model.modal([1.0, 2.0, 3.0])


@pytest.mark.parametrize("which", ["model", "sen_model"])
def test_statespace_matches_response_in_band(which, request):
    m = request.getfixturevalue(which)
    bias = [1.0, 2.0]
    sys = m.to_statespace(bias)
    assert sys.nstates == 4 and sys.ninputs == 2 and sys.noutputs == 2
    f = np.linspace(4400, 4440, 41)
    ss = np.transpose(sys(2j * np.pi * f), (2, 0, 1))
    exact = m.response(f, bias)
    err = np.linalg.norm(ss - exact) / np.linalg.norm(exact)
    assert err < 5 * sys.approximation_error + 1e-6
    assert sys.approximation_error < 0.05
    # poles = the model's damped modes
    poles = np.sort(np.abs(np.linalg.eigvals(sys.A).imag))[::2] / (2 * np.pi)
    np.testing.assert_allclose(poles, m.modal(bias).damped_hz, rtol=1e-9)


def test_save_load_round_trip(tmp_path, model):
    path = model.save(tmp_path / "m.nc")
    back = load_model(path)
    for name in ("M", "C", "K0", "Kp", "poly"):
        np.testing.assert_array_equal(getattr(back, name), getattr(model, name))
    assert back.structure.name == "act" and back.structure.order == 1
    assert back.meta == model.meta
    np.testing.assert_array_equal(
        back.response(PAPER_FREQS, [1, 1]), model.response(PAPER_FREQS, [1, 1])
    )


@settings(max_examples=30, deadline=None)
@given(
    b1=st.floats(-10, 10),
    b2=st.floats(-10, 10),
    scale=st.floats(0.1, 10),
)
def test_modal_frequencies_invariant_to_common_scaling(model, b1, b2, scale):
    """Scaling M, C, K0, K_p together (and P with them) changes nothing observable."""
    from dataclasses import replace

    other = replace(
        model,
        M=model.M * scale,
        C=model.C * scale,
        K0=model.K0 * scale,
        Kp=model.Kp * scale,
        poly=model.poly * scale,
        poly_w=model.poly_w * scale,
    )
    a, b = model.modal([b1, b2]), other.modal([b1, b2])
    np.testing.assert_allclose(a.frequencies_hz, b.frequencies_hz, rtol=1e-12)
    np.testing.assert_allclose(
        model.response(PAPER_FREQS[:5], [b1, b2]),
        other.response(PAPER_FREQS[:5], [b1, b2]),
        rtol=1e-9,
    )


def test_equation_error_matches_gamma(model):
    ds = simulate(cloverleaf_truth(), noise_rel=1e-4, seed=11)
    e = model.equation_error(ds)
    assert e.shape == (3, 121)
    assert np.nanmax(e) == pytest.approx(model.max_residual, rel=1e-6)
