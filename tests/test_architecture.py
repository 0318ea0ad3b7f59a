"""The architecture of ``sysid_core``: rooms with one-way imports, no cvxpy at run time, one
registry per run, one set of defaults.

* The rooms (subpackages) import one way (:data:`ROOMS`); a violation names the import. At most
  six top-level modules, none over 400 lines, and every room's ``__init__`` says what lives
  there and what it may import. The core imports no plugin.
* No import cycle anywhere in ``sysid_core``, counting imports inside functions and under
  ``if TYPE_CHECKING:`` (a static graph from ``ast``; the cycle finder is tested on its own).
* ``import sysid_core`` and a full ``sysid tune`` of the README example never import cvxpy (the
  reference formulation is test-only).
* A run's components come from the registry it is given, with the options of its configuration
  file: a third-party criterion's own option and the solver's options reach them, and a run
  through a registry of test plugins never touches the process-wide registry.
"""

from __future__ import annotations

import ast
import importlib
import importlib.util
import json
import os
import subprocess
import sys
from collections.abc import Iterable, Mapping
from pathlib import Path
from typing import Any, ClassVar

import numpy as np
import pytest
import sysid_cloverleaf.plugin
import sysid_criteria.plugin
import sysid_models.plugin
import sysid_objectives.plugin
import sysid_solvers.plugin
import xarray as xr
from sysid_cloverleaf import CloverleafGyro
from sysid_criteria.criteria import Degenerate
from sysid_models.structures import ActStructure
from sysid_objectives.least_squares import LeastSquares
from sysid_objectives.minimax import Minimax
from sysid_solvers.clarabel_backend import ClarabelSolver

import sysid_core
import sysid_core._compat
import sysid_core.plugin.registry
from sysid_core import hookimpl
from sysid_core.conic.program import Solver
from sysid_core.errors import ConfigError
from sysid_core.model.fitted import FittedModel
from sysid_core.plugin.registry import Registry
from sysid_core.run.config import load_config
from sysid_core.run.pipeline import TuningRun
from sysid_core.run.summary import RunSummary
from sysid_core.tuning.criteria import BiasSpace, TuningResult

ROOT = Path(__file__).resolve().parents[1]
CORE = Path(sysid_core.__file__).resolve().parent
README_EXAMPLE = ROOT / "examples" / "cloverleaf-2electrode.toml"


# =============================================================== import graph and cycle finder
def module_names(package_dir: Path, package: str) -> dict[str, Path]:
    """Every module of a package and its subpackages: ``{"pkg": __init__.py, "pkg.sub.mod":
    sub/mod.py, ...}`` (a subpackage is named by its ``__init__.py``)."""
    names = {}
    for path in sorted(package_dir.rglob("*.py")):
        parts = path.relative_to(package_dir).with_suffix("").parts
        if parts[-1] == "__init__":
            parts = parts[:-1]
        names[".".join([package, *parts])] = path
    return names


def _owner(name: str, known: Iterable[str]) -> str | None:
    """The longest known module that ``name`` is or lies in (``None``: outside the package)."""
    matches = [k for k in known if name == k or name.startswith(k + ".")]
    return max(matches, key=len) if matches else None


def _is_main_guard(node: ast.AST) -> bool:
    """``if __name__ == "__main__":`` (either operand order)."""
    if not (isinstance(node, ast.If) and isinstance(node.test, ast.Compare)):
        return False
    test = node.test
    if len(test.ops) != 1 or not isinstance(test.ops[0], ast.Eq):
        return False
    sides = [test.left, test.comparators[0]]
    names = [s.id for s in sides if isinstance(s, ast.Name)]
    constants = [s.value for s in sides if isinstance(s, ast.Constant)]
    return names == ["__name__"] and constants == ["__main__"]


def _walk_as_imported(tree: ast.AST) -> Iterable[ast.AST]:
    """Every node of ``tree`` (like ``ast.walk``) except the bodies of ``__main__`` guards.

    Code under ``if __name__ == "__main__":`` runs only when the file is the script, i.e. as
    module ``__main__``: its imports are not edges of the package's module.
    """
    todo = [tree]
    while todo:
        node = todo.pop()
        yield node
        if _is_main_guard(node):
            assert isinstance(node, ast.If)
            todo.extend(node.orelse)
            continue
        todo.extend(ast.iter_child_nodes(node))


