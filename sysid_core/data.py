"""Multi-experiment frequency-response data sets (xarray) and their validation.

Schema of a data set (an :class:`xarray.Dataset`):

* ``response``: complex, dims ``(experiment, frequency, output, input)``, the measured MIMO
  frequency response.
* ``measured``: bool, dims ``(experiment, frequency)``, optional. Experiments may use different
  frequency grids (the paper's ``m_k`` points each); the ``frequency`` coordinate is then the union
  of the grids and ``measured`` marks which points experiment ``k`` has. Unmeasured points hold NaN.
* coordinates: ``experiment`` (int), ``frequency`` (Hz, strictly increasing), ``output``,
  ``input``, ``electrode`` (names) and ``bias`` (volts relative to ground, dims
  ``(experiment, electrode)``).
* attributes: ``device``, ``structure_potential`` (volts, ``v_gyro``), ``frequency_units``
  (``"Hz"``), ``bias_units`` (``"V"``), ``response_units``.

The electrode potential seen by the structure is ``v = structure_potential - bias``.
"""

from __future__ import annotations

import os
from collections.abc import Sequence
from pathlib import Path

import numpy as np
import xarray as xr

from sysid_core.errors import (
    DataError,
    DimensionError,
    FrequencyGridError,
    MissingBiasError,
    NonFiniteDataError,
    RankConditionError,
    TooFewExperimentsError,
)
from sysid_core.io import atomic_write

__all__ = [
    "RESPONSE_DIMS",
    "check_rank_condition",
    "concat_experiments",
    "experiment_from_measurement",
    "load_dataset",
    "make_dataset",
    "measured_mask",
    "potentials",
    "save_dataset",
    "to_frd",
    "validate",
]

RESPONSE_DIMS = ("experiment", "frequency", "output", "input")
_RANK_TOL = 1e-9
#: Range of the largest |response| entry of an experiment that the fit's scaling handles.
MIN_MAGNITUDE, MAX_MAGNITUDE = 1e-100, 1e100


def make_dataset(
    responses: Sequence[np.ndarray],
    frequencies_hz: Sequence[np.ndarray] | np.ndarray,
    biases: np.ndarray | Sequence[Sequence[float]],
    electrodes: Sequence[str],
    structure_potential: float,
    device: str = "unknown",
    outputs: Sequence[str] = ("y1", "y2"),
    inputs: Sequence[str] = ("u1", "u2"),
    response_units: str = "V/V",
) -> xr.Dataset:
    """Build a data set from per-experiment responses.

    Parameters
    ----------
    responses : sequence of ndarray
        One complex array of shape ``(m_k, n_out, n_in)`` per experiment.
    frequencies_hz : ndarray or sequence of ndarray
        One grid shared by every experiment, or one grid per experiment (Hz).
    biases : array_like, shape (n_exp, n_e)
        Bias potentials relative to ground (volts), per experiment and electrode.
    electrodes : sequence of str
        Names of the bias electrodes.
    structure_potential : float
        ``v_gyro`` in volts.
    device, outputs, inputs, response_units
        Metadata.

    Returns
    -------
    xarray.Dataset
        Following the schema of this module (not yet validated; call :func:`validate`).
    """
    n_exp = len(responses)
    if isinstance(frequencies_hz, np.ndarray) and frequencies_hz.ndim == 1:
        grids = [np.asarray(frequencies_hz, dtype=float)] * n_exp
    else:
        grids = [np.asarray(f, dtype=float) for f in frequencies_hz]
    if len(grids) != n_exp:
        raise DimensionError(f"{n_exp} responses but {len(grids)} frequency grids")
    bias = np.asarray(biases, dtype=float)
    if bias.shape != (n_exp, len(electrodes)):
        raise MissingBiasError(
            f"biases have shape {bias.shape}; expected ({n_exp}, {len(electrodes)}): "
            "one bias per experiment and electrode"
        )
    same = all(g.shape == grids[0].shape and np.array_equal(g, grids[0]) for g in grids)
    union = grids[0] if same else np.unique(np.concatenate(grids))
    n_out, n_in = len(outputs), len(inputs)
    data = np.full((n_exp, union.size, n_out, n_in), np.nan + 1j * np.nan, dtype=complex)
    mask = np.zeros((n_exp, union.size), dtype=bool)
    for k, (resp, grid) in enumerate(zip(responses, grids, strict=True)):
        resp = np.asarray(resp)
        if resp.shape != (grid.size, n_out, n_in):
            raise DimensionError(
                f"experiment {k}: response has shape {resp.shape}; expected "
                f"({grid.size}, {n_out}, {n_in}) (frequency, output, input)"
            )
        pos = np.searchsorted(union, grid) if not same else np.arange(grid.size)
        data[k, pos] = resp
        mask[k, pos] = True
    ds = xr.Dataset(
        {"response": (RESPONSE_DIMS, data)},
        coords={
            "experiment": np.arange(n_exp),
            "frequency": ("frequency", union, {"units": "Hz"}),
            "output": list(outputs),
            "input": list(inputs),
            "electrode": list(electrodes),
            "bias": (("experiment", "electrode"), bias, {"units": "V"}),
        },
        attrs={
            "device": device,
            "structure_potential": float(structure_potential),
            "frequency_units": "Hz",
            "bias_units": "V",
            "response_units": response_units,
        },
    )
    if not same:
        ds["measured"] = (("experiment", "frequency"), mask)
    return ds


