"""Multi-experiment frequency-response data sets (xarray): schema, building, files.

Schema of a data set (an :class:`xarray.Dataset`):

* ``response``: complex, dims ``(experiment, frequency, output, input)``, the measured MIMO
  frequency response.
* ``measured``: bool, dims ``(experiment, frequency)``, optional. Experiments may use different
  frequency grids (the paper's ``m_k`` points each); the ``frequency`` coordinate is then the union
  of the grids and ``measured`` marks which points experiment ``k`` has. Unmeasured points hold NaN.
* ``time_s``: float, dims ``(experiment, frequency)``, optional: each point's time stamp
  (seconds, the device's clock), NaN where unknown or unmeasured.
* ``noise_var``: float, dims ``(experiment, frequency, output, input)``, optional: the device's
  estimate of the variance ``E|n|²`` of each complex response entry's noise (response units
  squared), NaN where unknown or unmeasured. The fit weights its points by it when every point
  has one (:class:`~sysid_core.identification.problem.FitProblem`).
* coordinates: ``experiment`` (int), ``frequency`` (Hz, strictly increasing), ``output``,
  ``input``, ``electrode`` (names) and ``bias`` (volts relative to ground, dims
  ``(experiment, electrode)``).
* attributes: ``device``, ``structure_potential`` (volts, ``v_gyro``), ``frequency_units``
  (``"Hz"``), ``bias_units`` (``"V"``), ``response_units``.

The electrode potential seen by the structure is ``v = structure_potential - bias`` (its square:
:func:`squared_potentials`). Checks of a data set: :mod:`sysid_core.data.validation`.
"""

from __future__ import annotations

import os
from collections.abc import Sequence
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np
import xarray as xr

from sysid_core.data.io import atomic_write
from sysid_core.data.pointvars import measurement_noise, noise_table, time_table
from sysid_core.errors import (
    DataError,
    DimensionError,
    MissingBiasError,
)

if TYPE_CHECKING:
    import control

__all__ = [
    "RESPONSE_DIMS",
    "concat_experiments",
    "experiment_from_measurement",
    "load_dataset",
    "make_dataset",
    "measured_mask",
    "point_noise",
    "point_times",
    "read_netcdf",
    "requested_bias",
    "save_dataset",
    "squared_potentials",
    "to_frd",
]

RESPONSE_DIMS = ("experiment", "frequency", "output", "input")


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
    times_s: Sequence[np.ndarray | None] | None = None,
    noise_var: Sequence[np.ndarray | None] | None = None,
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
    times_s : sequence of (ndarray or None), optional
        Per experiment, the time stamp of each point of its grid (seconds, the device's
        clock), or ``None`` for an experiment measured at unknown times. Stored as the
        variable ``time_s`` (``experiment``, ``frequency``; NaN where unknown or unmeasured)
        when any experiment has them.
    noise_var : sequence of (ndarray or None), optional
        Per experiment, the estimated variance ``E|n|²`` of each response entry's noise at each
        point of its grid, shape ``(m_k, n_out, n_in)`` like its response (NaN: unknown), or
        ``None`` for an experiment whose noise is unknown. Stored as the variable ``noise_var``
        (``experiment``, ``frequency``, ``output``, ``input``; NaN where unknown or unmeasured)
        when any experiment has one.

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
    if times_s is not None and any(t is not None for t in times_s):
        ds["time_s"] = (("experiment", "frequency"), time_table(times_s, grids, union, same))
        ds["time_s"].attrs["units"] = "s"
    if noise_var is not None and any(v is not None for v in noise_var):
        table = noise_table(noise_var, grids, union, same, (n_out, n_in))
        ds["noise_var"] = (RESPONSE_DIMS, table)
        ds["noise_var"].attrs["units"] = f"({response_units})^2"
    return ds


def point_noise(ds: xr.Dataset, k: int) -> np.ndarray | None:
    """Experiment ``k``'s noise variances at its measured points, ``(m_k, n_out, n_in)``, or None.

    ``None`` when the data set has no ``noise_var`` or experiment ``k`` has none at any point;
    NaN entries (unknown) are kept.
    """
    if "noise_var" not in ds:
        return None
    if set(ds["noise_var"].dims) != set(RESPONSE_DIMS):
        raise DimensionError(
            f"'noise_var' has dims {ds['noise_var'].dims}; expected {RESPONSE_DIMS}"
        )
    var = np.asarray(ds["noise_var"].transpose(*RESPONSE_DIMS).values[k], dtype=float)
    var = var[measured_mask(ds)[k]]
    return var if np.any(~np.isnan(var)) else None


def point_times(ds: xr.Dataset, k: int) -> np.ndarray | None:
    """Experiment ``k``'s time stamps at its measured points (seconds), or ``None``.

    ``None`` when it has none, or not at every point: a measurement at unknown times.
    """
    if "time_s" not in ds:
        return None
    t = np.asarray(ds["time_s"].values[k], dtype=float)[measured_mask(ds)[k]]
    return t if np.all(np.isfinite(t)) else None


