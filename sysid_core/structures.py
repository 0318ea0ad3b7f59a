"""The model-structure interface: where the extra dynamics sit relative to ``Z``.

The toolkit's fit engine treats every structure as the equation error

.. math:: E_{k,q} = P(\\omega_{k,q}) - \\mathcal{E}(\\psi_{k,q}, Z(j\\omega_{k,q}))

where :math:`P` is a complex polynomial of degree ``order`` in frequency and :math:`\\mathcal E`
is bilinear: :math:`\\psi Z` when extra dynamics sit at the output ("act", eq. 7 of Kim &
M'Closkey) or :math:`Z\\psi` when they sit at the input ("sen", eq. 10). A structure says which
(:attr:`ModelStructure.side`); the products follow from it.
"""

from __future__ import annotations

from typing import ClassVar, Literal

import numpy as np

from sysid_core.errors import ConfigError

__all__ = ["ModelStructure", "Side"]

Side = Literal["output", "input"]


class ModelStructure:
    """How the measured response relates to the second-order dynamics ``Z``.

    Subclasses set :attr:`name`, :attr:`side` and :attr:`description`; the equation-error
    product and the model response follow from :attr:`side`.

    Parameters
    ----------
    order : int
        Degree of the polynomial :math:`P` (the paper's :math:`n_R` or :math:`n_B`), 0 to
        :attr:`max_order`.
    """

    #: Name used in configuration files and on the command line.
    name: ClassVar[str]
    #: One line for ``sysid plugins``.
    description: ClassVar[str] = ""
    #: Largest supported polynomial order.
    max_order: ClassVar[int] = 6
    #: Where the extra dynamics sit: ``"output"`` (E = P - psi Z, response P Z^-1) or
    #: ``"input"`` (E = P - Z psi, response Z^-1 P).
    side: ClassVar[Side]

    def __init__(self, order: int = 1) -> None:
        if isinstance(order, bool) or not isinstance(order, (int, np.integer)):
            raise ConfigError(f"model order must be an integer, got {order!r}")
        if not 0 <= int(order) <= self.max_order:
            raise ConfigError(
                f"model order {order} is out of range for {self.name!r}: use 0 to {self.max_order}"
            )
        self.order = int(order)

    def product(self, psi: np.ndarray, z: np.ndarray) -> np.ndarray:
        """The bilinear term of the equation error: ``psi @ z`` (output) or ``z @ psi`` (input).

        Both arguments have shape ``(..., 2, 2)`` and broadcast.
        """
        return psi @ z if self.side == "output" else z @ psi

    def response(self, p: np.ndarray, z: np.ndarray) -> np.ndarray:
        """The model's frequency response from ``P`` and ``Z``: ``P Z^-1`` or ``Z^-1 P``."""
        if self.side == "output":  # P Z^-1 = (Z^-T P^T)^T
            zt, pt = np.swapaxes(z, -1, -2), np.swapaxes(p, -1, -2)
            return np.swapaxes(np.linalg.solve(zt, pt), -1, -2)
        return np.linalg.solve(z, p)

    def __repr__(self) -> str:
        return f"{type(self).__name__}(order={self.order})"