def imports_of(path: Path, module: str, package: str, known: set[str]) -> set[str]:
    """The package's modules that ``module`` imports, at any depth of its syntax tree.

    Every node is visited: imports at the top, inside functions and methods, under
    ``if TYPE_CHECKING:``, in ``try`` blocks (not under a ``__main__`` guard, see
    :func:`_walk_as_imported`). ``from pkg import x`` is an edge to ``pkg.x`` when ``x`` is a
    module, else to ``pkg`` (its ``__init__``); relative imports are resolved.
    """
    tree = ast.parse(path.read_text(encoding="utf-8"), filename=str(path))
    is_init = path.stem == "__init__"
    found: set[str] = set()
    for node in _walk_as_imported(tree):
        if isinstance(node, ast.Import):
            for alias in node.names:
                owner = _owner(alias.name, known)
                if owner is not None:
                    found.add(owner)
        elif isinstance(node, ast.ImportFrom):
            base = node.module or ""
            if node.level:
                parts = module.split(".") if is_init else module.split(".")[:-1]
                parts = parts[: len(parts) - (node.level - 1)]
                base = ".".join([*parts, *([node.module] if node.module else [])])
            if _owner(base, known) is None:
                continue
            for alias in node.names:
                owner = _owner(f"{base}.{alias.name}", known)
                if owner is not None:
                    found.add(owner)
    return found


def import_graph(package_dir: Path, package: str) -> dict[str, set[str]]:
    """``{module: {modules it imports}}`` over the package's own modules."""
    modules = module_names(package_dir, package)
    known = set(modules)
    return {name: imports_of(path, name, package, known) for name, path in modules.items()}


def find_cycles(graph: Mapping[str, Iterable[str]]) -> list[list[str]]:
    """One cycle ``[a, b, ..., a]`` per strongly connected component of 2+ nodes or self-loop.

    Tarjan's algorithm finds the components; in each, a shortest cycle through its first node
    (alphabetically) names it. Sorted, so the answer is deterministic.
    """
    edges = {node: sorted(set(targets)) for node, targets in graph.items()}
    for targets in list(edges.values()):
        for t in targets:
            edges.setdefault(t, [])
    index: dict[str, int] = {}
    low: dict[str, int] = {}
    stack: list[str] = []
    on_stack: set[str] = set()
    components: list[list[str]] = []

    def strongconnect(v: str) -> None:
        index[v] = low[v] = len(index)
        stack.append(v)
        on_stack.add(v)
        for w in edges[v]:
            if w not in index:
                strongconnect(w)
                low[v] = min(low[v], low[w])
            elif w in on_stack:
                low[v] = min(low[v], index[w])
        if low[v] == index[v]:
            component = []
            while True:
                w = stack.pop()
                on_stack.discard(w)
                component.append(w)
                if w == v:
                    break
            components.append(sorted(component))

    for v in sorted(edges):
        if v not in index:
            strongconnect(v)

    cycles = []
    for component in components:
        start = component[0]
        if len(component) == 1 and start not in edges[start]:
            continue
        members = set(component)
        # breadth-first from start's successors back to start, inside the component
        previous: dict[str, str] = {}
        frontier = [start]
        end = None
        while frontier and end is None:
            nxt = []
            for v in frontier:
                for w in edges[v]:
                    if w == start:
                        end = v
                        break
                    if w in members and w not in previous:
                        previous[w] = v
                        nxt.append(w)
                if end is not None:
                    break
            frontier = nxt
        assert end is not None  # a strongly connected component always closes
        path = [start]
        v = end
        while v != start:
            path.insert(1, v)
            v = previous[v]
        cycles.append([*path, start])
    return sorted(cycles)


def check_acyclic(graph: Mapping[str, Iterable[str]], what: str) -> None:
    """Fail naming every cycle of ``graph``."""
    cycles = find_cycles(graph)
    if cycles:
        named = "; ".join(" -> ".join(c) for c in cycles)
        raise AssertionError(f"import cycle(s) in {what}: {named}")


