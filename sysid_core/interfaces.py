"""The five interfaces of sysid-toolkit: ModelStructure, Objective, Solver, Device, TuningCriterion.

Data flows one way::

    Device -> Dataset (xarray) -> ModelStructure + Objective -> ConicProgram -> Solver
           -> FittedModel -> TuningCriterion -> bias -> Device

Each arrow is one interface. Plugins provide implementations through the hooks of
:mod:`sysid_core.hookspec`.
"""

from __future__ import annotations

from abc import ABC, abstractmethod
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any, ClassVar, Protocol, runtime_checkable

import numpy as np

from sysid_core.errors import ConfigError

if TYPE_CHECKING:
    import xarray as xr

    from sysid_core.conic import ConicProgram, ConicSolution
    from sysid_core.model import FittedModel
    from sysid_core.problem import FitProblem, ObjectiveResult
    from sysid_core.tuning import BiasSpace, TuningResult

__all__ = [
    "Device",
    "Goal",
    "ModelStructure",
    "Objective",
    "ProgressCallback",
    "Solver",
    "TuningCriterion",
    "check_options",
    "typed_option",
]

#: Receives one-line progress messages from long computations.
ProgressCallback = Callable[[str], None]


def check_options(kind: str, name: str, given: dict[str, Any], allowed: Sequence[str]) -> None:
    """Raise :class:`ConfigError` naming the first option in ``given`` not in ``allowed``."""
    for key in given:
        if key not in allowed:
            known = ", ".join(sorted(allowed)) or "none"
            raise ConfigError(f"unknown option {key!r} for {kind} {name!r}; known options: {known}")


def typed_option(
    kind: str,
    name: str,
    key: str,
    value: Any,
    expected: type,
    *,
    minimum: float | None = None,
    positive: bool = False,
) -> Any:
    """``value`` of option ``key`` checked against ``expected`` (bool, int or float) and bounds.

    Raises
    ------
    ConfigError
        Naming the component, the option, the value given and what it must be.
    """
    number = isinstance(value, (int, float, np.integer, np.floating)) and not isinstance(
        value, bool
    )
    if expected is bool:
        ok, what = isinstance(value, bool), "true or false"
    elif expected is int:
        ok, what = number and float(value).is_integer(), "an integer"
    else:
        ok, what = number and bool(np.isfinite(value)), "a finite number"
    if ok and positive and not value > 0:
        ok, what = False, f"{what} > 0 (positive)"
    elif ok and minimum is not None and not value >= minimum:
        ok, what = False, f"{what} >= {minimum:g}"
    if not ok:
        raise ConfigError(f"option {key!r} of {kind} {name!r} must be {what}, got {value!r}")
    return expected(value)


class ModelStructure(ABC):
    """How the measured response relates to the second-order dynamics ``Z``.

    The toolkit's fit engine treats every structure as the equation error

    .. math:: E_{k,q} = P(\\omega_{k,q}) - \\mathcal{E}(\\psi_{k,q}, Z(j\\omega_{k,q}))

    where :math:`P` is a complex polynomial of degree ``order`` in frequency and
    :math:`\\mathcal E` is bilinear: :math:`\\psi Z` when extra dynamics sit at the output
    ("act", eq. 7 of Kim & M'Closkey) or :math:`Z\\psi` when they sit at the input ("sen",
    eq. 10). A structure implements only these two products; everything else is shared.

    Parameters
    ----------
    order : int
        Degree of the polynomial :math:`P` (the paper's :math:`n_R` or :math:`n_B`), 0 to 6.
    """

    #: Name used in configuration files and on the command line.
    name: ClassVar[str]
    #: One line for ``sysid plugins``.
    description: ClassVar[str] = ""
    #: Largest supported polynomial order.
    max_order: ClassVar[int] = 6
    #: Where the extra dynamics sit: ``"output"`` (E = P - psi Z) or ``"input"`` (E = P - Z psi).
    side: ClassVar[str]

    def __init__(self, order: int = 1) -> None:
        if isinstance(order, bool) or not isinstance(order, (int, np.integer)):
            raise ConfigError(f"model order must be an integer, got {order!r}")
        if not 0 <= int(order) <= self.max_order:
            raise ConfigError(
                f"model order {order} is out of range for {self.name!r}: use 0 to {self.max_order}"
            )
        self.order = int(order)

    @abstractmethod
    def product(self, psi: np.ndarray, z: np.ndarray) -> np.ndarray:
        """The bilinear term of the equation error: ``psi @ z`` or ``z @ psi``.

        Both arguments have shape ``(..., 2, 2)`` and broadcast.
        """

    @abstractmethod
    def response(self, p: np.ndarray, z: np.ndarray) -> np.ndarray:
        """The model's frequency response from ``P`` and ``Z``: ``P Z^-1`` or ``Z^-1 P``."""

    def __repr__(self) -> str:
        return f"{type(self).__name__}(order={self.order})"


