"""The optional per-point variables of a data set, laid out on its frequency grid.

A measurement may carry, per point, a time stamp (``time_s``, the bench clock) and its noise
variances (``noise_var``, per channel); a data set of several experiments stores them on the
union of their grids, NaN where an experiment did not measure or did not say
(:mod:`sysid_core.data.schema`). These are the tables' builders.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
import xarray as xr

from sysid_core.errors import DimensionError

__all__ = ["measurement_noise", "noise_table", "time_table"]


def time_table(
    times_s: Sequence[np.ndarray | None],
    grids: Sequence[np.ndarray],
    union: np.ndarray,
    same: bool,
) -> np.ndarray:
    """The ``time_s`` variable: each experiment's stamps at its grid's places, NaN elsewhere."""
    if len(times_s) != len(grids):
        raise DimensionError(f"{len(grids)} experiments but {len(times_s)} time-stamp arrays")
    table = np.full((len(grids), union.size), np.nan)
    for k, (times, grid) in enumerate(zip(times_s, grids, strict=True)):
        if times is None:
            continue
        t = np.asarray(times, dtype=float).reshape(-1)
        if t.size != grid.size:
            raise DimensionError(
                f"experiment {k}: {t.size} time stamps for {grid.size} frequencies"
            )
        pos = np.arange(grid.size) if same else np.searchsorted(union, grid)
        table[k, pos] = t
    return table


def noise_table(
    noise_var: Sequence[np.ndarray | None],
    grids: Sequence[np.ndarray],
    union: np.ndarray,
    same: bool,
    channels: tuple[int, int],
) -> np.ndarray:
    """The ``noise_var`` variable: each experiment's variances at its grid's places, else NaN."""
    if len(noise_var) != len(grids):
        raise DimensionError(f"{len(grids)} experiments but {len(noise_var)} noise-variance arrays")
    table = np.full((len(grids), union.size, *channels), np.nan)
    for k, (var, grid) in enumerate(zip(noise_var, grids, strict=True)):
        if var is None:
            continue
        v = np.asarray(var)
        if np.iscomplexobj(v):
            raise DimensionError(f"experiment {k}: noise_var must be real (a variance)")
        if v.shape != (grid.size, *channels):
            raise DimensionError(
                f"experiment {k}: noise_var has shape {v.shape}; expected "
                f"({grid.size}, {channels[0]}, {channels[1]}) (frequency, output, input)"
            )
        pos = np.arange(grid.size) if same else np.searchsorted(union, grid)
        table[k, pos] = v.astype(float)
    return table


def measurement_noise(measurement: xr.DataArray) -> np.ndarray | None:
    """A measurement's ``noise_var`` coordinate as ``(frequency, output, input)``, or None."""
    if "noise_var" not in measurement.coords:
        return None
    var = measurement.coords["noise_var"]
    if set(var.dims) != {"frequency", "output", "input"}:
        raise DimensionError(
            f"a measurement's noise_var must have dims ('frequency', 'output', 'input'), got "
            f"{var.dims}"
        )
    return np.asarray(var.transpose("frequency", "output", "input").values)