def experiment_from_measurement(
    measurement: xr.DataArray,
    bias: Sequence[float],
    electrodes: Sequence[str],
    structure_potential: float,
    device: str = "unknown",
) -> xr.Dataset:
    """Wrap one device measurement (dims frequency, output, input) as a one-experiment data set."""
    if tuple(measurement.dims) != ("frequency", "output", "input"):
        raise DimensionError(
            f"a measurement must have dims ('frequency', 'output', 'input'), got {measurement.dims}"
        )
    return make_dataset(
        [np.asarray(measurement.values)],
        np.asarray(measurement["frequency"].values, dtype=float),
        [list(bias)],
        electrodes,
        structure_potential,
        device=device,
        outputs=[str(o) for o in measurement["output"].values],
        inputs=[str(i) for i in measurement["input"].values],
        response_units=str(measurement.attrs.get("units", "V/V")),
    )


def concat_experiments(datasets: Sequence[xr.Dataset]) -> xr.Dataset:
    """Join data sets experiment-wise (grids may differ); metadata come from the first one."""
    if not datasets:
        raise DataError("no data sets to join")
    first = datasets[0]
    responses, grids, biases = [], [], []
    for ds in datasets:
        mask = measured_mask(ds)
        f = ds["frequency"].values
        for k in range(ds.sizes["experiment"]):
            responses.append(ds["response"].values[k][mask[k]])
            grids.append(f[mask[k]])
            biases.append(ds["bias"].values[k])
    return make_dataset(
        responses,
        grids,
        np.array(biases),
        [str(e) for e in first["electrode"].values],
        float(first.attrs["structure_potential"]),
        device=str(first.attrs.get("device", "unknown")),
        outputs=[str(o) for o in first["output"].values],
        inputs=[str(i) for i in first["input"].values],
        response_units=str(first.attrs.get("response_units", "V/V")),
    )


def measured_mask(ds: xr.Dataset) -> np.ndarray:
    """Boolean ``(experiment, frequency)`` array: which points each experiment measured."""
    if "measured" in ds:
        return np.asarray(ds["measured"].values, dtype=bool)
    return np.ones((ds.sizes["experiment"], ds.sizes["frequency"]), dtype=bool)


def potentials(ds: xr.Dataset) -> np.ndarray:
    """Electrode potentials ``v = v_gyro - bias`` seen by the structure, ``(n_exp, n_e)``."""
    return float(ds.attrs["structure_potential"]) - np.asarray(ds["bias"].values, dtype=float)


