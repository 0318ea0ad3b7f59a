"""The documentation site builds with ``mkdocs build --strict`` (the README's command), and its
tutorial notebook runs from top to bottom to the simulated gyro's exact answer.

The site:

* The build succeeds and prints no warning. Strict mode fails on a broken link or anchor, a page
  missing from the navigation, a docstring griffe cannot match to its signature, a docstring role
  that names nothing (``docs/hooks/sphinx_roles.py``), a cross-reference without a target, a
  notebook link to no page (``docs/hooks/notebook_links.py``) and a tutorial cell that fails.
* The built pages hold what they should: the API page of ``sysid_core.api`` with an entry for
  each function and working links between entries, the tutorial with its plots and its run's
  result (the build executed it).
* Every public module of ``sysid_core`` is documented on a page of ``docs/api/``.
* The docstring-role extension links what resolves and reports what does not (on a small
  package written here).

The tutorial, ``docs/tutorials/measured-to-tuned.ipynb``, is executed with nbclient (a fresh
ipykernel kernel, this environment's Python) in a temporary folder, as a user would run it. A
last cell, added here and not stored in the notebook, reports the notebook's own results, which
must hold:

* the predicted bias's 95 % region holds the exact degenerate bias of the simulated gyro;
* the simulated ``tune`` converged, with its measured split under the acceptance and the true
  split at its final bias under it too, within 1 mV of the exact bias on each electrode;
* the Bode plots and the bias path were drawn (three PNG outputs).

The notebook is stored without outputs (checked too), so that the repository stays small.
"""

from __future__ import annotations

import json
import logging
import os
import re
import subprocess
import sys
from pathlib import Path

import griffe
import nbformat
import pytest
from nbclient import NotebookClient

ROOT = Path(__file__).resolve().parents[1]
HOOKS = ROOT / "docs" / "hooks"
NOTEBOOK = ROOT / "docs" / "tutorials" / "measured-to-tuned.ipynb"