@pytest.mark.parametrize(
    ("graph", "expected"),
    [
        ({}, []),
        ({"a": ["b", "c"], "b": ["c"], "c": [], "d": ["a"]}, []),  # a DAG, diamond included
        ({"a": ["a"]}, [["a", "a"]]),  # a self-loop
        ({"a": ["b"], "b": ["a"]}, [["a", "b", "a"]]),
        (
            # a 3-cycle with a chord and a tail into it, a self-loop, an edge to an unknown node
            {"e": ["a"], "a": ["b"], "b": ["c", "x"], "c": ["a", "b"], "d": ["d"]},
            [["a", "b", "c", "a"], ["d", "d"]],
        ),
        (
            # two components joined one way only: two cycles, not one
            {"a": ["b"], "b": ["a", "c"], "c": ["d"], "d": ["c"]},
            [["a", "b", "a"], ["c", "d", "c"]],
        ),
        ({"a": ["c"], "b": ["a"], "c": ["b", "d"], "d": []}, [["a", "c", "b", "a"]]),
    ],
    ids=["empty", "dag", "self-loop", "two", "three-and-self", "two-components", "order"],
)
def test_cycle_finder_on_small_graphs(
    graph: dict[str, list[str]], expected: list[list[str]]
) -> None:
    assert find_cycles(graph) == expected


def test_cycle_check_fails_naming_the_cycle() -> None:
    check_acyclic({"p.a": ["p.b"], "p.b": ["p.c"], "p.c": []}, "p")
    message = r"import cycle\(s\) in p: p\.a -> p\.b -> p\.c -> p\.a"
    with pytest.raises(AssertionError, match=message):
        check_acyclic({"p.a": ["p.b"], "p.b": ["p.c"], "p.c": ["p.a"]}, "p")


def test_import_collector_counts_every_depth(tmp_path: Path) -> None:
    """A cycle closed only by a function-level and a TYPE_CHECKING import is still a cycle."""
    pkg = tmp_path / "pkg"
    pkg.mkdir()
    (pkg / "__init__.py").write_text("from pkg.a import A\n")
    (pkg / "a.py").write_text("from pkg import b\nA = 1\n")
    (pkg / "b.py").write_text("def f():\n    from pkg.c import C\n    return C\n")
    (pkg / "c.py").write_text(
        "from typing import TYPE_CHECKING\n\nif TYPE_CHECKING:\n    import pkg.a\nC = 2\n"
    )
    (pkg / "d.py").write_text("from . import c\nfrom .a import A\nimport os\nimport pkgx.a\n")
    (pkg / "e.py").write_text("class K:\n    def m(self):\n        from pkg import A\n")
    # A script's own import of itself under a __main__ guard is module __main__'s, not an edge;
    # the else branch of the guard runs on import and counts; so does a self-import elsewhere.
    (pkg / "f.py").write_text(
        "if __name__ == '__main__':\n    from pkg.f import g\nelse:\n    import pkg.d\n"
    )
    (pkg / "g.py").write_text("try:\n    from pkg.g import x\nexcept ImportError:\n    x = 0\n")
    graph = import_graph(pkg, "pkg")
    assert graph == {
        "pkg": {"pkg.a"},
        "pkg.a": {"pkg.b"},
        "pkg.b": {"pkg.c"},
        "pkg.c": {"pkg.a"},
        "pkg.d": {"pkg.a", "pkg.c"},
        "pkg.e": {"pkg"},
        "pkg.f": {"pkg.d"},
        "pkg.g": {"pkg.g"},
    }
    assert find_cycles(graph) == [["pkg.a", "pkg.b", "pkg.c", "pkg.a"], ["pkg.g", "pkg.g"]]


def test_sysid_core_has_no_import_cycle() -> None:
    graph = import_graph(CORE, "sysid_core")
    assert len(graph) >= 60  # every module of the package and its rooms was parsed
    assert "sysid_core.plugin.registry" in graph["sysid_core.run.pipeline"]  # the graph has edges
    check_acyclic(graph, "sysid_core")


