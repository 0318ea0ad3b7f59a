"""The spread program's scale where the model has no oscillating modes at the box's centre.

A model fitted near one bias and extrapolated over wide limits can have electrodes that soften
so much that its mean eigenvalue at the centre of the box of squared potentials is below zero
(seen on a bench whose bias law softens: ``invalid value encountered in sqrt`` in the tie-break
of a run tuning six electrodes). The tie-break among equally good answers must still hold the
spread within its tolerance of the optimum, without a warning.
"""

from __future__ import annotations

import dataclasses
import warnings

import numpy as np
import scipy.linalg as sl
from sysid_cloverleaf.device import CloverleafGyro

from sysid_core.tuning.spread import solve_spread
from tests.tuning.test_tuning import ALL, SOLVER, exact_model, space

TIE_HZ = 1e-5


def _spread(model, w: np.ndarray) -> float:  # type: ignore[no-untyped-def]
    k = model.K0 + np.tensordot(w, model.Kp, axes=1)
    e = sl.eigh(k, model.M, eigvals_only=True)
    return float(e[-1] - e[0])


def test_a_box_centre_without_oscillating_modes_keeps_the_tie_break() -> None:
    truth = CloverleafGyro(noise=0, feedthrough=0, extra_modes=False, dac_bits=0).truth
    model = exact_model(truth, ALL)
    bias_space = space(truth, ALL)
    box = bias_space.box()
    centre = box.mean(axis=1)
    lam0 = np.trace(np.linalg.solve(model.M, model.K0)) / 2
    per_w = [np.trace(np.linalg.solve(model.M, k)) / 2 for k in model.Kp]
    scale = -1.5 * lam0 / float(np.dot(per_w, centre))  # the centre's mean eigenvalue: -lam0/2
    soft = dataclasses.replace(model, Kp=model.Kp * scale)
    anchor = np.full(3, bias_space.structure_potential**2)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        w, _ = solve_spread(soft, box, SOLVER, anchor_w=anchor)
        best, _ = solve_spread(soft, box, SOLVER)
    assert np.all((w >= box[:, 0] - 1e-9) & (w <= box[:, 1] + 1e-9))
    lam = soft.omega_center**2  # the tolerance in eigenvalues, near the band's centre
    tie = (np.sqrt(lam) + 2 * np.pi * TIE_HZ) ** 2 - lam
    optimum = _spread(soft, best)
    # the solver's accuracy is relative to the spread's scale (1e-6 leaves a margin)
    assert _spread(soft, w) <= optimum * (1 + 1e-6) + tie
