r"""The model-structure interface: where the extra dynamics sit relative to ``Z``.

The toolkit's fit engine treats every structure as the equation error

.. math:: E_{k,q} = P(\omega_{k,q}) - \mathcal{E}(\psi_{k,q}, Z(j\omega_{k,q}))

where :math:`P` is a complex polynomial of degree ``order`` in frequency and :math:`\mathcal E`
is bilinear: :math:`\psi Z` when extra dynamics sit at the output ("act", eq. 7 of Kim &
M'Closkey) or :math:`Z\psi` when they sit at the input ("sen", eq. 10). A structure says which
(:attr:`ModelStructure.side`); the products follow from it.
"""

from __future__ import annotations

from typing import ClassVar, Literal

import numpy as np

from sysid_core.errors import ConfigError

__all__ = [
    "DEFAULT_BIAS_TERMS",
    "DEFAULT_ORDER",
    "DEFAULT_STIFFNESS",
    "ModelStructure",
    "Side",
]

#: The toolkit's default model, used by the structures, :func:`sysid_core.api.fit`, ``sysid
#: fit`` and the configuration's ``[model]`` table alike: output dynamics, a polynomial of
#: order 2 whose constant term depends on the bias (measured on the cloverleaf, 49 starts:
#: first iteration median true split 9.9 mHz against 333 mHz for the paper's order-1,
#: bias-independent polynomial with minimax).
DEFAULT_ORDER = 2
DEFAULT_BIAS_TERMS = 1
#: The stiffness law in w: "linear" is the paper's; "auto" fits the quadratic law from
#: two-sided experiments and keeps it where a test shows its terms (100 random gyros: 94/100
#: under 2 mHz after two iterations, 44/100 with the linear law; the cloverleaf's v² law stays
#: linear: first-iteration median 6.0 mHz, 10.2 with the one-sided linear design). A design
#: that cannot show the quadratic terms (one-sided) gets the linear law.
DEFAULT_STIFFNESS = "auto"

Side = Literal["output", "input"]


class ModelStructure:
    r"""How the measured response relates to the second-order dynamics ``Z``.

    Subclasses set :attr:`name`, :attr:`side` and :attr:`description`; the equation-error
    product and the model response follow from :attr:`side`.

    Parameters
    ----------
    order : int
        Degree of the polynomial :math:`P` (the paper's :math:`n_R` or :math:`n_B`), 0 to
        :attr:`max_order` (default :data:`DEFAULT_ORDER`).
    bias_terms : int
        How many of the polynomial's lowest degrees also depend on the squared potentials:
        :math:`P(\nu, w) = \sum_l \nu^l (P_l + \sum_p P_{l,p} w_p)` for ``l < bias_terms``
        (default :data:`DEFAULT_BIAS_TERMS`; 0 is the paper's bias-independent :math:`P`). A
        capacitive feedthrough
        :math:`F(s)` in the data makes :math:`\psi Z = \tilde R + F Z`, and :math:`F Z` holds
        :math:`F K_p w_p`: terms that the bias-independent polynomial cannot absorb and that
        then bias the fitted :math:`K_p`. The relaxation keeps the fit linear in the unknowns.
    stiffness : {"linear", "quadratic", "auto"}
        The stiffness law in the squared potentials (default :data:`DEFAULT_STIFFNESS`):
        ``"linear"`` (the paper's
        :math:`K_0 + \sum_p K_p w_p`) or ``"quadratic"``, which adds :math:`\sum_p L_p w_p^2`
        (a real electrode's gap shrinks with its bias, so its stiffness is not exactly
        proportional to :math:`v^2`). Still linear in the unknowns; it needs each electrode at
        two biases besides the centre (a two-sided design). ``"auto"``: the fit decides (the
        quadratic law if the data show its terms, see :func:`sysid_core.api.fit`).
    """

    #: Name used in configuration files and on the command line.
    name: ClassVar[str]
    #: One line for ``sysid plugins``.
    description: ClassVar[str] = ""
    #: Largest supported polynomial order.
    max_order: ClassVar[int] = 6
    #: Lowest polynomial degrees that depend on the squared potentials (see ``bias_terms``).
    bias_terms: int = DEFAULT_BIAS_TERMS
    #: The stiffness law in ``w``: ``"linear"``, ``"quadratic"`` or ``"auto"``.
    stiffness: str = DEFAULT_STIFFNESS
    #: The stiffness laws a structure can take.
    STIFFNESS_LAWS: ClassVar[tuple[str, ...]] = ("linear", "quadratic", "auto")
    #: Where the extra dynamics sit: ``"output"`` (E = P - psi Z, response P Z^-1) or
    #: ``"input"`` (E = P - Z psi, response Z^-1 P).
    side: ClassVar[Side]

    def __init__(
        self,
        order: int = DEFAULT_ORDER,
        bias_terms: int = DEFAULT_BIAS_TERMS,
        stiffness: str = DEFAULT_STIFFNESS,
    ) -> None:
        if isinstance(order, bool) or not isinstance(order, (int, np.integer)):
            raise ConfigError(f"model order must be an integer, got {order!r}")
        if not 0 <= int(order) <= self.max_order:
            raise ConfigError(
                f"model order {order} is out of range for {self.name!r}: use 0 to {self.max_order}"
            )
        self.order = int(order)
        if isinstance(bias_terms, bool) or not isinstance(bias_terms, (int, np.integer)):
            raise ConfigError(f"bias_terms must be an integer, got {bias_terms!r}")
        if not 0 <= int(bias_terms) <= self.order + 1:
            raise ConfigError(
                f"bias_terms = {bias_terms} for a polynomial of order {self.order}: use 0 to "
                f"{self.order + 1}"
            )
        self.bias_terms = int(bias_terms)
        if stiffness not in self.STIFFNESS_LAWS:
            raise ConfigError(
                f"[model] stiffness = {stiffness!r}: use one of {', '.join(self.STIFFNESS_LAWS)}"
            )
        self.stiffness = str(stiffness)

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
        """The class name with ``order``, ``bias_terms`` and ``stiffness``."""
        return (
            f"{type(self).__name__}(order={self.order}, bias_terms={self.bias_terms}, "
            f"stiffness={self.stiffness!r})"
        )