# ====================================================================== rooms and their order
#: The rooms of sysid_core, lowest first: a module may import its own room and the rooms of
#: lower rank, never a room of the same rank (siblings) or a higher one. ``sysid_core``
#: itself (``__init__``, the facade) may import anything; ``_compat`` imports nothing;
#: ``_launch`` (imported first by the facade, the standard library only) neither.
ROOMS: dict[str, int] = {
    "_launch": 0,
    "errors": 0,
    "data": 1,
    "conic": 2,
    "model": 3,
    "identification": 4,
    "tuning": 4,
    "device": 4,
    "plugin": 5,
    "formats": 6,
    "clock": 6,
    "measure": 7,
    "drift": 8,
    "verdict": 9,
    "run": 10,
    "batch": 11,
    "api": 12,
    "testing": 12,
    "cli": 13,
    "_compat": 14,
}
#: Top-level modules besides ``__init__`` (the issue's limit: 6).
MAX_TOP_LEVEL = 6
MAX_MODULE_LINES = 400


def room_of(module: str) -> str | None:
    """The room of a ``sysid_core`` module (``None`` for the package itself)."""
    parts = module.split(".")
    return parts[1] if len(parts) > 1 else None


def layer_violations(graph: Mapping[str, Iterable[str]]) -> list[str]:
    """One line per import that goes up or sideways in :data:`ROOMS`, naming both ends."""
    found = []
    for module, targets in sorted(graph.items()):
        room = room_of(module)
        if room is None:
            continue
        for target in sorted(targets):
            other = room_of(target)
            if other is None or other == room:
                if other is None and room != "_compat":
                    found.append(f"{module} imports the package facade sysid_core")
                continue
            if ROOMS[other] >= ROOMS[room]:
                lower = [r for r, k in ROOMS.items() if k < ROOMS[room] and not r.startswith("_")]
                allowed = ", ".join(lower) or "nothing"
                found.append(
                    f"{module} imports {target}: the {room} room may import only {allowed}"
                )
    return found


def test_layer_check_names_the_offending_import() -> None:
    graph = {
        "sysid_core.device.simulation": {"sysid_core.tuning.criteria", "sysid_core.model.modal"},
        "sysid_core.model.fitted": {"sysid_core.data.schema"},
        "sysid_core.data.schema": {"sysid_core.run.config"},
    }
    assert layer_violations(graph) == [
        "sysid_core.data.schema imports sysid_core.run.config: the data room may import only "
        "errors",
        "sysid_core.device.simulation imports sysid_core.tuning.criteria: the device room may "
        "import only errors, data, conic, model",
    ]


def test_imports_flow_one_way_through_the_rooms() -> None:
    graph = import_graph(CORE, "sysid_core")
    assert {room_of(m) for m in graph} - {None} == set(ROOMS)  # every room is known
    problems = layer_violations(graph)
    assert not problems, "imports against the rooms' order:\n" + "\n".join(problems)


def test_the_core_imports_no_plugin() -> None:
    """Plugins stay plugins: no module of sysid_core names a plugin or device package."""
    offenders = []
    for name, path in module_names(CORE, "sysid_core").items():
        tree = ast.parse(path.read_text(encoding="utf-8"))
        for node in ast.walk(tree):
            mods = (
                [a.name for a in node.names]
                if isinstance(node, ast.Import)
                else [node.module or ""]
                if isinstance(node, ast.ImportFrom)
                else []
            )
            offenders += [
                f"{name} imports {m}"
                for m in mods
                if m.startswith("sysid_") and not m.startswith("sysid_core")
            ]
    assert not offenders, offenders


def test_rooms_sizes_and_docstrings() -> None:
    """At most six top-level modules, none over 400 lines, and every room says what it holds
    and what it may import."""
    top = sorted(p.stem for p in CORE.glob("*.py") if p.stem != "__init__")
    assert len(top) <= MAX_TOP_LEVEL, top
    long = {
        str(p.relative_to(CORE)): n
        for p in CORE.rglob("*.py")
        if (n := len(p.read_text(encoding="utf-8").splitlines())) > MAX_MODULE_LINES
    }
    assert not long, f"modules over {MAX_MODULE_LINES} lines: {long}"
    for init in CORE.glob("*/__init__.py"):
        doc = ast.get_docstring(ast.parse(init.read_text(encoding="utf-8"))) or ""
        if init.parent.name == "cli":
            continue  # the program's module: its docstring is the program's
        assert "Lives here" in doc and "May import" in doc, init


#: The one module that may look for optional attributes and methods on a device.
CAPABILITY_READER = "device/capabilities.py"


