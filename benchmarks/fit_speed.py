"""Wall time of the fit methods against the straightforward cvxpy formulation, in one run.

For each data size (experiments x points per experiment) and each method, a fresh worker process
builds the same synthetic data set (a cloverleaf-like gyro, seeded noise), warms the method up on
a small data set, then times ``--repeats`` runs from the data set to the answer (problem set-up
included) and reports the median. Every run has a time limit (``--timeout``, 120 s): a method
that cannot finish a case in time is reported as such, and the benchmark never hangs. BLAS is
limited to one thread (environment and threadpoolctl), as the design notes advise.

Methods
-------
fit            ``fit(..., objective=Minimax(), solver=Clarabel)``: the working-set minimax fit with
               default options (least-squares start, working set, tie-break).
least-squares  ``fit(..., objective=LeastSquares(), solver=Clarabel)``.
default        ``fit(ds)``: the toolkit's default model and objective (act of order 2 with a
               bias-dependent constant term, stiffness law "auto", least squares, Clarabel),
               covariance (and, on a two-sided design, the law's test) included;
               the line under each table gives its time relative to ``fit`` (the paper's
               minimax model of order 1, the default before).
clarabel-full  ``Minimax(working_set=False)`` on Clarabel: the full program on every point (and
               its full tie-break program).
scs-full       ``Minimax(working_set=False)`` on SCS.
cvxpy          :func:`sysid_core.reference.solve_reference`: the straightforward cvxpy
               formulation (one complex Hermitian LMI per point) solved by Clarabel.

Usage::

    python benchmarks/fit_speed.py                       # all cases, 5 repeats (~10 min)
    python benchmarks/fit_speed.py --cases 3x121 --repeats 3 --json

See ``benchmarks/README.md`` for the output and the targets.
"""

from __future__ import annotations

import argparse
import json
import math
import os
import queue
import statistics
import subprocess
import sys
import threading
import time
from pathlib import Path
from typing import Any

import numpy as np

METHODS = ("fit", "least-squares", "default", "clarabel-full", "scs-full", "cvxpy")
DEFAULT_CASES = ("3x121", "10x121", "49x121", "3x6000")
BAND_HZ = (4385.0, 4445.0)
V_GYRO = 15.58
PAPER_BIASES = [[0.0, 0.0], [1.0, 0.0], [0.0, 1.0]]
WARMUP_CASE = "3x21"
THREAD_ENV = {
    "OPENBLAS_NUM_THREADS": "1",
    "OMP_NUM_THREADS": "1",
    "MKL_NUM_THREADS": "1",
    "VECLIB_MAXIMUM_THREADS": "1",
}


# --------------------------------------------------------------------------- data
def parse_case(case: str) -> tuple[int, int]:
    """``"3x121"`` -> ``(3, 121)``."""
    try:
        n_exp, n_pts = (int(x) for x in case.lower().split("x"))
    except ValueError:
        raise SystemExit(f"bad case {case!r}: use EXPERIMENTSxPOINTS, e.g. 3x121") from None
    if n_exp < 3 or n_pts < 5:
        raise SystemExit(f"bad case {case!r}: at least 3 experiments and 5 points")
    return n_exp, n_pts


