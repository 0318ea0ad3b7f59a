"""Measured data: the data-set schema, its checks, and every file the toolkit reads or writes.

Lives here: the ``xarray`` schema of a multi-experiment data set and its netCDF files
(:mod:`.schema`), the checks of a data set and of the rank condition (6) (:mod:`.validation`),
atomic file writing (:mod:`.io`), the one reader of text files (:mod:`.textfile`), one sweep
per file in CSV, Touchstone, MATLAB (v4 to v7.3,
:mod:`.mat73`) and netCDF (:mod:`.sweepfiles`), instruments' text exports read with column maps
(:mod:`.columnmap`, :mod:`.columnsweep`, :mod:`.columnguess`), manifests of measured experiments
(:mod:`.manifest`, :mod:`.export`) and the reading of a run folder's measurements
(:mod:`.runfolder`).

May import: :mod:`sysid_core.errors` and third-party libraries only.
"""

from sysid_core.data.schema import (
    RESPONSE_DIMS,
    concat_experiments,
    experiment_from_measurement,
    load_dataset,
    make_dataset,
    measured_mask,
    point_noise,
    point_times,
    read_netcdf,
    requested_bias,
    save_dataset,
    squared_potentials,
    to_frd,
)

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