def device_probes(source: str) -> list[str]:
    """The ``getattr``/``hasattr`` calls in ``source`` whose object is a device."""
    found = []
    for node in ast.walk(ast.parse(source)):
        if (
            isinstance(node, ast.Call)
            and isinstance(node.func, ast.Name)
            and node.func.id in ("getattr", "hasattr")
            and node.args
        ):
            target = ast.unparse(node.args[0])
            if "device" in target.lower() or target in ("raw", "dev"):
                found.append(ast.unparse(node))
    return found


def test_the_probe_finder_sees_a_device_getattr() -> None:
    source = "x = getattr(self.device.device, 'tones', None)\ny = getattr(cfg, 'tones', 1)\n"
    assert device_probes(source) == ["getattr(self.device.device, 'tones', None)"]


def test_only_the_capability_reader_probes_a_device() -> None:
    """A device's optional capabilities and methods are read once, by ``device.capabilities``
    (the protocol check ``device.protocol.check_device`` looks for the required attributes)."""
    allowed = {CAPABILITY_READER, "device/protocol.py"}
    offenders = {
        str(p.relative_to(CORE)): probes
        for p in CORE.rglob("*.py")
        if str(p.relative_to(CORE)) not in allowed
        and (probes := device_probes(p.read_text(encoding="utf-8")))
    }
    assert not offenders, offenders


def test_defaults_agree_everywhere() -> None:
    """One set of defaults: the structures, fit(), the config's [model] and `sysid fit`."""
    import inspect

    from sysid_core.api import fit
    from sysid_core.cli.fit import fit_cmd
    from sysid_core.identification.objective import DEFAULT_OBJECTIVE, DEFAULT_SOLVER
    from sysid_core.model import structures
    from sysid_core.run.config import parse_config

    defaults = (structures.DEFAULT_ORDER, structures.DEFAULT_BIAS_TERMS)
    made = ActStructure()
    assert (made.order, made.bias_terms, made.stiffness) == (*defaults, "auto")
    model = parse_config({"device": {"name": "cloverleaf"}}).model
    assert (model.order, model.bias_terms, model.stiffness) == (*defaults, "auto")
    signature = inspect.signature(fit).parameters
    assert signature["order"].default == structures.DEFAULT_ORDER
    assert signature["objective"].default == DEFAULT_OBJECTIVE
    assert signature["solver"].default == DEFAULT_SOLVER
    cli = inspect.signature(fit_cmd).parameters
    for name, value in [
        ("order", structures.DEFAULT_ORDER),
        ("bias_terms", structures.DEFAULT_BIAS_TERMS),
        ("stiffness", structures.DEFAULT_STIFFNESS),
        ("objective", DEFAULT_OBJECTIVE),
        ("solver", DEFAULT_SOLVER),
    ]:
        assert cli[name].default == value, name


# ============================================================= cvxpy is for the tests only
def _python(code: str, cwd: Path) -> dict[str, Any]:
    """Run ``code`` in a fresh interpreter (every built-in plugin, none of the tests'); the
    last line it prints is JSON."""
    env = dict(os.environ)
    env.pop("SYSID_DISABLE_PLUGIN_AUTOLOAD", None)
    env["MPLBACKEND"] = "Agg"
    done = subprocess.run(
        [sys.executable, "-c", code],
        cwd=cwd,
        env=env,
        capture_output=True,
        text=True,
        timeout=300,
        check=False,
    )
    assert done.returncode == 0, done.stderr[-3000:]
    return json.loads(done.stdout.strip().splitlines()[-1])


def test_cvxpy_is_installed_for_these_checks() -> None:
    # Otherwise the two checks below would pass for the wrong reason.
    assert importlib.util.find_spec("cvxpy") is not None


def test_import_sysid_core_does_not_import_cvxpy(tmp_path: Path) -> None:
    code = (
        "import json, sys\n"
        "import sysid_core\n"
        "print(json.dumps({'cvxpy': 'cvxpy' in sys.modules, 'core': 'sysid_core' in sys.modules}))"
    )
    assert _python(code, tmp_path) == {"cvxpy": False, "core": True}


