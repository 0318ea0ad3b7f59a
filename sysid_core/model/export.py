"""Exports of a fitted model to python-control: a real state-space realisation and an FRD.

The model's polynomial ``P`` has complex coefficients in the real frequency, so the model is not
a real rational function of ``s``: :func:`to_statespace` realises it exactly at its resonances
and fits the smooth remainder over a band, weighted for the relative error at every frequency
(see its docstring; on the README's example, 6 states and at most 0.97 % at any frequency).
:func:`to_frd` gives the exact values on a grid. :class:`~sysid_core.model.fitted.FittedModel`
offers both as methods.
"""

from __future__ import annotations

import warnings
from collections.abc import Sequence
from typing import TYPE_CHECKING, Protocol

import numpy as np
import scipy.linalg

from sysid_core.errors import FrequencyGridError, ModelError, SysidWarning
from sysid_core.model.modal import principal_part
from sysid_core.model.structures import ModelStructure

if TYPE_CHECKING:
    import control


class ExportableModel(Protocol):
    """What the exports need of a model (:class:`sysid_core.model.fitted.FittedModel` has it)."""

    structure: ModelStructure
    M: np.ndarray
    C: np.ndarray
    poly: np.ndarray
    omega_center: float
    omega_half: float
    outputs: list[str]
    inputs: list[str]

    def check_bias(self, bias: Sequence[float] | np.ndarray | None) -> np.ndarray: ...

    def poly_at(self, bias: Sequence[float] | np.ndarray | None = None) -> np.ndarray: ...

    def modal_stiffness(self, b: np.ndarray) -> np.ndarray: ...

    def response(
        self, frequencies_hz: np.ndarray, bias: Sequence[float] | np.ndarray | None = None
    ) -> np.ndarray: ...

    def label(self, b: np.ndarray) -> str: ...


__all__ = ["BACKGROUND_POLES", "N_BAND_POINTS", "to_frd", "to_statespace"]

#: Points of the grid over the band on which :func:`to_statespace` fits and measures.
N_BAND_POINTS = 1001
#: Background poles of :func:`to_statespace`, in units of the band centre (rad/s): tried in this
#: order, the first set that meets the tolerance is used.
BACKGROUND_POLES: tuple[tuple[float, ...], ...] = (
    (),
    (1.0,),
    (1 / 3, 1.0, 3.0),
    (0.3, 0.3**0.5, 1.0, 3**0.5, 3.0),
)


