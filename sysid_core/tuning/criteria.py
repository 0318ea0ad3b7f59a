"""Tuning in the squared potentials ``w_p = v_p**2``, where every criterion is convex.

The stiffness ``K(w) = K0 + sum_p K_p w_p`` is affine in ``w``; the modal frequencies are the
generalized eigenvalues of ``(K(w), M)``. A :class:`TuningCriterion` solves a small
semidefinite program in ``w`` over the reachable box (from the device's bias limits,
:class:`BiasSpace`; the programs are in :mod:`sysid_core.tuning.spread`), then maps ``w`` back to
biases ``dv_p = v_gyro -/+ sqrt(w_p)`` inside the limits. A bias outside the limits is never
returned. A run counts as converged when the criterion's :class:`Goal` s are met on a verified
measurement.
"""

from __future__ import annotations

from abc import ABC, abstractmethod
from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Any, ClassVar

import numpy as np

from sysid_core.data.schema import squared_potentials
from sysid_core.errors import BiasLimitError, ConfigError
from sysid_core.model.fitted import FittedModel
from sysid_core.model.modal import degenerate_bias, degenerate_w, modal_frequencies_hz

__all__ = [
    "BiasSpace",
    "ConfidenceRegion",
    "Goal",
    "TuningCriterion",
    "TuningResult",
    "bias_from_w",
    "degenerate_bias",
    "degenerate_w",
    "frequencies_from_w",
    "w_interval",
]


def w_interval(v_gyro: float, low: float, high: float) -> tuple[float, float]:
    """Reachable ``w = (v_gyro - dv)**2`` for ``dv`` in ``[low, high]``."""
    if low > high:
        raise BiasLimitError(f"empty bias interval [{low}, {high}]")
    v_lo, v_hi = v_gyro - high, v_gyro - low
    w_max = max(v_lo**2, v_hi**2)
    w_min = 0.0 if v_lo <= 0.0 <= v_hi else min(v_lo**2, v_hi**2)
    return w_min, w_max


def bias_from_w(w: float, v_gyro: float, low: float, high: float, tol: float = 1e-9) -> float:
    """The bias ``dv = v_gyro -/+ sqrt(w)`` inside ``[low, high]`` (the smaller ``|dv|`` if both).

    Raises
    ------
    BiasLimitError
        If neither root is inside the limits.
    """
    root = float(np.sqrt(max(w, 0.0)))
    inside = [
        float(np.clip(dv, low, high))
        for dv in (v_gyro - root, v_gyro + root)
        if low - tol <= dv <= high + tol
    ]
    if not inside:
        raise BiasLimitError(
            f"w = {w:.6g} V^2 needs a bias of {v_gyro - root:.4f} or {v_gyro + root:.4f} V, "
            f"outside the limits [{low}, {high}] V"
        )
    return min(inside, key=abs)


def frequencies_from_w(model: FittedModel, w: np.ndarray) -> np.ndarray:
    """Undamped modal frequencies (Hz) of ``model`` at squared potentials ``w``."""
    return modal_frequencies_hz(model.stiffness_w(w), model.M)