def test_readme_tune_does_not_import_cvxpy(tmp_path: Path) -> None:
    """``sysid tune examples/cloverleaf-2electrode.toml`` end to end (about 5 s)."""
    out = tmp_path / "run"
    code = (
        "import json, sys\n"
        "from sysid_core.cli import main\n"
        f"code = main(['tune', {str(README_EXAMPLE)!r}, '--out', {str(out)!r}, '--no-plots'])\n"
        "print(json.dumps({'code': code, 'cvxpy': 'cvxpy' in sys.modules}))"
    )
    assert _python(code, ROOT) == {"code": 0, "cvxpy": False}
    summary = json.loads((out / "summary.json").read_text())
    assert summary["converged"] is True
    assert (out / "iter01" / "model.nc").exists()


# ======================================================== components from the run's registry
class MarginCriterion(Degenerate):
    """A third party's criterion with an option of its own (``margin``); tunes like degenerate."""

    name: ClassVar[str] = "test-margin"
    description: ClassVar[str] = "degenerate modes, with a margin option"
    solved: ClassVar[list[MarginCriterion]] = []

    def __init__(self, *, solver: Solver, margin: float = 0.0, tolerance_hz: float = 1e-3) -> None:
        super().__init__(solver=solver, tolerance_hz=tolerance_hz)
        self.margin = margin

    def solve(self, model: FittedModel, space: BiasSpace) -> TuningResult:
        MarginCriterion.solved.append(self)
        return super().solve(model, space)


class _ThirdPartyCriterion:
    @hookimpl
    def sysid_tuning_criteria(self):
        return {MarginCriterion.name: MarginCriterion}


BUILTIN_PLUGINS = {
    "models": sysid_models.plugin,
    "objectives": sysid_objectives.plugin,
    "solvers": sysid_solvers.plugin,
    "criteria": sysid_criteria.plugin,
    "cloverleaf": sysid_cloverleaf.plugin,
}


def builtins_and_margin() -> Registry:
    """The built-in plugin modules registered by hand, and the third-party criterion."""
    registry = Registry(autoload=False)
    for name, module in BUILTIN_PLUGINS.items():
        registry.register(module, name=name)
    registry.register(_ThirdPartyCriterion(), name="margin-criterion", distribution="tests")
    return registry


MARGIN_CONFIG = """
[device]
name = "{device}"

[model]
structure = "act"
order = 1
stiffness = "linear"

[solver]
name = "clarabel"
tol_gap_rel = 1e-9

[tuning]
criterion = "test-margin"
electrodes = ["B1", "B2"]
start_bias = [0.0, 0.0, 0.0]
max_iterations = {max_iterations}

[tuning.options]
{option} = 0.25

[experiment]
resolution_hz = 1.0
verify_resolution_hz = 0.02
"""


def margin_config(
    tmp_path: Path, device: str = "cloverleaf", option: str = "margin", max_iterations: int = 4
) -> Path:
    """A configuration file choosing the third-party criterion, with the reduced sweeps."""
    path = tmp_path / "margin.toml"
    text = MARGIN_CONFIG.format(device=device, option=option, max_iterations=max_iterations)
    path.write_text(text)
    return path


def test_criterion_and_solver_options_from_the_file_reach_the_components(tmp_path: Path) -> None:
    cfg = load_config(margin_config(tmp_path))
    run = TuningRun(cfg, tmp_path / "out", registry=builtins_and_margin(), plots=False)
    assert isinstance(run.criterion, MarginCriterion)
    assert run.criterion.margin == 0.25
    assert run.criterion.solver is run.solver  # the run's solver, with the [solver] options
    assert isinstance(run.solver, ClarabelSolver)
    assert run.solver.options["tol_gap_rel"] == 1e-9
    assert run.measurements == 0  # building a run measures nothing ...
    assert not (tmp_path / "out").exists()  # ... and writes nothing


def test_unknown_criterion_option_is_a_config_error_naming_it(tmp_path: Path) -> None:
    path = margin_config(tmp_path, option="marginn")
    with pytest.raises(ConfigError, match=r"'marginn'.*'test-margin'"):
        TuningRun(load_config(path), tmp_path / "out", registry=builtins_and_margin())


# ------------------------------------------------------------------ no global registry
class ArchCloverleaf(CloverleafGyro):
    """The cloverleaf under a name that only the test registry provides; records its work."""

    name: ClassVar[str] = "arch-cloverleaf"
    instances: ClassVar[list[ArchCloverleaf]] = []

    def __init__(self, **options: Any) -> None:
        super().__init__(**options)
        self.calls = 0
        ArchCloverleaf.instances.append(self)

    def measure(self, bias, frequencies_hz) -> xr.DataArray:
        self.calls += 1
        return super().measure(bias, frequencies_hz)


