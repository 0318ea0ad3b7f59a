"""Checks of a data set against the schema of :mod:`sysid_core.data.schema`, and the rank condition.

* :func:`validate`: every defect has its own error class and a message saying what and where.
* :func:`check_rank_condition`: eq. (6) of Kim & M'Closkey, ``rank [1, v_k1^2, ..., v_kne^2] =
  n_e + 1``, checked on a design before anything is measured, naming the redundant experiments.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
import xarray as xr

from sysid_core.data.schema import RESPONSE_DIMS, measured_mask, squared_potentials
from sysid_core.errors import (
    DataError,
    DimensionError,
    FrequencyGridError,
    MissingBiasError,
    NonFiniteDataError,
    RankConditionError,
    TooFewExperimentsError,
)

__all__ = [
    "MAX_MAGNITUDE",
    "MIN_MAGNITUDE",
    "check_rank_condition",
    "design_rank",
    "validate",
]

_RANK_TOL = 1e-9
#: Range of the largest |response| entry of an experiment that the fit's scaling handles.
MIN_MAGNITUDE, MAX_MAGNITUDE = 1e-100, 1e100


def _regressors(w: np.ndarray, quadratic: bool) -> np.ndarray:
    """The rows ``[1, w, (w²)]`` of the rank condition, centred and scaled column by column."""
    phi = np.hstack([np.ones((w.shape[0], 1)), w] + ([w**2] if quadratic else []))
    phi = phi - np.r_[0.0, phi[0, 1:]]  # centred on the first experiment: better conditioned
    phi[:, 0] = 1.0
    return phi / np.maximum(np.abs(phi).max(axis=0), 1e-300)


def design_rank(
    bias: np.ndarray | Sequence[Sequence[float]], structure_potential: float, quadratic: bool
) -> int:
    """The rank of the rank condition's regressors over ``bias`` (shape ``(n_exp, n_e)``).

    ``n_e + 1`` (``2 n_e + 1`` with ``quadratic``) is what (6) asks for
    (:func:`check_rank_condition`).
    """
    bias = np.atleast_2d(np.asarray(bias, dtype=float))
    phi = _regressors(squared_potentials(structure_potential, bias), quadratic)
    return int(np.linalg.matrix_rank(phi, tol=_RANK_TOL * np.sqrt(bias.shape[0])))


def check_rank_condition(
    bias: np.ndarray | Sequence[Sequence[float]],
    structure_potential: float,
    electrodes: Sequence[str] | None = None,
    quadratic: bool = False,
) -> None:
    """Check the rank condition (6): ``rank [1, v_k1^2, ..., v_kne^2] = n_e + 1``.

    With ``quadratic`` (the quadratic stiffness law, which adds ``L_p w_p²``) the regressors
    are ``[1, w, w²]`` and the rank must be ``2 n_e + 1``: each electrode at two biases
    besides the centre (a two-sided design).

    Parameters
    ----------
    bias : array_like, shape (n_exp, n_e)
        Bias potentials relative to ground (volts).
    structure_potential : float
        ``v_gyro`` (volts).
    electrodes : sequence of str, optional
        Names, for the error message.
    quadratic : bool
        Check the condition of the quadratic stiffness law.

    Raises
    ------
    TooFewExperimentsError
        With fewer than ``n_e + 1`` experiments.
    RankConditionError
        Naming the experiments that add nothing (combinations of earlier ones) and any
        electrode whose potential never changes.
    """
    bias = np.atleast_2d(np.asarray(bias, dtype=float))
    n_exp, n_e = bias.shape
    names = list(electrodes) if electrodes is not None else [f"#{p}" for p in range(n_e)]
    need = 2 * n_e + 1 if quadratic else n_e + 1
    if n_exp < need:
        law = f" and L1..L{n_e} (quadratic stiffness law)" if quadratic else ""
        raise TooFewExperimentsError(
            f"{n_exp} experiment(s) for {n_e} bias electrode(s): the stiffness matrices "
            f"K0, K1..K{n_e}{law} need at least {need} experiments satisfying the rank "
            "condition (6)"
            + (
                "; each electrode stepped up and down gives them ([experiment] design = "
                '"two-sided", the default of this law)'
                if quadratic
                else ""
            )
        )
    if design_rank(bias, structure_potential, quadratic) == need:
        return
    w = squared_potentials(structure_potential, bias)
    phi = _regressors(w, quadratic)
    # Greedy: which experiments do not add to the span of the ones before them?
    basis: list[np.ndarray] = []
    kept: list[int] = []
    redundant: list[str] = []
    for k in range(n_exp):
        row = phi[k]
        if basis:
            q, _ = np.linalg.qr(np.array(basis).T)
            resid = row - q @ (q.T @ row)
        else:
            resid = row
        if np.linalg.norm(resid) > _RANK_TOL * max(float(np.linalg.norm(row)), 1.0):
            basis.append(row)
            kept.append(k)
        else:
            redundant.append(f"experiment {k} is a combination of experiments {kept}")
    constant = [names[p] for p in range(n_e) if np.ptp(w[:, p]) <= _RANK_TOL * w[:, p].max()]
    detail = "; ".join(redundant)
    if constant:
        detail += f"; the potential of electrode(s) {', '.join(constant)} never changes"
    fix = (
        'step each electrode up and down from a base bias ([experiment] design = "two-sided")'
        if quadratic
        else "step one electrode at a time from a base bias (eq. 18)"
    )
    raise RankConditionError(
        f"the experiment design violates the rank condition (6): rank {len(kept)} < {need}. "
        f"{detail}. Fix: vary each electrode's squared potential independently, e.g. {fix}."
    )


def validate(ds: xr.Dataset) -> xr.Dataset:
    """Check a data set against the schema; return it unchanged or raise a :class:`DataError`.

    Rejects, each with its own error class and a message saying what and where: NaN/inf values,
    wrong dims or shapes, non-increasing or duplicate frequencies, missing biases, an experiment
    whose response is all zero or of absurd magnitude (beyond 1e±100), fewer than ``n_e + 1``
    experiments, designs that violate the rank condition (6), and an optional ``noise_var``
    with other dims, complex values, or a negative or infinite variance at a measured point
    (NaN there means unknown).
    """
    resp = _check_response(ds)
    f = _check_frequencies(ds)
    bias, electrodes, vg = _check_bias(ds)
    _check_values(ds, resp, f)
    _check_noise(ds, f)
    check_rank_condition(bias, vg, electrodes)
    return ds


def _check_response(ds: xr.Dataset) -> xr.DataArray:
    """The data set's ``response``: complex, 2x2, with the dims of the schema."""
    if not isinstance(ds, xr.Dataset):
        raise DimensionError(f"expected an xarray.Dataset, got {type(ds).__name__}")
    if "response" not in ds:
        raise DimensionError("the data set has no 'response' variable")
    resp = ds["response"]
    if tuple(resp.dims) != RESPONSE_DIMS:
        raise DimensionError(f"'response' has dims {tuple(resp.dims)}; expected {RESPONSE_DIMS}")
    if not np.iscomplexobj(resp.values):
        raise DimensionError(f"'response' must be complex, got dtype {resp.dtype}")
    if resp.sizes["output"] != 2 or resp.sizes["input"] != 2:
        raise DimensionError(
            f"'response' is {resp.sizes['output']}x{resp.sizes['input']} (output x input); "
            "the two-mode gyro models need 2x2 data"
        )
    return resp


