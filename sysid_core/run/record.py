"""What one iteration of a tuning run did (:class:`IterationRecord`), and what the records say.

The run's ``summary.json`` holds one record per iteration (its ``history``); the run reads the
least and the latest verified split from them (:func:`verified_splits`).
"""

from __future__ import annotations

import dataclasses
import functools
from dataclasses import dataclass
from typing import Any, TypedDict

import numpy as np
import xarray as xr

from sysid_core.data.io import json_line
from sysid_core.measure.verification import Verification
from sysid_core.model.fitted import FittedModel
from sysid_core.tuning.confidence import split_interval
from sysid_core.tuning.criteria import Goal, TuningResult

__all__ = [
    "IterationRecord",
    "Least",
    "Seen",
    "failed_in_a_row",
    "last_linearised",
    "latest_measured",
    "least_measured",
    "seen_so_far",
    "verified_splits",
]


@dataclass
class IterationRecord:
    """What one iteration did.

    ``experiments``: the biases (tuned electrodes) its model was fitted at that no earlier
    iteration's record lists, so that the records together list every bias a fit used once;
    ``fitted_experiments``: how many experiments its fit used; ``points``: frequency points
    measured by the run so far; ``bench_time_s``: the bench time spent by the end of its
    verification; ``measured_split_ci_hz``: the 95 % interval of the split its verification
    measured (None without one).
    """

    iteration: int
    experiments: list[list[float]]
    tuning: dict[str, Any]
    verified_bias: list[float]
    verification: str
    measured_split_hz: float | None
    measured_frequency_hz: float | None
    measured_frequencies_hz: list[float] | None
    goals: list[dict[str, Any]]
    evidence: list[dict[str, Any]]
    gamma: float
    fit_time_s: float
    points: int = 0
    bench_time_s: float | None = None
    measured_split_ci_hz: list[float] | None = None
    fitted_experiments: int = 0

    @classmethod
    def of(
        cls,
        it: int,
        ds: xr.Dataset,
        model: FittedModel,
        result: TuningResult,
        bias: np.ndarray,
        ver: Verification,
        goals: list[Goal],
        counts: tuple[int, float | None] = (0, None),
        listed: set[tuple[float, ...]] | None = None,
    ) -> IterationRecord:
        """Iteration ``it``'s record; ``counts``: the run's points and bench time (s) so far.

        ``listed``: the biases earlier records list (updated with this one's); None: list
        every bias of ``ds``. A run's windows pile up near one bias, and a record that listed
        them all would make ``summary.json`` grow with the square of the iterations.
        """
        fitted = ds["bias"].values.tolist()
        new = fitted if listed is None else _unlisted(fitted, listed)
        return cls(
            iteration=it,
            experiments=new,
            fitted_experiments=len(fitted),
            tuning=result.as_dict(),
            verified_bias=bias.tolist(),
            verification=ver.status,
            measured_split_hz=ver.split_hz,
            measured_frequency_hz=ver.frequency_hz,
            measured_frequencies_hz=None
            if ver.frequencies_hz is None
            else [float(x) for x in ver.frequencies_hz],
            goals=[g.as_dict() for g in goals],
            evidence=[w.as_dict() for w in ver.windows],
            gamma=model.gamma,
            fit_time_s=float(model.facts.fit_time_s or 0.0),
            measured_split_ci_hz=_interval(ver),
            points=counts[0],
            bench_time_s=counts[1],
        )

    def as_dict(self) -> dict[str, Any]:
        """JSON-friendly form."""
        return {f.name: getattr(self, f.name) for f in dataclasses.fields(self)}

    @functools.cached_property
    def json(self) -> str:
        """:meth:`as_dict` as one line of JSON, encoded once (a record does not change)."""
        return json_line(self.as_dict())


def _unlisted(biases: list[list[float]], listed: set[tuple[float, ...]]) -> list[list[float]]:
    """The ``biases`` not in ``listed``, each once, in order; ``listed`` takes them."""
    new = []
    for b in biases:
        key = tuple(b)
        if key not in listed:
            listed.add(key)
            new.append(b)
    return new


def _interval(ver: Verification) -> list[float] | None:
    """The 95 % interval of the split ``ver`` measured, or None."""
    if not ver.verified or ver.split_hz is None:
        return None
    found = split_interval(ver.model)
    return None if found is None else [float(found[0]), float(found[1])]


#: The least split a verified window of a run measured (Hz) and its bias, or None.
Least = tuple[float, np.ndarray] | None


def least_measured(history: list[IterationRecord]) -> Least:
    """The least split a verified window of the run measured, with its bias (None before one)."""
    found = [
        (float(h.measured_split_hz), np.asarray(h.verified_bias, dtype=float))
        for h in history
        if h.verification == "verified"
        and h.measured_split_hz is not None
        and np.isfinite(h.measured_split_hz)
    ]
    return min(found, key=lambda pair: pair[0]) if found else None


def latest_measured(history: list[IterationRecord]) -> Least:
    """The latest iteration's verified split and its bias, or None (not verified)."""
    if not history:
        return None
    h = history[-1]
    if h.verification != "verified" or h.measured_split_hz is None:
        return None
    if not np.isfinite(h.measured_split_hz):
        return None
    return float(h.measured_split_hz), np.asarray(h.verified_bias, dtype=float)


def failed_in_a_row(history: list[IterationRecord]) -> int:
    """How many of the latest iterations in a row had a verification that showed no modes."""
    count = 0
    for h in reversed(history):
        if h.verification != "failed":
            break
        count += 1
    return count


def last_linearised(history: list[IterationRecord]) -> tuple[dict[str, float] | None, float | None]:
    """The latest linearised step's ``trust_region`` entry and the split then verified there.

    ``(None, None)`` before any (:func:`~sysid_core.verdict.trust.trust_radius` reads them).
    """
    for h in reversed(history):
        if "trust_region" in h.tuning:
            split = h.measured_split_hz if h.verification == "verified" else None
            return h.tuning["trust_region"], None if split is None else float(split)
    return None, None


class Seen(TypedDict):
    """What an answer (:func:`sysid_core.verdict.answer.answer`) is told of the run so far."""

    least_measured: Least
    latest_measured: Least
    linearised: tuple[dict[str, float] | None, float | None]


def seen_so_far(history: list[IterationRecord]) -> Seen:
    """:func:`least_measured`, :func:`latest_measured` and :func:`last_linearised`."""
    return Seen(
        least_measured=least_measured(history),
        latest_measured=latest_measured(history),
        linearised=last_linearised(history),
    )


def verified_splits(history: list[IterationRecord]) -> tuple[Least, Least]:
    """:func:`least_measured` and :func:`latest_measured` of ``history``."""
    return least_measured(history), latest_measured(history)