@dataclass(frozen=True)
class BiasSpace:
    """Where a criterion may move the biases.

    Attributes
    ----------
    electrodes : list of str
        All of the device's bias electrodes.
    tuned : list of str
        The electrodes being tuned, in the order of the model's electrodes.
    start_bias : ndarray
        Bias of every electrode (volts); electrodes not tuned stay at these values.
    limits : tuple of float
        Allowed bias ``(low, high)`` in volts.
    structure_potential : float
        ``v_gyro`` in volts.
    """

    electrodes: list[str]
    tuned: list[str]
    start_bias: np.ndarray
    limits: tuple[float, float]
    structure_potential: float

    def __post_init__(self) -> None:
        """Check that the tuned electrodes exist and ``start_bias`` has one value per electrode."""
        unknown = [e for e in self.tuned if e not in self.electrodes]
        if unknown:
            raise ConfigError(
                f"cannot tune electrode(s) {unknown}: the device has {self.electrodes}"
            )
        if len(self.start_bias) != len(self.electrodes):
            raise ConfigError(
                f"start_bias has {len(self.start_bias)} values; the device has "
                f"{len(self.electrodes)} electrodes ({', '.join(self.electrodes)})"
            )

    @property
    def index(self) -> list[int]:
        """Positions of the tuned electrodes among all electrodes."""
        return [self.electrodes.index(e) for e in self.tuned]

    def box(self, max_abs_bias: float | None = None) -> np.ndarray:
        """Reachable ``w`` per tuned electrode, ``(n_t, 2)``; optionally with ``|dv| <= T``."""
        low, high = self.limits
        if max_abs_bias is not None:
            low, high = max(low, -max_abs_bias), min(high, max_abs_bias)
        return np.array([w_interval(self.structure_potential, low, high) for _ in self.tuned])

    def full_bias(self, tuned_bias: Sequence[float]) -> np.ndarray:
        """All electrodes' biases: the tuned ones set, the others at their start value."""
        out = np.array(self.start_bias, dtype=float)
        out[self.index] = tuned_bias
        return out

    def to_bias(self, w: np.ndarray, max_abs_bias: float | None = None) -> np.ndarray:
        """Full bias vector for squared potentials ``w`` of the tuned electrodes."""
        low, high = self.limits
        if max_abs_bias is not None:
            low, high = max(low, -max_abs_bias), min(high, max_abs_bias)
        tuned = [bias_from_w(wp, self.structure_potential, low, high) for wp in w]
        return self.full_bias(tuned)


@dataclass(frozen=True)
class ConfidenceRegion:
    """A tuning answer's confidence region (the method: :mod:`sysid_core.tuning.confidence`).

    Attributes
    ----------
    level : float
        Confidence level (0.95).
    bias_ci : ndarray, shape (n_electrodes, 2)
        Per electrode ``[low, high]`` volts, every electrode of the device (an electrode that
        is not tuned has ``low = high`` = its bias); together a box of probability ``level``.
    split_ci_hz : (float, float)
        Range of the split at the answer's bias (Hz).
    frequency_ci_hz : (float, float)
        Interval of the mean modal frequency at the answer's bias (Hz).
    samples : int
        Number of models drawn.
    """

    level: float
    bias_ci: np.ndarray
    split_ci_hz: tuple[float, float]
    frequency_ci_hz: tuple[float, float]
    samples: int

    def as_dict(self) -> dict[str, Any]:
        """JSON-friendly form (the keys of ``tuning.json`` and the ``--json`` line)."""
        return {
            "confidence_level": self.level,
            "bias_ci": [[float(lo), float(hi)] for lo, hi in self.bias_ci],
            "split_ci_hz": [float(v) for v in self.split_ci_hz],
            "frequency_ci_hz": [float(v) for v in self.frequency_ci_hz],
        }

    def describe(self, tuned: list[int] | None = None) -> str:
        """One line: ``±`` half-widths of the tuned electrodes' biases and the split's range."""
        rows = range(len(self.bias_ci)) if tuned is None else tuned
        half = ", ".join(f"±{0.5 * (self.bias_ci[p][1] - self.bias_ci[p][0]):.4f}" for p in rows)
        lo, hi = self.split_ci_hz
        return f"{self.level:.0%} region: bias [{half}] V, split {lo * 1e3:.3g}-{hi * 1e3:.3g} mHz"


