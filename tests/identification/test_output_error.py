"""The output-error refinement of a one-sweep model: the response error's own minimum.

Truth: random gyros' modal frequencies at the sweep's bias (``true_modal_frequencies_hz``) and
the noise the device adds. The windows are a locating chain's zoom: ±8 Hz around each mode,
centred 3 Hz off, at a step of 1 Hz (2-5 bandwidths of these gyros), four far points; the
noise is 2.5 times that of 60 dB shared by 8 tones (an uncontrolled lab's window). There the
equation-error fit and its ``1/‖Z‖`` refits miss the data by 0.34-0.8 of the response, some
over the band's limit, where the response's own minimum misses it by its noise.
"""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from sysid_core.identification.fitting import fit_structure
from sysid_core.identification.outputerror import refine_output_error
from sysid_core.identification.reweighting import refit
from sysid_core.measure.evidence import BAND_FIT_TOLERANCE, noise_share, response_error
from tests.truths import random_gyro_sweep

NOISE = 2.5 * np.sqrt(8.0) * 1e-3


def _zoom(seed: int, noise_seed: int, noise: float = NOISE):  # type: ignore[no-untyped-def]
    def around_the_modes(device, bias):  # type: ignore[no-untyped-def]
        truth = device.true_modal_frequencies_hz(bias)
        core = [np.arange(-8.0, 8.01, 1.0) + f + 3.0 for f in truth]
        far = [truth[0] - np.array([40.0, 80.0]), truth[1] + np.array([40.0, 80.0])]
        return np.unique(np.concatenate(core + far))

    device, bias, sweep, fitter = random_gyro_sweep(seed, noise, noise_seed, around_the_modes)
    return device.true_modal_frequencies_hz(bias), sweep, fitter


def _noise(sweep) -> float:  # type: ignore[no-untyped-def]
    psi = sweep["response"].values[0]
    return noise_share(sweep, np.ones(psi.shape[0], dtype=bool), psi)


@pytest.mark.parametrize(("seed", "noise_seed"), [(257, 1), (257, 2), (220, 1), (220, 3)])
def test_the_refinement_meets_the_noise_where_the_equation_error_fits_do_not(
    seed: int, noise_seed: int
) -> None:
    truth, sweep, fitter = _zoom(seed, noise_seed)
    single = sweep.isel(electrode=[])
    plain = fit_structure(single, fitter.structure, fitter.objective, fitter.solver)
    weighted, _ = refit(single, fitter.structure, fitter.objective, fitter.solver, first=plain)
    # the case: both equation-error fits refused over a whole-band sweep's limit
    assert response_error(sweep, plain[0]) > BAND_FIT_TOLERANCE
    assert response_error(sweep, weighted) > BAND_FIT_TOLERANCE
    model = refine_output_error(single, plain[0])
    assert model is not None and model.meta["output_error"]
    modes = model.modal([])
    # the modes within a tenth of their bandwidth (the step is 2-5 of them)
    assert np.all(np.abs(np.sort(modes.frequencies_hz) - truth) < 0.1 * modes.bandwidth_hz)
    # the response missed by about the noise (the model leaves out the gyro's extra modes)
    assert response_error(sweep, model) < 2.0 * _noise(sweep) + 0.05
    # and the run's fitter keeps it: the evidence holds
    kept, evidence = fitter.window(sweep, band=True)
    assert evidence.ok, evidence.failures()
    assert kept.meta.get("output_error")


def test_noise_free_data_give_back_the_model_they_came_from() -> None:
    """From a start a bandwidth off, the search returns the data's own model."""
    _, sweep, fitter = _zoom(226, 1, noise=1e-4)
    single = sweep.isel(electrode=[])
    plain = fit_structure(single, fitter.structure, fitter.objective, fitter.solver)
    truth = refine_output_error(single, plain[0])
    assert truth is not None
    f = sweep["frequency"].values
    exact = single.drop_vars("noise_var", errors="ignore").copy()
    exact["response"] = (exact["response"].dims, truth.response(f)[None])
    # both modes moved up by about two bandwidths of the first
    raise_by = 1 + 4 * float(truth.modal([]).bandwidth_hz[0]) / float(f.mean())
    shifted = dataclasses.replace(truth, K0=truth.K0 * raise_by)
    found = refine_output_error(exact, shifted)
    assert found is not None
    want, got = truth.modal([]), found.modal([])
    scale = want.bandwidth_hz
    assert np.allclose(
        np.sort(got.frequencies_hz), np.sort(want.frequencies_hz), rtol=0, atol=1e-6 * scale.min()
    )
    assert np.allclose(got.bandwidth_hz, want.bandwidth_hz, rtol=1e-5)
    assert response_error(exact, found) < 1e-6


def test_a_model_with_electrodes_is_not_refined() -> None:
    _, sweep, fitter = _zoom(226, 1)
    model, _ = fit_structure(
        sweep.isel(electrode=[]), fitter.structure, fitter.objective, fitter.solver
    )
    several = dataclasses.replace(
        model,
        Kp=np.zeros((1, 2, 2)),
        electrodes=["B1"],
        poly_w=np.zeros((0, 1, 2, 2)),
        stiffness_factor=None,
    )
    assert refine_output_error(sweep, several) is None


def test_a_search_that_ends_on_a_singular_mass_matrix_gives_none() -> None:
    """A search gone astray (``M``'s second eigenvalue at 0) is refused, not raised."""
    from sysid_core.identification.outputerror import _ResponseFit

    _, sweep, fitter = _zoom(226, 1)
    single = sweep.isel(electrode=[])
    model, _ = fit_structure(single, fitter.structure, fitter.objective, fitter.solver)
    psi = single["response"].values[0]
    problem = _ResponseFit(single["frequency"].values, psi, np.ones(psi.shape), model)
    x = problem.initial()
    assert problem.model(x, 0) is not None
    x[0], x[1] = 0.0, 0.0  # L21 = L22 = 0: M = diag(m11, 0)
    assert problem.model(x, 0) is None
