"""The paper's two model structures.

Both share the second-order dynamics ``Z(s) = M s^2 + C s + K0 + sum_p K_p v_p^2`` and a complex
polynomial ``P`` of degree ``order`` that absorbs signal-conditioning dynamics and
sensor-actuator non-collocation; they differ only in which side ``P`` sits on.
"""

from __future__ import annotations

from sysid_core.model.structures import ModelStructure

__all__ = ["ActStructure", "SenStructure"]


class ActStructure(ModelStructure):
    """``act``: extra dynamics reflected to the output, ``psi = R~ Z_act^-1`` (eq. 2, fit by 8).

    Equation error ``E = R~ - psi Z``.
    """

    name = "act"
    side = "output"
    description = "output dynamics reflected: psi = R~ Z^-1, error R~ - psi Z (eqs. 2-3, 8)"


class SenStructure(ModelStructure):
    """``sen``: extra dynamics reflected to the input, ``psi = Z_sen^-1 B~`` (eq. 4, fit by 10).

    Equation error ``E = B~ - Z psi``.
    """

    name = "sen"
    side = "input"
    description = "input dynamics reflected: psi = Z^-1 B~, error B~ - Z psi (eqs. 4-5, 10)"
