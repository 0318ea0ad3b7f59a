"""A fitted model's file: the netCDF layout that :meth:`FittedModel.save` writes.

:func:`model_to_dataset` lays a model out as an :class:`xarray.Dataset`; :func:`model_fields`
reads the fields back (everything but the structure, which is rebuilt by name from the
registry: :func:`sysid_core.api.load_model`).
"""

from __future__ import annotations

import json
from collections.abc import Sequence
from typing import Any, Protocol

import numpy as np
import xarray as xr

from sysid_core.model.structures import ModelStructure

__all__ = ["DEFAULT_INPUTS", "DEFAULT_OUTPUTS", "channel_names", "model_fields", "model_to_dataset"]

#: Channel names of a model whose data set did not name its channels.
DEFAULT_OUTPUTS: tuple[str, str] = ("y1", "y2")
DEFAULT_INPUTS: tuple[str, str] = ("u1", "u2")


class SavedModel(Protocol):
    """What a model file holds (:class:`sysid_core.model.fitted.FittedModel` has it)."""

    structure: ModelStructure
    M: np.ndarray
    C: np.ndarray
    K0: np.ndarray
    Kp: np.ndarray
    poly: np.ndarray
    poly_w: np.ndarray
    omega_center: float
    omega_half: float
    electrodes: list[str]
    structure_potential: float
    gamma: float
    max_residual: float
    meta: dict[str, Any]
    outputs: list[str]
    inputs: list[str]
    stiffness_factor: np.ndarray | None
    Lp: np.ndarray | None


def model_to_dataset(model: SavedModel) -> xr.Dataset:
    """``model`` as an :class:`xarray.Dataset` (the layout of a model file)."""
    ds = xr.Dataset(
        {
            "M": (("row", "col"), model.M),
            "C": (("row", "col"), model.C),
            "K0": (("row", "col"), model.K0),
            "Kp": (("electrode", "row", "col"), model.Kp),
            "poly_real": (("degree", "row", "col"), model.poly.real),
            "poly_imag": (("degree", "row", "col"), model.poly.imag),
            "poly_w_real": (("bias_degree", "electrode", "row", "col"), model.poly_w.real),
            "poly_w_imag": (("bias_degree", "electrode", "row", "col"), model.poly_w.imag),
            **(
                {"stiffness_factor": (("parameter", "factor"), model.stiffness_factor)}
                if model.stiffness_factor is not None
                else {}
            ),
            **({"Lp": (("electrode", "row", "col"), model.Lp)} if model.Lp is not None else {}),
        },
        coords={
            "electrode": list(model.electrodes),
            "degree": np.arange(model.poly.shape[0]),
            "output": list(model.outputs),
            "input": list(model.inputs),
        },
        attrs={
            "structure": model.structure.name,
            "order": model.structure.order,
            "bias_terms": model.structure.bias_terms,
            "stiffness": getattr(model.structure, "stiffness", "linear"),
            "omega_center": model.omega_center,
            "omega_half": model.omega_half,
            "structure_potential": model.structure_potential,
            "gamma": model.gamma,
            "max_residual": model.max_residual,
            "meta": json.dumps(model.meta, default=_jsonable),
            "units": "M normalised (M >= I); C rad/s; K0 (rad/s)^2; Kp (rad/s)^2/V^2",
        },
    )
    return ds


def model_fields(ds: xr.Dataset) -> dict[str, Any]:
    """The keyword arguments of :class:`~sysid_core.model.fitted.FittedModel` from a model file.

    Every argument but ``structure``, from the file's data set ``ds``. Files written before
    channel names were saved get the default names ``y1, y2`` / ``u1, u2``.
    """
    return dict(
        M=ds["M"].values,
        C=ds["C"].values,
        K0=ds["K0"].values,
        Kp=ds["Kp"].values,
        poly=ds["poly_real"].values + 1j * ds["poly_imag"].values,
        poly_w=(
            ds["poly_w_real"].values + 1j * ds["poly_w_imag"].values
            if "poly_w_real" in ds
            else np.zeros((0, ds.sizes["electrode"], 2, 2), dtype=complex)
        ),
        omega_center=float(ds.attrs["omega_center"]),
        omega_half=float(ds.attrs["omega_half"]),
        electrodes=[str(e) for e in ds["electrode"].values],
        structure_potential=float(ds.attrs["structure_potential"]),
        gamma=float(ds.attrs["gamma"]),
        max_residual=float(ds.attrs["max_residual"]),
        meta=json.loads(str(ds.attrs["meta"])),
        outputs=channel_names(ds, "output", DEFAULT_OUTPUTS),
        inputs=channel_names(ds, "input", DEFAULT_INPUTS),
        stiffness_factor=ds["stiffness_factor"].values if "stiffness_factor" in ds else None,
        Lp=ds["Lp"].values if "Lp" in ds else None,
    )


def channel_names(ds: xr.Dataset, coord: str, default: Sequence[str]) -> list[str]:
    """The labels of coordinate ``coord`` of ``ds``, or ``default`` if it has none."""
    if coord in ds.coords:
        return [str(v) for v in ds.coords[coord].values]
    return list(default)


def _jsonable(obj: object) -> object:
    if isinstance(obj, np.ndarray):
        return obj.tolist()
    if isinstance(obj, np.generic):
        return obj.item()
    return str(obj)