def check_rank_condition(
    bias: np.ndarray | Sequence[Sequence[float]],
    structure_potential: float,
    electrodes: Sequence[str] | None = None,
) -> None:
    """Check the rank condition (6): ``rank [1, v_k1^2, ..., v_kne^2] = n_e + 1``.

    Parameters
    ----------
    bias : array_like, shape (n_exp, n_e)
        Bias potentials relative to ground (volts).
    structure_potential : float
        ``v_gyro`` (volts).
    electrodes : sequence of str, optional
        Names, for the error message.

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
    if n_exp < n_e + 1:
        raise TooFewExperimentsError(
            f"{n_exp} experiment(s) for {n_e} bias electrode(s): the stiffness matrices "
            f"K0, K1..K{n_e} need at least {n_e + 1} experiments satisfying the rank condition (6)"
        )
    w = (structure_potential - bias) ** 2
    phi = np.hstack([np.ones((n_exp, 1)), w])
    phi = phi / np.maximum(np.abs(phi).max(axis=0), 1e-300)
    if np.linalg.matrix_rank(phi, tol=_RANK_TOL * np.sqrt(n_exp)) == n_e + 1:
        return
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
        if np.linalg.norm(resid) > _RANK_TOL * max(np.linalg.norm(row), 1.0):
            basis.append(row)
            kept.append(k)
        else:
            redundant.append(f"experiment {k} is a combination of experiments {kept}")
    constant = [names[p] for p in range(n_e) if np.ptp(w[:, p]) <= _RANK_TOL * w[:, p].max()]
    detail = "; ".join(redundant)
    if constant:
        detail += f"; the potential of electrode(s) {', '.join(constant)} never changes"
    raise RankConditionError(
        f"the experiment design violates the rank condition (6): rank {len(kept)} < {n_e + 1}. "
        f"{detail}. Fix: vary each electrode's squared potential independently, e.g. step one "
        f"electrode at a time from a base bias (eq. 18)."
    )


def validate(ds: xr.Dataset) -> xr.Dataset:
    """Check a data set against the schema; return it unchanged or raise a :class:`DataError`.

    Rejects, each with its own error class and a message saying what and where: NaN/inf values,
    wrong dims or shapes, non-increasing or duplicate frequencies, missing biases, an experiment
    whose response is all zero or of absurd magnitude (beyond 1e±100), fewer than ``n_e + 1``
    experiments, and designs that violate the rank condition (6).
    """
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
    check_rank_condition(bias, float(vg), electrodes)
    return ds


def save_dataset(ds: xr.Dataset, path: str | os.PathLike[str]) -> Path:
    """Save as netCDF (h5netcdf engine), atomically; complex values are kept exactly.

    The complex response is stored as two float64 variables ``response_real`` and
    ``response_imag`` so that any netCDF reader can open the file.
    """
    out = ds.copy()
    for name in [v for v in ds.data_vars if np.iscomplexobj(ds[v].values)]:
        out[f"{name}_real"] = ds[name].real
        out[f"{name}_imag"] = ds[name].imag
        out[f"{name}_real"].attrs["sysid_complex"] = f"{name}: real part"
        out[f"{name}_imag"].attrs["sysid_complex"] = f"{name}: imaginary part"
        out = out.drop_vars(name)
    if "measured" in out:
        out["measured"] = out["measured"].astype("int8")
        out["measured"].attrs["sysid_bool"] = 1
    return atomic_write(path, lambda tmp: out.to_netcdf(tmp, engine="h5netcdf"))


def load_dataset(path: str | os.PathLike[str]) -> xr.Dataset:
    """Load a data set written by :func:`save_dataset` (into memory; the file is closed)."""
    path = Path(path)
    if not path.exists():
        raise DataError(f"no data file at {path}")
    try:
        with xr.open_dataset(path, engine="h5netcdf") as raw:
            ds = raw.load()
    except (OSError, ValueError) as exc:
        raise DataError(f"cannot read {path} as netCDF: {exc}") from exc
    for name in [v for v in ds.data_vars if str(v).endswith("_real")]:
        base = str(name)[: -len("_real")]
        if f"{base}_imag" in ds:
            ds[base] = ds[name] + 1j * ds[f"{base}_imag"]
            ds[base].attrs = {}
            ds = ds.drop_vars([name, f"{base}_imag"])
    if "measured" in ds:
        ds["measured"] = ds["measured"].astype(bool)
        ds["measured"].attrs = {}
    for coord in ("output", "input", "electrode"):
        if coord in ds.coords:
            ds = ds.assign_coords({coord: [str(v) for v in ds[coord].values]})
    return ds


def to_frd(ds: xr.Dataset, experiment: int = 0):  # -> control.FrequencyResponseData
    """One experiment as a :class:`control.FrequencyResponseData` (frequencies in rad/s)."""
    import control

    mask = measured_mask(ds)[experiment]
    resp = ds["response"].values[experiment][mask]  # (m, out, in)
    omega = 2 * np.pi * ds["frequency"].values[mask]
    return control.FrequencyResponseData(
        np.transpose(resp, (1, 2, 0)),
        omega,
        inputs=[str(i) for i in ds["input"].values],
        outputs=[str(o) for o in ds["output"].values],
        name=f"{ds.attrs.get('device', 'data')}[experiment {experiment}]",
    )
