"""The data set: measured frequency responses in memory, their schema and their checks.

Lives here: the ``xarray`` schema of a multi-experiment data set and its own netCDF files
(:mod:`.schema`, per-point time stamps and noise in :mod:`.pointvars`), the checks of a data set
and of the rank condition (6) (:mod:`.validation`), one sweep in memory and the checks every
file format shares (:mod:`.sweep`), and atomic file writing (:mod:`.io`). The files a lab
brings (response files in any format, column maps, manifests, exports) are
:mod:`sysid_core.formats`; a run's folder is :mod:`sysid_core.clock.runfolder`.

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