@pytest.fixture(scope="module")
def site(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """The site, built once by ``mkdocs build --strict`` (about 15 s with the tutorial run)."""
    out = tmp_path_factory.mktemp("site")
    env = dict(os.environ)
    env["TMPDIR"] = str(out.parent)  # where the tutorial writes its files
    env["NO_MKDOCS_2_WARNING"] = "1"  # the theme's notice about its end of life
    env.pop("SYSID_DOCS_EXECUTE", None)
    done = subprocess.run(
        [sys.executable, "-m", "mkdocs", "build", "--strict", "--site-dir", str(out / "site")],
        cwd=ROOT,
        env=env,
        capture_output=True,
        text=True,
        timeout=600,
    )
    log = done.stdout + done.stderr
    assert done.returncode == 0, log
    warnings = [line for line in log.splitlines() if "WARNING" in line and "Kernel" not in line]
    assert not warnings, "\n".join(warnings)
    return out / "site"


def test_the_api_page_documents_the_functions(site: Path) -> None:
    page = (site / "api" / "api" / "index.html").read_text()
    for name in ("fit", "tune", "predict_bias", "load_model"):
        assert f'id="sysid_core.api.{name}"' in page, name
    # the docstrings' roles became links to the entries (here: the module's summary of them)
    assert 'href="#sysid_core.api.predict_bias"' in page
    # a reference into another page, from predict_bias's Returns section
    assert re.search(r'href="\.\./tuning/#sysid_core\.tuning\.criteria\.ConfidenceRegion"', page)
    assert ":func:" not in page and ":class:" not in page


def test_the_tutorial_page_shows_its_run(site: Path) -> None:
    page = (site / "tutorials" / "measured-to-tuned" / "index.html").read_text()
    assert page.count('src="data:image/png;base64,') >= 3  # the two Bode plots, the bias path
    assert "inside the 95 % region: True" in page
    assert "converged after" in page
    assert 'href="../../measured-data/"' in page  # its links point to the site's pages
    assert "measured-data.md" not in page.replace("measured-data.md)", "")


def test_every_public_module_is_on_an_api_page() -> None:
    named = set()
    for page in (ROOT / "docs" / "api").glob("*.md"):
        named |= set(re.findall(r"^::: (sysid_core[\w.]*)", page.read_text(), re.MULTILINE))
    core = ROOT / "sysid_core"
    modules = set()
    for path in core.rglob("*.py"):
        parts = path.relative_to(ROOT).with_suffix("").parts
        if parts[-1] in ("__init__", "__main__"):
            parts = parts[:-1]
        if not any(p.startswith("_") for p in parts):
            modules.add(".".join(parts))
    assert not modules - named, f"modules on no page of docs/api/: {sorted(modules - named)}"
    assert not named - modules, f"docs/api/ names modules that do not exist: {named - modules}"


def _load(tmp_path: Path, source: str) -> griffe.Object:
    """Load a package ``demo`` (``source`` as its ``__init__``) through the extension."""
    sys.path.insert(0, str(HOOKS))
    try:
        from sphinx_roles import SphinxRoles
    finally:
        sys.path.remove(str(HOOKS))
    (tmp_path / "demo").mkdir()
    (tmp_path / "demo" / "__init__.py").write_text(source)
    (tmp_path / "demo" / "tools.py").write_text('def helper():\n    """Helps."""\n')
    return griffe.load(
        "demo",
        search_paths=[str(tmp_path)],
        extensions=griffe.load_extensions(SphinxRoles(packages=["demo"])),
    )


def test_roles_become_links_and_unknown_names_are_reported(
    tmp_path: Path, caplog: pytest.LogCaptureFixture
) -> None:
    source = '''r"""Demo: :func:`~demo.tools.helper`, :mod:`.tools`, :class:`xarray.Dataset`,
:exc:`ValueError`, :func:`run`, :func:`missing` and :mod:`demo.gone`.

Literal block::

    code

The law :math:`w = v^2`:

.. math::

    Z = K - M \\omega^2
"""


def run():
    """Runs."""
'''
    with caplog.at_level(logging.WARNING):
        pkg = _load(tmp_path, source)
    warnings = [r.getMessage() for r in caplog.records if r.levelno >= logging.WARNING]
    assert pkg.docstring is not None
    text = pkg.docstring.value
    assert "[`helper`][demo.tools.helper]" in text
    assert "[`.tools`][demo.tools]" in text
    assert "[`run`][demo.run]" in text
    assert "`xarray.Dataset`" in text and "[`xarray.Dataset`]" not in text  # another library
    assert "`ValueError`" in text and "[`ValueError`]" not in text  # a builtin
    assert "Literal block:\n\n    code" in text
    assert "The law `w = v^2`:" in text
    assert "```latex\nZ = K - M \\omega^2\n```" in text
    assert len(warnings) == 2, warnings
    assert "'missing'" in warnings[0] and "'demo.gone'" in warnings[1]


# ===================================================================== the tutorial
# Runs in the notebook's kernel after its last cell: the names are the notebook's.
REPORT = """
import json
print("REPORT " + json.dumps({
    "bias_ci": [list(map(float, ci)) for ci in region.bias_ci],
    "exact": [float(x) for x in exact],
    "converged": bool(result.converged),
    "split_hz": result.split_hz,
    "acceptance_hz": config["tuning"]["acceptance_hz"],
    "final": [float(x) for x in result.bias[:2]],
    "true_split_hz": float(gyro.truth.split_hz(list(result.bias))),
    "work": str(work),
}))
"""


def test_the_notebook_is_stored_without_outputs() -> None:
    nb = nbformat.read(NOTEBOOK, as_version=4)
    code = [c for c in nb.cells if c.cell_type == "code"]
    assert code
    dirty = [i for i, c in enumerate(code) if c.outputs or c.execution_count is not None]
    assert not dirty, f"code cells {dirty} have outputs: clear them before committing"


def test_the_tutorial_runs_and_reaches_the_exact_answer(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.setenv("TMPDIR", str(tmp_path))  # the notebook's `work` folder goes here
    nb = nbformat.read(NOTEBOOK, as_version=4)
    nb.cells.append(nbformat.v4.new_code_cell(REPORT))
    NotebookClient(
        nb, timeout=300, kernel_name="python3", resources={"metadata": {"path": str(tmp_path)}}
    ).execute()

    images = sum(
        "image/png" in out.get("data", {}) for cell in nb.cells for out in cell.get("outputs", [])
    )
    assert images == 3, "the two Bode plots and the bias path"
    text = "".join(out.get("text", "") for out in nb.cells[-1].outputs)
    report = json.loads(text.split("REPORT ", 1)[1])

    assert Path(report["work"]).parent == tmp_path
    for exact, (low, high) in zip(report["exact"], report["bias_ci"], strict=True):
        assert low <= exact <= high, (exact, low, high)
    assert report["converged"]
    assert report["split_hz"] <= report["acceptance_hz"]
    assert report["true_split_hz"] <= report["acceptance_hz"]
    for final, exact in zip(report["final"], report["exact"], strict=True):
        assert abs(final - exact) < 1e-3, (final, exact)