def to_statespace(
    model: ExportableModel,
    bias: Sequence[float] | np.ndarray | None = None,
    band_hz: tuple[float, float] | None = None,
    *,
    rtol: float = 1e-2,
) -> control.StateSpace:
    """A real, stable state-space system that reproduces the model's response over a band.

    The response is :meth:`~.fitted.FittedModel.response`. The complex polynomial ``P`` has
    complex coefficients in the real frequency, so the model is not a real rational function of
    ``s``; the realisation matches it over ``band_hz`` only. It is built in two parts:

    * the resonances, exactly: the two upper poles ``p_i`` of ``Z^-1`` with their exact
      residues ``P(nu(-j p_i)) R_i`` (``act``) or ``R_i P(nu(-j p_i))`` (``sen``), ``R_i``
      the rank-one residue of ``Z^-1`` and ``P`` continued to the complex frequency. Each
      mode and its conjugate is one real 2-state block ``[[Re p, -Im p], [Im p, Re p]]``
      (states ``mode<i>_re``, ``mode<i>_im``);
    * the smooth remainder over the band (at the conjugate poles a real system's residues
      are the conjugates, the model's are not), fitted by least squares weighted by
      ``1/‖G(f)‖`` with a real ``D`` and as few real background poles ``-a omega_b``
      (``omega_b`` the band centre, ``a`` in 0.3 … 3, 2 states ``bg<k>_<input>`` each) as
      bring the largest relative error at one frequency under ``rtol``: 0, 1, 3 or 5.

    Parameters
    ----------
    bias : sequence of float, optional
        Bias potentials (volts relative to ground), one per electrode; default 0 V.
    band_hz : (float, float), optional
        Band (Hz) to match; default the fitted band ``omega_center ± omega_half``.
    rtol : float
        Target for ``approximation_error_pointwise``; the fewest background poles that meet
        it are used. Default 1 %.

    Returns
    -------
    control.StateSpace
        Inputs and outputs named after the data's channels
        (:attr:`~.fitted.FittedModel.inputs`, :attr:`~.fitted.FittedModel.outputs`), named after
        the bias. Attributes set on it, measured on
        ``N_BAND_POINTS`` (1001) evenly spaced frequencies ``f`` of the band with ``G``
        the model's response and ``G_ss`` the system's:

        ``approximation_error_pointwise``
            ``max_f ‖G_ss(f) - G(f)‖ / ‖G(f)‖`` (Frobenius norms): the largest relative error
            at one frequency, which ``rtol`` bounds.
        ``approximation_error``
            ``sqrt(sum |G_ss - G|^2 / sum |G|^2)`` over all points and entries.
        ``approximation_error_peak``
            ``max |G_ss - G|`` (largest entry error at any point) divided by the largest
            ``|G|`` entry over the band.
        ``approximation_band_hz``
            The band ``(low, high)``.

    Raises
    ------
    ModelError
        For a non-finite bias, or one at which the model has no oscillating modes.
    FrequencyGridError
        For a ``band_hz`` that is not two finite frequencies with ``0 < low < high``.
    TypeError
        For a bias that is not numbers.

    Warns
    -----
    SysidWarning
        When even 5 background poles leave ``approximation_error_pointwise > rtol`` (a
        band far wider than the fitted one).
    """
    import control

    if isinstance(rtol, bool) or not (isinstance(rtol, (int, float)) and rtol > 0):
        raise ModelError(f"rtol must be a positive number; got {rtol!r}")
    b = model.check_bias(bias)
    k = model.modal_stiffness(b)
    lo, hi = _band(model, band_hz)
    f = np.linspace(lo, hi, N_BAND_POINTS)
    omega = 2 * np.pi * f
    target = model.response(f, b)
    scale = float(np.linalg.norm(target))

    t, bc, cc = principal_part(
        model.M,
        model.C,
        k,
        model.poly_at(b),
        model.omega_center,
        model.omega_half,
        model.structure.side,
    )
    a_res, b_res, c_res = _real_realisation(t, bc, cc)
    rest = target - _frequency_response(a_res, b_res, c_res, np.zeros((2, 2)), omega)
    rest = rest.reshape(-1, 4)

    omega_b = np.pi * (lo + hi)
    # Each frequency's row is divided by |G(f)| (Frobenius): the least squares then minimises
    # the pointwise relative error, which is what rtol bounds; near an anti-resonance |G| is
    # small and an unweighted fit leaves its error largest there (measured: 1.4 % on the
    # README's example against 0.07 % band average).
    weight = 1.0 / np.maximum(np.linalg.norm(target, axis=(1, 2)), 1e-12 * scale)
    chosen: tuple[float, np.ndarray, np.ndarray] | None = None
    for poles in BACKGROUND_POLES:
        rates = omega_b * np.asarray(poles, dtype=float)
        basis = np.column_stack(
            [np.ones_like(omega, dtype=complex)] + [r / (1j * omega + r) for r in rates]
        )
        lhs = np.concatenate([basis.real, basis.imag]) * np.tile(weight, 2)[:, None]
        rhs = np.concatenate([rest.real, rest.imag]) * np.tile(weight, 2)[:, None]
        norms = np.linalg.norm(lhs, axis=0)  # unit columns: a well-posed least squares
        coef = np.linalg.lstsq(lhs / norms, rhs, rcond=None)[0] / norms[:, None]
        err = float(np.max(np.linalg.norm(basis @ coef - rest, axis=1) * weight))
        if chosen is None or err < chosen[0]:
            chosen = (err, rates, coef)
        if err <= rtol:
            chosen = (err, rates, coef)
            break
    assert chosen is not None
    _, rates, coef = chosen

    n_bg = rates.size
    a = scipy.linalg.block_diag(a_res, *(-r * np.eye(2) for r in rates))
    b_ss = np.vstack([b_res, *(r * np.eye(2) for r in rates)])
    c_ss = np.hstack([c_res, *(coef[1 + i].reshape(2, 2) for i in range(n_bg))])
    d_ss = coef[0].reshape(2, 2)
    states = [f"mode{i + 1}_{part}" for i in range(2) for part in ("re", "im")]
    states += [f"bg{i + 1}_{u}" for i in range(n_bg) for u in model.inputs]
    sys = control.StateSpace(
        a,
        b_ss,
        c_ss,
        d_ss,
        inputs=list(model.inputs),
        outputs=list(model.outputs),
        states=states,
        name=model.label(b),
    )
    g_ss = _frequency_response(a, b_ss, c_ss, d_ss, omega)
    sys.approximation_error = float(np.linalg.norm(g_ss - target)) / scale
    sys.approximation_error_peak = float(np.abs(g_ss - target).max() / np.abs(target).max())
    sys.approximation_error_pointwise = float(
        np.max(np.linalg.norm(g_ss - target, axis=(1, 2)) * weight)
    )
    sys.approximation_band_hz = (lo, hi)
    if sys.approximation_error_pointwise > rtol:
        warnings.warn(
            f"to_statespace: the realisation matches the model to "
            f"{sys.approximation_error_pointwise:.2g} (largest relative error at one "
            f"frequency) over {lo:g}-{hi:g} Hz, not {rtol:g}: "
            "narrow band_hz towards the fitted band",
            SysidWarning,
            stacklevel=3,
        )
    return sys