def _check_frequencies(ds: xr.Dataset) -> np.ndarray:
    """The frequency grid (Hz): 1-D, at least two points, finite, positive, increasing."""
    if "frequency" not in ds.coords or ds["frequency"].ndim != 1:
        raise DimensionError("the data set needs a 1-D 'frequency' coordinate (Hz)")
    f = np.asarray(ds["frequency"].values, dtype=float)
    if f.size < 2:
        raise FrequencyGridError(f"only {f.size} frequency point(s); a fit needs many more")
    bad = np.flatnonzero(~np.isfinite(f))
    if bad.size:
        raise NonFiniteDataError(f"frequency[{bad[0]}] is {f[bad[0]]}: frequencies must be finite")
    if f[0] <= 0:
        raise FrequencyGridError(f"frequency[0] = {f[0]} Hz: frequencies must be positive")
    steps = np.diff(f)
    if np.any(steps <= 0):
        i = int(np.flatnonzero(steps <= 0)[0])
        what = "duplicated" if steps[i] == 0 else "not increasing"
        raise FrequencyGridError(
            f"frequencies are {what} at index {i + 1}: {f[i]} Hz then {f[i + 1]} Hz; sort the "
            "points and drop duplicates (use a 'measured' mask for per-experiment grids)"
        )
    return f


