"""The tutorial notebook runs from top to bottom and reaches the simulated gyro's exact answer.

``docs/tutorials/measured-to-tuned.ipynb`` is executed with nbclient (a fresh ipykernel kernel,
this environment's Python) in a temporary folder, as a user would run it. A last cell, added
here and not stored in the notebook, reports the notebook's own results, which must hold:

* the predicted bias's 95 % region holds the exact degenerate bias of the simulated gyro;
* the simulated ``tune`` converged, with its measured split under the acceptance and the true
  split at its final bias under it too, within 1 mV of the exact bias on each electrode;
* the Bode plots and the bias path were drawn (three PNG outputs).

The notebook is stored without outputs (checked too), so that the repository stays small.
"""

from __future__ import annotations

import json
from pathlib import Path

import nbformat
import pytest
from nbclient import NotebookClient

ROOT = Path(__file__).resolve().parents[1]
NOTEBOOK = ROOT / "docs" / "tutorials" / "measured-to-tuned.ipynb"

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
    monkeypatch.setenv("JUPYTER_PLATFORM_DIRS", "1")
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