def to_frd(
    model: ExportableModel,
    frequencies_hz: Sequence[float] | np.ndarray | None = None,
    bias: Sequence[float] | np.ndarray | None = None,
) -> control.FrequencyResponseData:
    """The model's exact response at ``bias`` as a :class:`control.FrequencyResponseData`.

    Parameters
    ----------
    frequencies_hz : array_like, optional
        Positive, strictly increasing frequencies (Hz); default 1001 points over the fitted
        band ``omega_center ± omega_half``.
    bias : sequence of float, optional
        Bias potentials (volts relative to ground), one per electrode; default 0 V.

    Returns
    -------
    control.FrequencyResponseData
        :meth:`~.fitted.FittedModel.response` at those frequencies (stored in rad/s, as
        python-control expects), inputs and outputs named after the data's channels, named
        after the bias.

    Raises
    ------
    ModelError
        For a non-finite bias.
    FrequencyGridError
        For frequencies that are not finite, positive and strictly increasing.
    TypeError
        For a bias that is not numbers.
    """
    import control

    b = model.check_bias(bias)
    if frequencies_hz is None:
        f = np.linspace(*_band(model, None), N_BAND_POINTS)
    else:
        try:
            f = np.atleast_1d(np.asarray(frequencies_hz, dtype=float))
        except (TypeError, ValueError):
            raise FrequencyGridError(
                f"frequencies_hz must be numbers (Hz); got {frequencies_hz!r}"
            ) from None
        if f.ndim != 1 or f.size == 0:
            raise FrequencyGridError(
                f"frequencies_hz must be a non-empty 1-D grid; got shape {f.shape}"
            )
        if not np.all(np.isfinite(f)) or f.min() <= 0 or np.any(np.diff(f) <= 0):
            raise FrequencyGridError(
                "frequencies_hz must be finite, positive and strictly increasing"
            )
    response = model.response(f, b)
    return control.FrequencyResponseData(
        np.transpose(response, (1, 2, 0)),
        2 * np.pi * f,
        inputs=list(model.inputs),
        outputs=list(model.outputs),
        name=model.label(b),
    )


def _band(model: ExportableModel, band_hz: tuple[float, float] | None) -> tuple[float, float]:
    """``band_hz`` checked, or the fitted band ``omega_center ± omega_half`` (Hz)."""
    if band_hz is None:
        return (
            (model.omega_center - model.omega_half) / (2 * np.pi),
            (model.omega_center + model.omega_half) / (2 * np.pi),
        )
    try:
        lo, hi = (float(x) for x in band_hz)
    except (TypeError, ValueError):
        raise FrequencyGridError(
            f"band_hz must be two frequencies (low, high) in Hz; got {band_hz!r}"
        ) from None
    if not (np.isfinite(lo) and np.isfinite(hi) and 0 < lo < hi):
        raise FrequencyGridError(
            f"band_hz must be finite frequencies with 0 < low < high (Hz); got ({lo}, {hi})"
        )
    return lo, hi


def _real_realisation(
    t: np.ndarray, bc: np.ndarray, cc: np.ndarray
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Real ``(A, B, C)`` of ``Cc (sI - T)^-1 Bc`` plus its conjugate system.

    The complex state ``z_i`` becomes ``(Re z_i, Im z_i)``; the output is ``2 Re(Cc z)``.
    """
    n = t.shape[0]
    a = np.zeros((2 * n, 2 * n))
    for i in range(n):
        for j in range(n):
            a[2 * i : 2 * i + 2, 2 * j : 2 * j + 2] = [
                [t[i, j].real, -t[i, j].imag],
                [t[i, j].imag, t[i, j].real],
            ]
    b = np.empty((2 * n, bc.shape[1]))
    b[0::2], b[1::2] = bc.real, bc.imag
    c = np.empty((cc.shape[0], 2 * n))
    c[:, 0::2], c[:, 1::2] = 2 * cc.real, -2 * cc.imag
    return a, b, c


def _frequency_response(
    a: np.ndarray, b: np.ndarray, c: np.ndarray, d: np.ndarray, omega: np.ndarray
) -> np.ndarray:
    """``C (j omega I - A)^-1 B + D``, shape ``(N, n_out, n_in)``."""
    eye = np.eye(a.shape[0])
    return c @ np.linalg.solve(1j * omega[:, None, None] * eye - a, b) + d
