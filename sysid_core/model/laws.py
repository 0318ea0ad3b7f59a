"""Stiffness laws in the squared potentials: the tangent of a quadratic law.

A ``quadratic`` model's stiffness ``K0 + Σ K_p w_p + Σ L_p w_p²`` is replaced by its tangent at
``w0`` for the tuning criteria, which work with a stiffness linear in ``w``.
"""

from __future__ import annotations

import dataclasses
from typing import Any, Protocol, TypeVar

import numpy as np

__all__ = ["linearize"]


class _Quadratic(Protocol):
    electrodes: list[str]
    K0: np.ndarray
    Kp: np.ndarray
    Lp: np.ndarray | None
    stiffness_factor: np.ndarray | None
    meta: dict[str, Any]


_M = TypeVar("_M", bound=_Quadratic)


def linearize(self: _M, w0: np.ndarray) -> _M:
    """The model (a dataclass) with its stiffness replaced by its tangent at ``w0``.

    ``K0 − Σ L_p w0_p²`` and ``K_p + 2 L_p w0_p``; the covariance factor is mapped by the same
    linear map. A model without ``L_p`` is returned as it is.
    """
    if self.Lp is None:
        return self
    w0 = np.asarray(w0, dtype=float).reshape(-1)
    n_e = len(self.electrodes)
    factor = None
    if self.stiffness_factor is not None:
        t = np.zeros((6 + 3 * n_e, 6 + 6 * n_e))
        t[: 6 + 3 * n_e, : 6 + 3 * n_e] = np.eye(6 + 3 * n_e)
        for p in range(n_e):
            lp = slice(6 + 3 * n_e + 3 * p, 9 + 3 * n_e + 3 * p)
            t[3:6, lp] = -(w0[p] ** 2) * np.eye(3)
            t[6 + 3 * p : 9 + 3 * p, lp] = 2.0 * w0[p] * np.eye(3)
        factor = t @ self.stiffness_factor
    return dataclasses.replace(  # type: ignore[type-var]
        self,
        K0=self.K0 - np.tensordot(w0**2, self.Lp, axes=1),
        Kp=self.Kp + 2.0 * w0[:, None, None] * self.Lp,
        Lp=None,
        stiffness_factor=factor,
        meta={**self.meta, "linearized_at_w": w0.tolist()},
    )