class Solver(ABC):
    """A conic-solver backend: solves a :class:`~sysid_core.conic.ConicProgram`.

    A backend maps its solver's status words to the toolkit's: anything but an accurate optimum
    raises :class:`~sysid_core.errors.SolverError` naming the status, never a silently bad answer.
    Unknown options raise :class:`~sysid_core.errors.ConfigError` naming the option.
    """

    name: ClassVar[str]
    description: ClassVar[str] = ""

    @abstractmethod
    def solve(self, program: ConicProgram) -> ConicSolution:
        """Solve ``program`` and return its solution, or raise ``SolverError``."""


class Objective(ABC):
    """A fit criterion over the equation errors of all data points.

    The objective assembles conic programs from a :class:`~sysid_core.problem.FitProblem`
    and solves them with the given solver, as many times as its method needs.
    """

    name: ClassVar[str]
    description: ClassVar[str] = ""

    @abstractmethod
    def fit(
        self,
        problem: FitProblem,
        solver: Solver,
        progress: ProgressCallback | None = None,
    ) -> ObjectiveResult:
        """Return the scaled parameter vector that optimises this objective on ``problem``."""


@dataclass(frozen=True)
class Goal:
    """One goal of a tuning criterion, checked on a verified measurement.

    Attributes
    ----------
    name : str
        What is measured (``"split"``, ``"frequency error"``).
    value_hz : float
        Its measured value (Hz).
    limit_hz : float
        The largest value that meets the goal (Hz).
    """

    name: str
    value_hz: float
    limit_hz: float

    @property
    def met(self) -> bool:
        """The measured value is within the limit."""
        return bool(self.value_hz <= self.limit_hz)

    def as_dict(self) -> dict[str, Any]:
        """JSON-friendly form."""
        return {
            "name": self.name,
            "value_hz": float(self.value_hz),
            "limit_hz": float(self.limit_hz),
            "met": self.met,
        }

    def __str__(self) -> str:
        sign = "<=" if self.met else ">"
        return f"{self.name} {self.value_hz * 1e3:.3g} mHz {sign} {self.limit_hz * 1e3:.3g} mHz"


class TuningCriterion(ABC):
    """Computes the bias potentials that tune a fitted model.

    All criteria work in the squared potentials ``w_p = v_p**2`` where they are convex, and map
    back to bias potentials ``dv_p`` inside the device's limits.
    """

    name: ClassVar[str]
    description: ClassVar[str] = ""

    def goals(self, measured_hz: np.ndarray, acceptance_hz: float) -> list[Goal]:
        """The criterion's goals on the modal frequencies measured by a verification.

        A run counts as converged only when every goal is met. The default is the split:
        ``f2 - f1 <= acceptance_hz``. A criterion with more goals (a target frequency) adds them.
        """
        f = np.sort(np.asarray(measured_hz, dtype=float))
        return [Goal("split", float(f[1] - f[0]), float(acceptance_hz))]

    @abstractmethod
    def solve(self, model: FittedModel, space: BiasSpace) -> TuningResult:
        """Return the tuning biases for ``model`` within ``space``.

        Raises
        ------
        UnreachableTuningError
            When the goal cannot be met inside the limits; carries the best reachable bias.
        """


@runtime_checkable
class Device(Protocol):
    """What the toolkit needs of a gyro, simulated or real (duck-typed).

    Attributes
    ----------
    electrodes : Sequence[str]
        Names of the bias electrodes (``n_e`` of them).
    bias_limits : tuple of float
        Allowed bias ``dv`` in volts, ``(low, high)``, for every electrode.
    structure_potential : float
        ``v_gyro`` in volts; the electrode potential seen by the structure is ``v_gyro - dv``.
    band_hz : tuple of float
        The frequency band, in Hz, where the two modes are.
    """

    electrodes: Sequence[str]
    bias_limits: tuple[float, float]
    structure_potential: float
    band_hz: tuple[float, float]

    def measure(self, bias: Sequence[float], frequencies_hz: np.ndarray) -> xr.DataArray:
        """Apply ``bias`` (volts, one per electrode) and measure the frequency response.

        Returns a complex ``DataArray`` with dims ``("frequency", "output", "input")``. The core
        checks ``bias`` against ``bias_limits`` before calling.
        """
        ...
