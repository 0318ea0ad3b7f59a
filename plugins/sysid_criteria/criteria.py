"""The three tuning criteria of the paper, convex in the squared potentials ``w``."""

from __future__ import annotations

from typing import Annotated, Any

import numpy as np
from annotated_types import Gt

from sysid_core.conic.program import Solver
from sysid_core.data.schema import squared_potentials
from sysid_core.errors import ConfigError, SolverError, UnreachableTuningError
from sysid_core.model.fitted import FittedModel
from sysid_core.tuning.criteria import (
    BiasSpace,
    Goal,
    TuningCriterion,
    TuningResult,
    frequencies_from_w,
)
from sysid_core.tuning.spread import solve_spread

__all__ = ["Degenerate", "MinMaxBias", "Target"]

Positive = Annotated[float, Gt(0)]


def _fmt(bias: np.ndarray) -> str:
    return "[" + ", ".join(f"{b:.4f}" for b in bias) + "] V"


def _start_w(space: BiasSpace) -> np.ndarray:
    """The squared potentials of the tuned electrodes at ``space``'s start bias.

    With more tuned electrodes than the goals need, the optimal biases form a set, and the
    criteria return its point nearest these (:func:`~sysid_core.tuning.spread.solve_spread`):
    from 0 V the smallest biases; in a tuning run, the least change from the bias it is at,
    where its model's law was measured (an answer that moves along the set from one iteration
    to the next carries the law's error along it: random gyros that tuned six electrodes took
    292-389 dwells with the smallest biases and 125-228 with the least change,
    ``docs/studies/trust-region.md``).
    """
    return squared_potentials(space.structure_potential, np.asarray(space.start_bias)[space.index])


class _Base(TuningCriterion):
    """Shared by the three: the conic ``solver`` (the run's, with its options) and a tolerance.

    Options are checked by the registry against these annotations (see
    :mod:`sysid_core.plugin.options`) before anything is built.
    """

    def __init__(self, *, solver: Solver, tolerance_hz: Positive = 1e-3) -> None:
        if not isinstance(solver, Solver):
            raise ConfigError(
                f"criterion {self.name!r} needs a conic solver (a sysid_core.conic.Solver), "
                f"got {solver!r}"
            )
        if not (isinstance(tolerance_hz, (int, float)) and tolerance_hz > 0):
            raise ConfigError(f"tolerance_hz must be a positive number of Hz, got {tolerance_hz!r}")
        self.tolerance_hz = float(tolerance_hz)
        self.solver = solver

    def _result(
        self, model: FittedModel, space: BiasSpace, w: np.ndarray, value: float, **info: Any
    ) -> TuningResult:
        f = frequencies_from_w(model, w)
        return TuningResult(
            bias=space.to_bias(w, info.pop("max_abs_bias", None)),
            w=w,
            frequencies_hz=f,
            split_hz=float(f[1] - f[0]),
            criterion=self.name,
            value=value,
            info=info,
        )


class Degenerate(_Base):
    """Equal modal frequencies (eq. 14, as eigenvalue-spread minimisation).

    ``min t`` s.t. ``lam M ⪯ K(w) ⪯ (lam + t) M`` over the reachable box of ``w``. With more
    electrodes than needed, among the degenerate points (within 1e-5 Hz of the least spread) the
    one closest to the start bias (:func:`_start_w`) is returned: from 0 V, the smallest biases.

    Parameters
    ----------
    tolerance_hz : float
        Largest predicted split that counts as degenerate (default 1 mHz); above it the goal is
        unreachable inside the limits.
    solver : Solver
        Conic solver backend (the run's, with the ``[solver]`` options).
    """

    name = "degenerate"
    description = "equal modal frequencies, eq. (14) as spread minimisation"

    def solve(self, model: FittedModel, space: BiasSpace) -> TuningResult:
        box = space.box()
        anchor = _start_w(space)
        w, _ = solve_spread(model, box, self.solver, anchor_w=anchor)
        res = self._result(model, space, w, 0.0)
        res.value = res.split_hz
        if res.split_hz > self.tolerance_hz:
            raise UnreachableTuningError(
                f"the modes cannot be made degenerate inside the bias limits {space.limits} V "
                f"with electrodes {', '.join(space.tuned)}: the best reachable split is "
                f"{res.split_hz * 1e3:.1f} mHz at {_fmt(res.bias)}",
                best_bias=res.bias.tolist(),
                best_value=res.split_hz,
            )
        return res


