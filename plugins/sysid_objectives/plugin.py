"""Entry point of the built-in fit objectives."""

from __future__ import annotations

from collections.abc import Callable, Mapping

from sysid_core import hookimpl
from sysid_core.plugin.interfaces import Objective
from sysid_objectives.least_squares import LeastSquares
from sysid_objectives.minimax import Minimax


@hookimpl
def sysid_objectives() -> Mapping[str, Callable[..., Objective]]:
    return {"minimax": Minimax, "least-squares": LeastSquares}