def _check_bias(ds: xr.Dataset) -> tuple[np.ndarray, list[str] | None, float]:
    """The biases ``(n_exp, n_e)``, the electrode names (if given) and ``structure_potential``."""
    if "bias" not in ds.coords and "bias" not in ds:
        raise MissingBiasError("the data set has no 'bias' coordinate (experiment, electrode)")
    bias_da = ds["bias"]
    if tuple(bias_da.dims) != ("experiment", "electrode"):
        raise MissingBiasError(
            f"'bias' has dims {tuple(bias_da.dims)}; expected ('experiment', 'electrode')"
        )
    bias = np.asarray(bias_da.values, dtype=float)
    electrodes = [str(e) for e in ds["electrode"].values] if "electrode" in ds.coords else None
    missing = np.argwhere(~np.isfinite(bias))
    if missing.size:
        k, p = missing[0]
        name = electrodes[p] if electrodes else p
        raise MissingBiasError(
            f"bias of experiment {k}, electrode {name} is missing ({bias[k, p]})"
        )
    vg = ds.attrs.get("structure_potential")
    if vg is None or not np.isfinite(float(vg)):
        raise MissingBiasError(
            "attribute 'structure_potential' (v_gyro, volts) is missing or not finite"
        )
    return bias, electrodes, float(vg)


def _check_values(ds: xr.Dataset, resp: xr.DataArray, f: np.ndarray) -> None:
    """The measured points: the mask's shape, finite values, at least 2 per experiment."""
    mask = measured_mask(ds)
    if mask.shape != (resp.sizes["experiment"], f.size):
        raise DimensionError(f"'measured' has shape {mask.shape}; expected {resp.shape[:2]}")
    values = resp.values
    finite = np.isfinite(values).all(axis=(2, 3))
    bad_points = np.argwhere(mask & ~finite)
    if bad_points.size:
        k, q = bad_points[0]
        o, i = np.argwhere(~np.isfinite(values[k, q]))[0]
        raise NonFiniteDataError(
            f"response of experiment {k} at {f[q]} Hz (output {o}, input {i}) is "
            f"{values[k, q, o, i]}; {len(bad_points)} point(s) in all are not finite. "
            "Remeasure them or mark them unmeasured with the 'measured' variable"
        )
    empty = np.flatnonzero(mask.sum(axis=1) < 2)
    if empty.size:
        raise FrequencyGridError(f"experiment {empty[0]} has fewer than 2 measured points")
    _check_magnitudes(values, mask)


def _check_noise(ds: xr.Dataset, f: np.ndarray) -> None:
    """The optional ``noise_var``: real, the response's dims, finite and >= 0 or NaN (unknown)."""
    if "noise_var" not in ds:
        return
    var = ds["noise_var"]
    if tuple(var.dims) != RESPONSE_DIMS:
        raise DimensionError(f"'noise_var' has dims {tuple(var.dims)}; expected {RESPONSE_DIMS}")
    if var.dtype.kind not in "iuf":
        raise DimensionError(f"'noise_var' must be real (a variance), got dtype {var.dtype}")
    if var.shape != ds["response"].shape:
        raise DimensionError(
            f"'noise_var' has shape {var.shape}; expected that of 'response', "
            f"{ds['response'].shape}"
        )
    values = np.asarray(var.values, dtype=float)
    known = measured_mask(ds)[:, :, None, None] & ~np.isnan(values)
    bad = np.argwhere(known & ~(np.isfinite(values) & (values >= 0)))
    if bad.size:
        k, q, o, i = bad[0]
        cls = NonFiniteDataError if np.isinf(values[k, q, o, i]) else DataError
        raise cls(
            f"noise_var of experiment {k} at {f[q]} Hz (output {o}, input {i}) is "
            f"{values[k, q, o, i]}: a noise variance must be finite and >= 0 (NaN: unknown); "
            f"{len(bad)} value(s) in all"
        )


def _check_magnitudes(values: np.ndarray, mask: np.ndarray) -> None:
    """Every experiment's largest measured entry is nonzero and in the range the fit handles."""
    for k in range(values.shape[0]):
        mag = np.abs(values[k][mask[k]])
        if not mag.any():
            raise DataError(
                f"the response of experiment {k} is all zero: nothing to identify (was the "
                "analyzer connected and the gyro driven?)"
            )
        top = float(mag.max())
        if not MIN_MAGNITUDE <= top <= MAX_MAGNITUDE:
            raise DataError(
                f"the response of experiment {k} peaks at {top:.3g}, outside the range "
                f"{MIN_MAGNITUDE:g} to {MAX_MAGNITUDE:g} the fit can handle; express it in "
                "other units (e.g. divide by a constant gain)"
            )