class Target(_Base):
    """Both modes at a target frequency (eq. 23, bounding the frequency error directly).

    ``min t`` s.t. ``(w0^2 - t) M ⪯ K(w) ⪯ (w0^2 + t) M``: the modal frequencies lie within
    ``sqrt(w0^2 ± t)``. The frequency error reported is ``max_i |f_i - target_hz|``. With more
    electrodes than needed, the optimal point closest to the start bias (:func:`_start_w`).

    Parameters
    ----------
    target_hz : float
        Target modal frequency (Hz); required.
    tolerance_hz : float
        Largest frequency error that counts as reached (default 10 mHz).
    solver : Solver
        Conic solver backend (the run's, with the ``[solver]`` options).
    """

    name = "target"
    description = "both modes at target_hz, eq. (23)"

    def __init__(
        self,
        *,
        solver: Solver,
        target_hz: Positive | None = None,
        tolerance_hz: Positive = 1e-2,
    ) -> None:
        super().__init__(solver=solver, tolerance_hz=tolerance_hz)
        if target_hz is None:
            raise ConfigError("criterion 'target' needs target_hz (in [tuning])")
        if not (isinstance(target_hz, (int, float)) and target_hz > 0):
            raise ConfigError(f"target_hz must be a positive frequency, got {target_hz!r}")
        self.target_hz = float(target_hz)

    def goals(self, measured_hz: np.ndarray, acceptance_hz: float) -> list[Goal]:
        """The split, and the largest distance of a measured mode from ``target_hz``."""
        error = float(np.max(np.abs(np.asarray(measured_hz, dtype=float) - self.target_hz)))
        return [
            *super().goals(measured_hz, acceptance_hz),
            Goal("frequency error", error, self.tolerance_hz),
        ]

    def solve(self, model: FittedModel, space: BiasSpace) -> TuningResult:
        box = space.box()
        lam0 = (2 * np.pi * self.target_hz) ** 2
        anchor = _start_w(space)
        w, _ = solve_spread(model, box, self.solver, target_lam=lam0, anchor_w=anchor)
        res = self._result(model, space, w, 0.0, target_hz=self.target_hz)
        res.value = float(np.max(np.abs(res.frequencies_hz - self.target_hz)))
        res.info["frequency_error_hz"] = res.value
        if res.value > self.tolerance_hz:
            raise UnreachableTuningError(
                f"the modes cannot both reach {self.target_hz} Hz inside the bias limits "
                f"{space.limits} V with electrodes {', '.join(space.tuned)}: the best reachable "
                f"frequency error is {res.value:.3f} Hz (modes at "
                f"{res.frequencies_hz[0]:.3f} and {res.frequencies_hz[1]:.3f} Hz) at "
                f"{_fmt(res.bias)}",
                best_bias=res.bias.tolist(),
                best_value=res.value,
            )
        return res


class MinMaxBias(_Base):
    """Degenerate modes with the smallest largest bias ``max_p |dv_p|``.

    Bisection on the bound ``T``: for each ``T`` the reachable ``w_p`` is the interval
    ``[max(0, |v_gyro| - T)^2, (|v_gyro| + T)^2]`` (intersected with the device limits) and a
    spread program decides whether degenerate modes are reachable (spread ≤ 1e-5 Hz). A bound
    whose program the solver cannot decide counts as infeasible (the answer stays a verified
    feasible point, at worst a little above the optimum).

    Parameters
    ----------
    tolerance_hz : float
        Largest predicted split that counts as degenerate at the full limits (default 1 mHz).
    bias_tol : float
        Bisection stops when the bracket on ``T`` is narrower than this (default 1e-4 V).
    solver : Solver
        Conic solver backend (the run's, with the ``[solver]`` options).
    """

    name = "min-max-bias"
    description = "degenerate modes with the smallest max |bias| (bisection)"
    _FEASIBLE_HZ = 1e-5

    def __init__(
        self,
        *,
        solver: Solver,
        tolerance_hz: Positive = 1e-3,
        bias_tol: Positive = 1e-4,
    ) -> None:
        super().__init__(solver=solver, tolerance_hz=tolerance_hz)
        if not (isinstance(bias_tol, (int, float)) and bias_tol > 0):
            raise ConfigError(f"bias_tol must be a positive number of volts, got {bias_tol!r}")
        self.bias_tol = float(bias_tol)

    def _spread(self, model: FittedModel, space: BiasSpace, t_max: float):
        w, _ = solve_spread(model, space.box(t_max), self.solver)
        f = frequencies_from_w(model, w)
        return w, float(f[1] - f[0])

    def solve(self, model: FittedModel, space: BiasSpace) -> TuningResult:
        low, high = space.limits
        hi = max(abs(low), abs(high))
        w_hi, split = self._spread(model, space, hi)
        if split > self.tolerance_hz:
            res = self._result(model, space, w_hi, split)
            raise UnreachableTuningError(
                f"the modes cannot be made degenerate inside the bias limits {space.limits} V: "
                f"the best reachable split is {split * 1e3:.1f} mHz at {_fmt(res.bias)}",
                best_bias=res.bias.tolist(),
                best_value=split,
            )
        # No bias has |dv| below the limit nearest 0 when the limits exclude 0: start there
        # (a bound below it would leave an empty interval of w).
        lo = 0.0 if low <= 0.0 <= high else min(abs(low), abs(high))
        while hi - lo > self.bias_tol:
            mid = 0.5 * (lo + hi)
            try:
                w, split = self._spread(model, space, mid)
            except SolverError:  # undecided (seen on tiny boxes): treat as infeasible, go up
                split = float("inf")
            if split <= self._FEASIBLE_HZ:
                hi, w_hi = mid, w
            else:
                lo = mid
        res = self._result(model, space, w_hi, 0.0, max_abs_bias=hi + 1e-9)
        res.value = res.split_hz
        res.info["max_abs_bias"] = float(np.max(np.abs(res.bias[space.index])))
        return res
