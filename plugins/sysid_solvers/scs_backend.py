"""SCS backend: calls ``scs.SCS`` directly on the standard form (SCS's own PSD convention)."""

from __future__ import annotations

import time
from typing import Any, ClassVar

import numpy as np
import scipy.sparse as sp

from sysid_core.conic import ConicProgram, ConicSolution
from sysid_core.errors import ConfigError, SolverError
from sysid_core.interfaces import Solver, typed_option

__all__ = ["ScsSolver"]

#: SCS settings accepted here, with their type.
_KNOWN: dict[str, type] = {
    "eps_abs": float,
    "eps_rel": float,
    "eps_infeas": float,
    "max_iters": int,
    "time_limit_secs": float,
    "verbose": bool,
    "normalize": bool,
    "scale": float,
    "adaptive_scale": bool,
    "rho_x": float,
    "alpha": float,
    "acceleration_lookback": int,
    "acceleration_interval": int,
    "use_indirect": bool,
    "gpu": bool,
}


class ScsSolver(Solver):
    """SCS splitting conic solver.

    Parameters
    ----------
    **options
        SCS settings (``eps_abs``, ``eps_rel``, ``max_iters``, ...). Defaults here:
        ``eps_abs = eps_rel = 1e-7``, ``max_iters = 200000``, ``verbose = False`` (SCS's own
        1e-4 is too loose for tuning).

    Only status ``solved`` is accepted; ``solved_inaccurate`` and every other status raise
    :class:`~sysid_core.errors.SolverError` naming it.
    """

    name = "scs"
    description = "SCS first-order (ADMM) conic solver (direct, standard form)"
    STATUS_MAP: ClassVar[dict[str, str]] = {"solved": "solved"}

    def __init__(self, **options: Any) -> None:
        for key, value in options.items():
            if key not in _KNOWN:
                raise ConfigError(
                    f"unknown option {key!r} for solver 'scs'; known: {', '.join(sorted(_KNOWN))}"
                )
            options[key] = typed_option("solver", "scs", key, value, _KNOWN[key])
        self.options = {
            "eps_abs": 1e-7,
            "eps_rel": 1e-7,
            "max_iters": 200_000,
            "verbose": False,
            **options,
        }

    def solve(self, program: ConicProgram) -> ConicSolution:
        import scs

        c = program.cones
        data = {"A": sp.csc_matrix(program.A), "b": program.b, "c": program.c}
        if program.P is not None:
            data["P"] = sp.triu(program.P, format="csc")
        cone = {"z": c.zero, "l": c.nonneg, "q": list(c.soc), "s": list(c.psd)}
        t0 = time.perf_counter()
        try:
            out = scs.SCS(data, cone, **self.options).solve()
        except Exception as exc:
            raise SolverError(f"SCS failed: {exc}", status="error") from exc
        elapsed = time.perf_counter() - t0
        info = out["info"]
        raw = str(info["status"])
        status = self.STATUS_MAP.get(raw)
        if status is None:
            raise SolverError(
                f"SCS ended with status {raw!r} after {info['iter']} iterations, not 'solved': "
                "the model would be unreliable. Try more iterations (max_iters), solver "
                "'clarabel', or check the data",
                status=raw,
            )
        return ConicSolution(
            x=np.asarray(out["x"]),
            objective=float(info["pobj"]),
            status=status,
            solver_status=raw,
            iterations=int(info["iter"]),
            solve_time=elapsed,
        )