@dataclass
class TuningResult:
    """A criterion's answer.

    Attributes
    ----------
    bias : ndarray
        Bias of every electrode (volts), inside the limits.
    w : ndarray
        Squared potentials of the tuned electrodes.
    frequencies_hz : ndarray
        The model's modal frequencies at ``bias``.
    split_hz : float
        The model's predicted split at ``bias``.
    criterion : str
        Name of the criterion.
    value : float
        The criterion's optimal value in Hz (split, or frequency error for ``target``).
    info : dict
        Anything else (target, max |dv|, ...).
    confidence : ConfidenceRegion or None
        How sure the answer is (set by the run from the model's covariance; ``None`` when
        the fit states none).
    """

    bias: np.ndarray
    w: np.ndarray
    frequencies_hz: np.ndarray
    split_hz: float
    criterion: str
    value: float
    info: dict[str, Any] = field(default_factory=dict)
    confidence: ConfidenceRegion | None = None

    @property
    def frequency_hz(self) -> float:
        """Mean predicted modal frequency."""
        return float(np.mean(self.frequencies_hz))

    def as_dict(self) -> dict[str, Any]:
        """JSON-friendly form."""
        return {
            "criterion": self.criterion,
            "bias": [float(b) for b in self.bias],
            "predicted_frequencies_hz": [float(f) for f in self.frequencies_hz],
            "predicted_split_hz": self.split_hz,
            "value_hz": self.value,
            **{k: v for k, v in self.info.items() if isinstance(v, (int, float, str, list, dict))},
            **(self.confidence.as_dict() if self.confidence is not None else {}),
        }


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
        """The goal as a line: name, measured value, ``<=`` or ``>``, limit (mHz)."""
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


#: Most linearizations of a quadratic-law model before :func:`solve_criterion` gives up.
MAX_LINEARIZATIONS = 50
#: The answer has settled when no bias moves more than this between linearizations (volts).
SETTLED_V = 1e-7
#: ... or when the moves stop shrinking below this (a criterion's own resolution; volts).
STALLED_V = 1e-3


def solve_criterion(
    criterion: TuningCriterion, model: FittedModel, space: BiasSpace
) -> tuple[TuningResult, FittedModel]:
    """``criterion``'s answer for ``model``, and the linear model it was computed from.

    Criteria work with a stiffness linear in ``w``. A model of the quadratic law
    (``model.Lp``) is linearized at the start bias, solved, linearized again at the answer and
    solved again, until no bias moves more than :data:`SETTLED_V` (or the moves stop
    shrinking below :data:`STALLED_V`, the resolution of a bisecting criterion; the quadratic
    terms are small corrections, so a few rounds suffice): the answer then holds for
    the quadratic model itself, whose tangent at the answer is the linear model returned (for
    the confidence region). A linear model is solved once and returned as it is.

    From the fifth round each new point is damped (halfway, from the 21st a fifth of the way):
    the answer of ``min-max-bias`` can jump between distant points of the degenerate set. If
    the rounds still do not settle within :data:`MAX_LINEARIZATIONS` (4 of 100 random gyros'
    min-max runs before the damping), the answer of the tangent at the identification bias is
    used; ``result.info["linearizations"]`` says so (else it holds the number of rounds).

    Raises
    ------
    UnreachableTuningError
        As the criterion does, for the model linearized where it stopped.
    """
    if model.Lp is None:
        return criterion.solve(model, space), model
    w0 = squared_potentials(space.structure_potential, space.start_bias[space.index])
    bias0 = np.asarray(space.start_bias, dtype=float)
    first: tuple[TuningResult, FittedModel] | None = None
    moved, before = float("inf"), float("inf")
    for round_ in range(MAX_LINEARIZATIONS):
        local = model.linearized(w0)
        result = criterion.solve(local, space)
        first = first or (result, local)
        moved = float(np.max(np.abs(np.asarray(result.bias) - bias0)))
        # settled, or stalled at the criterion's own resolution (min-max bisects to 1e-4 V)
        if moved <= SETTLED_V or (round_ >= 3 and moved <= STALLED_V and moved > 0.5 * before):
            result.info["linearizations"] = round_ + 1
            return result, local
        before = moved
        # damped from the fifth round: a criterion whose answer jumps (min-max-bias moves
        # along the degenerate set) would otherwise go back and forth
        step = 1.0 if round_ < 4 else 0.5 if round_ < 20 else 0.2
        w0 = w0 + step * (np.asarray(result.w, dtype=float) - w0)
        bias0 = np.asarray(result.bias, dtype=float)
    assert first is not None
    result, local = first
    result.info["linearizations"] = (
        f"did not settle in {MAX_LINEARIZATIONS} rounds (the bias still moved by {moved:.3g} V): "
        "the answer of the tangent at the identification bias is used"
    )
    return result, local