class _OnlyTestPlugins:
    """Every component of a run from one test plugin (the global registry has no arch-*)."""

    @hookimpl
    def sysid_devices(self):
        return {ArchCloverleaf.name: ArchCloverleaf}

    @hookimpl
    def sysid_model_structures(self):
        return {"act": ActStructure}

    @hookimpl
    def sysid_objectives(self):
        return {"minimax": Minimax, "least-squares": LeastSquares}

    @hookimpl
    def sysid_solvers(self):
        return {"clarabel": ClarabelSolver}

    @hookimpl
    def sysid_tuning_criteria(self):
        return {MarginCriterion.name: MarginCriterion}


def _modules_importing_get_registry() -> list[str]:
    """The core's modules that bind ``get_registry`` at import time (grep, by ``ast``)."""
    found = []
    for name, path in module_names(CORE, "sysid_core").items():
        tree = ast.parse(path.read_text(encoding="utf-8"))
        for node in tree.body:
            if isinstance(node, ast.ImportFrom) and any(
                a.name == "get_registry" for a in node.names
            ):
                found.append(name)
    return found


@pytest.fixture
def no_global_registry(monkeypatch: pytest.MonkeyPatch) -> list[str]:
    """Every way to the process-wide registry fails the test (and is recorded).

    ``get_registry`` is replaced in ``sysid_core.plugin.registry`` (function-level imports find it
    there) and in every loaded module that imported it by name; ``_REGISTRY`` becomes an object
    that fails on any use; loading entry points (what a new default ``Registry()`` does) fails.
    """
    calls: list[str] = []

    def fail(what: str) -> None:
        calls.append(what)
        pytest.fail(f"{what}: the run used the process-wide registry", pytrace=True)

    class Poison:
        def __getattr__(self, attribute: str) -> Any:
            fail(f"_REGISTRY.{attribute}")

    original = sysid_core.plugin.registry.get_registry
    importers = _modules_importing_get_registry()
    assert {"sysid_core", "sysid_core.api"} <= set(importers)
    for name in importers:
        importlib.import_module(name)
    patched = []
    for name, module in list(sys.modules.items()):
        if not name.startswith("sysid") or module is None:
            continue
        for attribute, value in list(vars(module).items()):
            if value is original:
                monkeypatch.setattr(module, attribute, lambda: fail("get_registry()"))
                patched.append(f"{name}.{attribute}")
    assert set(importers) <= {p.rsplit(".", 1)[0] for p in patched}
    monkeypatch.setattr(sysid_core.plugin.registry, "_REGISTRY", Poison())
    monkeypatch.setattr(
        Registry, "load_entry_points", lambda self, eps: fail("Registry.load_entry_points()")
    )
    return calls


def test_run_with_its_own_registry_uses_no_global(
    tmp_path: Path, no_global_registry: list[str]
) -> None:
    registry = Registry(autoload=False)
    registry.register(_OnlyTestPlugins(), name="only-test-plugins", distribution="tests")
    cfg = load_config(margin_config(tmp_path, device=ArchCloverleaf.name, max_iterations=1))
    ArchCloverleaf.instances.clear()
    MarginCriterion.solved.clear()

    run = TuningRun(cfg, tmp_path / "out", registry=registry, plots=False)
    summary = run.run()

    assert isinstance(summary, RunSummary) and summary.iterations == 1
    assert summary.experiments >= 3
    assert [d.calls > 0 for d in ArchCloverleaf.instances] == [True]  # built by the registry
    assert MarginCriterion.solved == [run.criterion]  # its criterion tuned
    assert np.all(np.abs(summary.bias) <= 10.0)
    assert no_global_registry == []


# ============================================================= public import paths
def documented_paths() -> list[tuple[str, list[str]]]:
    """The table of ``docs/contracts.md``'s "Python import paths": ``(path, names)`` rows."""
    text = (ROOT / "docs" / "contracts.md").read_text(encoding="utf-8")
    section = text.split("## Python import paths", 1)[1].split("\n## ", 1)[0]
    rows = []
    for line in section.splitlines():
        cells = [c.strip() for c in line.strip().strip("|").split("|")]
        if len(cells) == 2 and cells[0].startswith("`sysid_core"):
            names = [n.strip().strip("`") for n in cells[1].split(",")]
            rows.append((cells[0].strip("`"), names))
    return rows


