"""What a fit found, as typed fields: the stiffness law and its test, the drift terms, the data.

A fitted model keeps what its fit found in ``FittedModel.meta``, a JSON mapping that
``model.nc`` stores as it is (the file layout, :mod:`sysid_core.model.files`). The run reads it
through :class:`FitFacts` (``model.facts``), parsed once, so that no step decodes strings of its
own and a key that moves has one reader to change.

==========================  ==================================================================
field                       from ``meta``
==========================  ==================================================================
``law``                     ``stiffness_law``, with ``law_statistic``, ``law_threshold``,
                            ``law_tested`` and ``law_test`` (:class:`LawTest`)
``trend_per_s``             ``drift_trend``: the stiffness trend in time (2×2, per second)
``trend_span_s``            ``drift_trend_span_s``: the span it was measured over
``drift_rate_per_h``        ``drift_rate_per_h``: a common frequency drift, relative per hour
``offsets``                 ``drift_offsets``, with ``drift_epoch_times_s``
``time_span_s``             ``time_span_s``: the span of the data's time stamps
``fit_bias``                ``fit_bias``: the biases of the data's experiments
``fit_time_s``              ``fit_time_s``: the fit's wall time
``from_model``              ``from_model``: the model was given, not fitted (``--from-model``)
==========================  ==================================================================
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any

import numpy as np

__all__ = ["FitFacts", "LawTest"]


@dataclass(frozen=True)
class LawTest:
    """The stiffness law a fit kept, and the test that chose it.

    Attributes
    ----------
    law : str
        ``"linear"`` or ``"quadratic"``.
    statistic, threshold : float or None
        The Wald statistic of the quadratic terms and its 99 % threshold (None: not tested).
    tested : str or None
        Which terms were tested: ``"split"`` (those that split the modes) or ``"all"``.
    note : str or None
        Why the law was chosen without the test (e.g. the design does not identify it).
    fallback : bool
        The quadratic fit failed and the linear law was fitted instead.
    """

    law: str
    statistic: float | None = None
    threshold: float | None = None
    tested: str | None = None
    note: str | None = None
    fallback: bool = False

    def describe(self) -> str:
        """One line: the law and why (``linear (test of the L_p terms 3.2 <= 13.3)``)."""
        if self.statistic is not None and self.threshold is not None:
            part = " that split the modes" if self.tested == "split" else ""
            sign = ">" if self.law == "quadratic" else "<="
            return (
                f"{self.law} (test of the L_p terms{part} {self.statistic:.3g} {sign} "
                f"{self.threshold:.3g})"
            )
        return f"{self.law} ({self.note})"


def _optional_float(value: Any) -> float | None:
    return None if value is None else float(value)


@dataclass(frozen=True)
class FitFacts:
    """What a fit found (see the module), read from a model's ``meta``."""

    law: LawTest | None = None
    trend_per_s: np.ndarray | None = None
    trend_span_s: float = 0.0
    drift_rate_per_h: float | None = None
    offsets: tuple[float, ...] = ()
    epoch_times_s: tuple[float, ...] = ()
    time_span_s: float = 0.0
    fit_bias: np.ndarray | None = None
    fit_time_s: float | None = None
    from_model: bool = False

    @classmethod
    def of(cls, meta: Mapping[str, Any]) -> FitFacts:
        """The facts of a model's ``meta`` (missing keys: not found)."""
        law = meta.get("stiffness_law")
        trend = meta.get("drift_trend")
        bias = meta.get("fit_bias")
        return cls(
            law=None
            if law is None
            else LawTest(
                str(law),
                _optional_float(meta.get("law_statistic")),
                _optional_float(meta.get("law_threshold")),
                meta.get("law_tested"),
                None if meta.get("law_test") is None else str(meta["law_test"]),
                bool(meta.get("law_fallback", False)),
            ),
            trend_per_s=None if trend is None else np.asarray(trend, dtype=float),
            trend_span_s=float(meta.get("drift_trend_span_s") or 0.0),
            drift_rate_per_h=_optional_float(meta.get("drift_rate_per_h")),
            offsets=tuple(float(d) for d in meta.get("drift_offsets") or ()),
            epoch_times_s=tuple(float(t) for t in meta.get("drift_epoch_times_s") or ()),
            time_span_s=float(meta.get("time_span_s") or 0.0),
            fit_bias=None if bias is None else np.atleast_2d(np.asarray(bias, dtype=float)),
            fit_time_s=_optional_float(meta.get("fit_time_s")),
            from_model=bool(meta.get("from_model", False)),
        )
