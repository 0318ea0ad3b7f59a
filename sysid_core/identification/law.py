"""The test that keeps the quadratic stiffness law (``stiffness = "auto"``).

A Wald test of the quadratic terms ``L_p`` of a least-squares fit. On data with time stamps
(a bench with a clock) only the part of every ``L_p`` that splits the modes is tested
(:func:`split_part`): the five sweeps of a two-sided design are minutes apart, temperature
moves both modes between them, and the part that moves both modes together takes up that
drift.
"""

from __future__ import annotations

import numpy as np

from sysid_core.model.fitted import FittedModel

__all__ = ["LAW_TEST_LEVEL", "law_statistic", "split_part"]

#: Confidence level of the test that keeps the quadratic stiffness law (``stiffness = "auto"``).
LAW_TEST_LEVEL = 0.99


def split_part(mass: np.ndarray) -> np.ndarray:
    """The map from a stiffness term's entries ``(11, 12, 22)`` to its part that splits modes.

    With ``N = M^{-1/2} L M^{-1/2}`` the term as the modes see it, the rows are
    ``(N11 − N22) / 2`` and ``N12``: the traceless part of ``N``, which moves the two modal
    frequencies apart or turns their axes. The rest, ``tr N / 2``, moves both modes together,
    as temperature does.
    """
    lam, vec = np.linalg.eigh(np.asarray(mass, dtype=float))
    root = vec @ np.diag(1.0 / np.sqrt(lam)) @ vec.T
    rows = []
    for entry in ((1.0, 0.0, 0.0), (0.0, 1.0, 0.0), (0.0, 0.0, 1.0)):
        term = np.array([[entry[0], entry[1]], [entry[1], entry[2]]])
        n = root @ term @ root
        rows.append([(n[0, 0] - n[1, 1]) / 2.0, n[0, 1]])
    return np.array(rows).T


def law_statistic(model: FittedModel, split_only: bool = True) -> tuple[float, int] | None:
    """Wald statistic and degrees of freedom of a least-squares fit's quadratic terms ``L_p``.

    The statistic is ``d^T Cov(d)^+ d``, χ²-distributed when the law is linear. With
    ``split_only`` (data with time stamps), ``d`` is the part of every ``L_p`` that splits the
    modes (:func:`split_part`: two numbers per electrode): the common part, which moves both
    modes together, is left out, because a bench's temperature moves both modes between the
    sweeps of a design, and a test of all three entries took that drift for a quadratic law
    (the cloverleaf, whose law is ``v²``, at a good lab's drift: 15 of 24 starts). Without it
    (a frozen bench, where nothing moves between sweeps), ``d`` is every entry (11, 12, 22) of
    every ``L_p``, and the common part is evidence too (a quadratic law can show in the common
    part first: 9.3 for the split part alone, under the threshold of 13.3, measured). ``None``
    without ``L_p`` or without a covariance (minimax).
    """
    if model.Lp is None or model.stiffness_factor is None or not len(model.electrodes):
        return None
    n_e = len(model.electrodes)
    rows = model.stiffness_factor[-3 * n_e :]
    part = np.kron(np.eye(n_e), split_part(model.M)) if split_only else np.eye(3 * n_e)
    values = part @ np.concatenate([[lp[0, 0], lp[0, 1], lp[1, 1]] for lp in model.Lp])
    factor = part @ rows
    cov = factor @ factor.T
    lam, vec = np.linalg.eigh(cov)
    keep = lam > 1e-12 * max(float(lam.max()), 1e-300)
    proj = vec[:, keep].T @ values
    return float(np.sum(proj**2 / lam[keep])), int(keep.sum())