def test_every_documented_import_path_imports() -> None:
    rows = documented_paths()
    assert len(rows) >= 25 and rows[0][0] == "sysid_core"
    missing = []
    for path, names in rows:
        module = importlib.import_module(path)
        missing += [f"{path}.{n}" for n in names if not hasattr(module, n)]
    assert not missing, missing
    # the package's __all__ is documented whole
    assert set(sysid_core.__all__) <= set(rows[0][1])
    assert {"RunSummary", "TuningResult", "PipelineConfig"} <= set(sysid_core.__all__)


def test_hookspec_is_the_marker_whatever_is_imported_first() -> None:
    """``sysid_core.hookspec`` is the hook marker; no module of that name rebinds it."""
    code = (
        "import warnings; warnings.simplefilter('ignore', DeprecationWarning)\n"
        "from sysid_core.hookspec import hookimpl as old\n"  # the 0.1 module path, first
        "import pluggy, sysid_core, json\n"
        "from sysid_core import hookspec, hookimpl\n"
        "print(json.dumps([isinstance(hookspec, pluggy.HookspecMarker), old is hookimpl]))"
    )
    assert _python(code, ROOT) == [True, True]


@pytest.mark.parametrize("old", sorted(sysid_core._compat.MOVED))
def test_an_old_module_path_warns_and_forwards(old: str) -> None:
    """Every module path of release 0.1 that moved still gives the same objects, warning."""
    new = importlib.import_module(f"sysid_core.{sysid_core._compat.MOVED[old]}")
    shim = importlib.import_module(f"sysid_core.{old}")
    public = getattr(new, "__all__", None) or [
        n
        for n, v in vars(new).items()
        if not n.startswith("_") and getattr(v, "__module__", None) == new.__name__
    ]
    assert public, new
    name = public[0]
    with pytest.warns(DeprecationWarning, match=rf"sysid_core\.{old} moved to sysid_core\."):
        value = getattr(shim, name)
    assert value is getattr(new, name)


def test_names_that_left_their_module_forward_to_their_new_home() -> None:
    from sysid_core.api import load_model
    from sysid_core.conic.program import sigma_max_2x2
    from sysid_core.identification.fitting import check_fit
    from sysid_core.model.structures import DEFAULT_ORDER

    with pytest.warns(DeprecationWarning, match="sysid_core.identification.fitting"):
        from sysid_core.fit import check_fit as old_check
    with pytest.warns(DeprecationWarning, match="sysid_core.api"):
        from sysid_core.fit import load_model as old_load
    with pytest.warns(DeprecationWarning, match="sysid_core.conic.program"):
        from sysid_core.problem import sigma_max_2x2 as old_sigma
    with pytest.warns(DeprecationWarning, match="sysid_core.model.structures"):
        from sysid_core.config import DEFAULT_ORDER as old_order
    assert (old_check, old_load, old_sigma, old_order) == (
        check_fit,
        load_model,
        sigma_max_2x2,
        DEFAULT_ORDER,
    )


def test_tests_mirror_the_rooms() -> None:
    """``tests/<room>/`` holds the tests of each room that has its own; at the top only the
    tests of the whole (architecture, docs, the documentation site) and the shared helpers."""
    tests = ROOT / "tests"
    rooms = {p.name for p in tests.iterdir() if p.is_dir() and p.name in ROOMS}
    assert rooms >= {"data", "formats", "model", "identification", "tuning", "device", "plugin"}
    assert rooms >= {"clock", "measure", "drift", "verdict", "run"}
    assert rooms >= {"batch", "cli"}
    for room in rooms:
        assert list((tests / room).glob("test_*.py")), room
    top = sorted(p.name for p in tests.glob("test_*.py"))
    assert top == ["test_architecture.py", "test_docs.py", "test_site.py"], top
    names = [p.name for p in tests.rglob("test_*.py") if "plugins" not in p.parts]
    assert len(names) == len(set(names)), "test file names must be unique (pytest's rootdir)"