def biases(n_exp: int) -> np.ndarray:
    """The paper's three biases, or an ``r x c`` grid over ±6 V (``r c = n_exp``, ``r`` >= 2).

    Any grid with at least two distinct values per electrode satisfies the rank condition (6).
    """
    if n_exp == 3:
        return np.array(PAPER_BIASES)
    rows = max(d for d in range(1, math.isqrt(n_exp) + 1) if n_exp % d == 0)
    if rows < 2:
        raise SystemExit(f"{n_exp} experiments: use 3 or a number with a factor in 2..sqrt(n)")
    b1, b2 = np.meshgrid(np.linspace(-6, 6, n_exp // rows), np.linspace(-6, 6, rows))
    return np.column_stack([b1.ravel(), b2.ravel()])


def truth():  # -> GyroTruth
    """A two-electrode gyro like the paper's cloverleaf (B3 folded into K0), velocity pick-off,
    output low-passes: inside the model class for ``act`` with order 1."""
    from sysid_core.device.simulation import GyroTruth, LowPass

    two_pi = 2 * np.pi
    kp = np.array(
        [
            [[-11464.16, 0.0], [0.0, -573.21]],
            [[-7635.31, -6908.14], [-6908.14, -7635.31]],
            [[-591.98, 100.48], [100.48, -11820.66]],
        ]
    )
    k0 = two_pi**2 * np.array([[19706390.62, 21303.38], [21303.38, 19724860.06]])
    return GyroTruth(
        M=np.eye(2),
        C=np.array([[0.502227, 0.066914], [0.066914, 0.579493]]),
        K0=k0 + kp[2] * V_GYRO**2,
        Kp=kp[:2],
        structure_potential=V_GYRO,
        electrodes=("B1", "B2"),
        R=np.array([[0.97, 0.23], [-0.15, 1.04]]),
        velocity_pickoff=True,
        h_out=LowPass((20000.0, 18470.0), (1.0, 0.97)),
    )


def dataset(case: str, seed: int = 0):  # -> xarray.Dataset
    """Synthetic data: 0.1 % noise per point plus 1e-4 of each experiment's peak (seeded)."""
    from sysid_core.data.schema import make_dataset

    n_exp, n_pts = parse_case(case)
    tr = truth()
    freqs = np.linspace(*BAND_HZ, n_pts)
    rng = np.random.default_rng(seed)
    responses = []
    for b in biases(n_exp):
        r = tr.response(b, freqs)
        scale = 1e-3 * np.abs(r) + 1e-4 * np.abs(r).max()
        z = (rng.standard_normal(r.shape) + 1j * rng.standard_normal(r.shape)) / np.sqrt(2)
        responses.append(r + scale * z)
    return make_dataset(responses, freqs, biases(n_exp), ["B1", "B2"], V_GYRO, device="truth")


# --------------------------------------------------------------------------- worker
def run_method(method: str, ds: Any, warmup: bool = False) -> dict[str, Any]:
    """One run of ``method`` from the data set to its answer; γ in physical units.

    With ``warmup`` SCS is capped at a few iterations (the warm-up only loads code).
    """
    sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests"))
    from reference import solve_reference  # the cvxpy formulation (tests/reference.py)
    from sysid_models.structures import ActStructure
    from sysid_objectives.least_squares import LeastSquares
    from sysid_objectives.minimax import Minimax
    from sysid_solvers.clarabel_backend import ClarabelSolver
    from sysid_solvers.scs_backend import ScsSolver
    from threadpoolctl import threadpool_limits

    from sysid_core.api import fit
    from sysid_core.identification.problem import FitProblem

    t0 = time.perf_counter()
    if method == "cvxpy":
        with threadpool_limits(limits=1, user_api="blas"):
            problem = FitProblem(ds, ActStructure(1))
            sol = solve_reference(problem, "minimax", "CLARABEL")
        elapsed = time.perf_counter() - t0
        return {
            "time": elapsed,
            "gamma": sol.value * problem.scaling.psi_scale,
            "status": sol.status,
            "detail": f"compile {sol.compile_time:.2f} s, solver {sol.solver_time:.2f} s",
        }
    if method == "default":
        model = fit(
            ds,
            ActStructure(2, bias_terms=1, stiffness="auto"),
            objective=LeastSquares(),
            solver=ClarabelSolver(),
        )
        elapsed = time.perf_counter() - t0
        return {
            "time": elapsed,
            "gamma": model.gamma,
            "status": "solved" + ("" if model.stiffness_factor is not None else ", no covariance"),
            "detail": f"act(2, bias_terms=1, {model.meta.get('stiffness_law')} law), "
            f"{model.meta['n_parameters']} unknowns, covariance",
        }
    objective, solver = {
        "fit": (Minimax, ClarabelSolver),
        "least-squares": (LeastSquares, ClarabelSolver),
        "clarabel-full": (lambda: Minimax(working_set=False), ClarabelSolver),
        "scs-full": (
            lambda: Minimax(working_set=False),
            (lambda: ScsSolver(max_iters=50)) if warmup else ScsSolver,
        ),
    }[method]
    model = fit(ds, ActStructure(1), objective=objective(), solver=solver())
    elapsed = time.perf_counter() - t0
    meta = model.meta
    return {
        "time": elapsed,
        "gamma": model.gamma,
        "status": "solved" + ("" if meta["certified"] else ", NOT certified"),
        "detail": f"{meta['solves']} solves, {meta['working_set']} points in last program, "
        f"{meta['solver_iterations']} iterations",
    }


def worker(case: str, method: str, repeats: int, budget: float, memory_gb: float) -> None:
    """Warm up on a small case, then print one JSON line per timed run (flushed)."""
    if memory_gb > 0:
        import resource

        limit = int(memory_gb * 2**30)
        resource.setrlimit(resource.RLIMIT_AS, (limit, limit))
    import warnings

    warnings.simplefilter("ignore")  # e.g. a broken third-party plugin; statuses are reported
    try:
        run_method(method, dataset(WARMUP_CASE, seed=1), warmup=True)
    except Exception:  # the warm-up only loads code; the timed runs report failures
        pass
    print(json.dumps({"warm": True}), flush=True)
    ds = dataset(case)
    start = time.perf_counter()
    for i in range(repeats):
        try:
            out = run_method(method, ds)
        except MemoryError:
            out = {"error": f"out of memory (limit {memory_gb:g} GB)", "status": "memory"}
        except Exception as exc:
            status = getattr(exc, "status", None) or type(exc).__name__
            out = {"error": f"{type(exc).__name__}: {exc}", "status": str(status)}
        print(json.dumps({"run": i, **out}), flush=True)
        if "error" in out or time.perf_counter() - start > budget:
            break


# --------------------------------------------------------------------------- driver
def measure(
    case: str, method: str, repeats: int, timeout: float, budget: float, memory_gb: float
) -> dict[str, Any]:
    """Run one worker process; collect its runs, killing it if one run exceeds ``timeout``."""
    cmd = [
        sys.executable, os.path.abspath(__file__), "--worker", case, method,
        "--repeats", str(repeats), "--budget", str(budget), "--memory-gb", str(memory_gb),
    ]  # fmt: skip
    env = {**os.environ, **THREAD_ENV}
    proc = subprocess.Popen(cmd, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, env=env)
    lines: queue.Queue[str | None] = queue.Queue()

    def pump() -> None:
        assert proc.stdout is not None
        for line in proc.stdout:
            lines.put(line)
        lines.put(None)

    threading.Thread(target=pump, daemon=True).start()
    runs: list[dict[str, Any]] = []
    # The first deadline covers start-up, imports and the warm-up (on a small data set).
    deadline = time.monotonic() + timeout
    timed_out = warm = False
    while True:
        try:
            line = lines.get(timeout=max(deadline - time.monotonic(), 0.0))
        except queue.Empty:
            timed_out = True
            proc.kill()
            break
        if line is None:
            break
        if line.startswith("{"):
            item = json.loads(line)
            if item.get("warm"):
                warm = True
            else:
                runs.append(item)
            deadline = time.monotonic() + timeout  # each run (and the warm-up) gets the limit
    proc.wait()
    stderr = proc.stderr.read() if proc.stderr else ""
    ok = [r for r in runs if "error" not in r]
    result: dict[str, Any] = {"case": case, "method": method, "runs": len(ok)}
    if ok:
        result.update(
            time=statistics.median(r["time"] for r in ok),
            gamma=ok[-1]["gamma"],
            status=ok[-1]["status"],
            detail=ok[-1].get("detail", ""),
        )
    elif timed_out:
        what = "" if warm else " (in the warm-up on a small case)"
        result.update(time=None, gamma=None, status=f"did not finish in {timeout:g} s{what}")
    else:
        err = next((r for r in runs if "error" in r), None)
        tail = stderr.strip().splitlines()[-1:] if stderr.strip() else ["no output"]
        result.update(
            time=None,
            gamma=None,
            status=err["status"] if err else "crashed",
            detail=err["error"] if err else tail[0],
        )
    if timed_out and ok:
        result["detail"] = result.get("detail", "") + f"; a later run exceeded {timeout:g} s"
    return result


def fmt_time(t: float | None) -> str:
    return "-" if t is None else (f"{t * 1e3:.1f} ms" if t < 1 else f"{t:.2f} s")


def report(case: str, results: dict[str, dict[str, Any]], timeout: float) -> None:
    """Print one case's table."""
    cvx = results["cvxpy"]["time"]
    cvx_unfinished = str(results["cvxpy"]["status"]).startswith("did not finish")
    ref = results["clarabel-full"]["gamma"]
    print(f"\n== {case} (experiments x points) ==")
    head = (
        f"{'method':<14} {'median':>10} {'runs':>4} {'speed-up':>9} {'gamma':>13} "
        f"{'rel. to full':>12}  status"
    )
    print(head)
    print("-" * len(head))
    for method in METHODS:
        r = results[method]
        t = r["time"]
        if t is None:
            ratio = "-"
        elif cvx is not None:
            ratio = f"{cvx / t:.1f}x"
        elif cvx_unfinished:
            ratio = f">{timeout / t:.0f}x"
        else:
            ratio = "-"
        gamma = r["gamma"]
        g = "-" if gamma is None else f"{gamma:.7g}"
        rel = "-" if gamma is None or not ref else f"{(gamma - ref) / ref:+.1e}"
        detail = f" ({r['detail']})" if r.get("detail") else ""
        print(
            f"{method:<14} {fmt_time(t):>10} {r['runs']:>4} {ratio:>9} {g:>13} {rel:>12}  "
            f"{r['status']}{detail}"
        )
    new, old = results["default"]["time"], results["fit"]["time"]
    if new is not None and old is not None:
        print(
            f"default fit / paper's minimax fit (the default before): {new / old:.3f} "
            f"({'faster' if new < old else 'SLOWER'})"
        )


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--cases", default=",".join(DEFAULT_CASES), help="e.g. 3x121,10x121")
    parser.add_argument("--methods", default=",".join(METHODS), help="subset, comma-separated")
    parser.add_argument("--repeats", type=int, default=5, help="timed runs per method (median)")
    parser.add_argument("--timeout", type=float, default=120.0, help="limit per run, seconds")
    parser.add_argument(
        "--budget", type=float, default=60.0,
        help="stop repeating a method once its runs took this long (at least one run)",
    )  # fmt: skip
    parser.add_argument("--memory-gb", type=float, default=8.0, help="address space per worker")
    parser.add_argument("--json", action="store_true", help="last line: one JSON object of times")
    parser.add_argument("--worker", nargs=2, metavar=("CASE", "METHOD"), help=argparse.SUPPRESS)
    args = parser.parse_args(argv)
    if args.worker:
        worker(*args.worker, args.repeats, args.budget, args.memory_gb)
        return
    cases = [c.strip() for c in args.cases.split(",") if c.strip()]
    methods = [m.strip() for m in args.methods.split(",") if m.strip()]
    for m in methods:
        if m not in METHODS:
            raise SystemExit(f"unknown method {m!r}; known: {', '.join(METHODS)}")
    for c in cases:
        parse_case(c)
        biases(parse_case(c)[0])
    print(
        f"fit speed: act order 1, cloverleaf-like truth, median of up to {args.repeats} runs after "
        f"a warm-up, each method in a fresh process, one BLAS thread, {args.timeout:g} s per run",
        flush=True,
    )
    table: dict[str, dict[str, float | None]] = {}
    for case in cases:
        results: dict[str, dict[str, Any]] = {}
        for method in METHODS:
            if method not in methods:
                results[method] = {"time": None, "gamma": None, "runs": 0, "status": "skipped"}
                continue
            results[method] = measure(
                case, method, args.repeats, args.timeout, args.budget, args.memory_gb
            )
            r = results[method]
            print(f"  {case} {method}: {fmt_time(r['time'])} ({r['status']})", flush=True)
        report(case, results, args.timeout)
        table[case] = {m: results[m]["time"] for m in METHODS}
    print(
        "\nmedian: wall time from the data set to the answer (problem set-up included); "
        "speed-up: cvxpy median / method median ('>N' when cvxpy did not finish: a lower bound); "
        "gamma: minimax optimum in physical units (least-squares: its largest residual); "
        "rel. to full: relative difference to clarabel-full's gamma."
    )
    if args.json:
        print(json.dumps(table))


if __name__ == "__main__":
    main()