def experiment_from_measurement(
    measurement: xr.DataArray,
    bias: Sequence[float] | np.ndarray,
    electrodes: Sequence[str],
    structure_potential: float,
    device: str = "unknown",
) -> xr.Dataset:
    """Wrap one device measurement (dims frequency, output, input) as a one-experiment data set.

    The experiment's ``bias`` is what the gyro really saw: the measurement's ``applied_bias``
    attribute when the device reports one (a DAC's nearest code, a source's read-back) with one
    finite value per electrode, else the requested ``bias``. The requested bias is kept in the
    attribute ``requested_bias`` (a resumed run finds its measurements by it). The optional
    coordinates ``time_s`` (``frequency``) and ``noise_var`` (``frequency``, ``output``,
    ``input``) become the variables of the same names.
    """
    if tuple(measurement.dims) != ("frequency", "output", "input"):
        raise DimensionError(
            f"a measurement must have dims ('frequency', 'output', 'input'), got {measurement.dims}"
        )
    requested = np.asarray(bias, dtype=float).reshape(-1)
    used = requested
    applied = measurement.attrs.get("applied_bias")
    if applied is not None:
        values = np.atleast_1d(np.asarray(applied, dtype=float)).reshape(-1)
        if values.shape == requested.shape and np.all(np.isfinite(values)):
            used = values
    ds = make_dataset(
        [np.asarray(measurement.values)],
        np.asarray(measurement["frequency"].values, dtype=float),
        [used.tolist()],
        electrodes,
        structure_potential,
        device=device,
        outputs=[str(o) for o in measurement["output"].values],
        inputs=[str(i) for i in measurement["input"].values],
        response_units=str(measurement.attrs.get("units", "V/V")),
        times_s=[
            np.asarray(measurement["time_s"].values, dtype=float)
            if "time_s" in measurement.coords
            else None
        ],
        noise_var=[measurement_noise(measurement)],
    )
    ds.attrs["requested_bias"] = requested.tolist()
    return ds


def requested_bias(ds: xr.Dataset) -> np.ndarray:
    """The bias a one-experiment data set was requested at (its applied bias if not recorded)."""
    if "requested_bias" in ds.attrs:
        return np.atleast_1d(np.asarray(ds.attrs["requested_bias"], dtype=float)).reshape(-1)
    return np.asarray(ds["bias"].values[0], dtype=float)


def concat_experiments(datasets: Sequence[xr.Dataset]) -> xr.Dataset:
    """Join data sets experiment-wise (grids may differ); metadata come from the first one.

    An ``epoch`` coordinate (per experiment: when it was measured, see
    :mod:`sysid_core.identification.problem`) is kept when every data set has one. The
    variables ``time_s`` and ``noise_var`` are kept (NaN for the experiments without them).
    """
    if not datasets:
        raise DataError("no data sets to join")
    first = datasets[0]
    responses, grids, biases = [], [], []
    times: list[np.ndarray | None] = []
    noise: list[np.ndarray | None] = []
    for ds in datasets:
        mask = measured_mask(ds)
        f = ds["frequency"].values
        for k in range(ds.sizes["experiment"]):
            responses.append(ds["response"].values[k][mask[k]])
            grids.append(f[mask[k]])
            biases.append(ds["bias"].values[k])
            times.append(point_times(ds, k))
            noise.append(point_noise(ds, k))
    joined = make_dataset(
        responses,
        grids,
        np.array(biases),
        [str(e) for e in first["electrode"].values],
        float(first.attrs["structure_potential"]),
        device=str(first.attrs.get("device", "unknown")),
        outputs=[str(o) for o in first["output"].values],
        inputs=[str(i) for i in first["input"].values],
        response_units=str(first.attrs.get("response_units", "V/V")),
        times_s=times,
        noise_var=noise,
    )
    if all("epoch" in ds.coords for ds in datasets):
        epochs = np.concatenate([np.asarray(ds["epoch"].values, dtype=int) for ds in datasets])
        joined = joined.assign_coords(epoch=("experiment", epochs))
    return joined


def squared_potentials(
    structure_potential: float, bias: np.ndarray | Sequence[float]
) -> np.ndarray:
    """``w = (v_gyro - dv)**2``: the squared electrode potentials seen by the structure.

    The one place this relation is written: the stiffness depends on ``w`` linearly, which is
    what makes the fit (rank condition (6)) and the tuning criteria convex. Works elementwise on
    any array of biases (volts relative to ground).
    """
    return (float(structure_potential) - np.asarray(bias, dtype=float)) ** 2


def measured_mask(ds: xr.Dataset) -> np.ndarray:
    """Boolean ``(experiment, frequency)`` array: which points each experiment measured."""
    if "measured" in ds:
        return np.asarray(ds["measured"].values, dtype=bool)
    return np.ones((ds.sizes["experiment"], ds.sizes["frequency"]), dtype=bool)


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
        out = out.drop_vars([name])
    if "measured" in out:
        out["measured"] = out["measured"].astype("int8")
        out["measured"].attrs["sysid_bool"] = 1
    return atomic_write(path, lambda tmp: out.to_netcdf(tmp, engine="h5netcdf"))


def read_netcdf(path: str | os.PathLike[str], what: str = "data") -> xr.Dataset:
    """The netCDF file at ``path``, loaded into memory (the file is closed).

    A missing or unreadable file raises a :class:`DataError` naming the file and ``what`` it
    should have held.
    """
    path = Path(path)
    if not path.exists():
        raise DataError(f"no {what} file at {path}")
    try:
        with xr.open_dataset(path, engine="h5netcdf") as raw:
            return raw.load()
    except (OSError, ValueError) as exc:
        raise DataError(f"cannot read {path} as {what} (netCDF): {exc}") from exc


def load_dataset(path: str | os.PathLike[str]) -> xr.Dataset:
    """Load a data set written by :func:`save_dataset` (into memory; the file is closed)."""
    ds = read_netcdf(path)
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


def to_frd(ds: xr.Dataset, experiment: int = 0) -> control.FrequencyResponseData:
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
