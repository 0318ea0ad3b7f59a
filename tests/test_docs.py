"""Every command and snippet in the README and the docs runs as written.

Fenced blocks are collected from ``README.md``, ``docs/**/*.md`` and ``benchmarks/README.md``:

* ``bash`` / ``sh``: each command line runs in a shell, in a folder holding a copy of
  ``examples/`` (where the snippets expect it), with this environment's ``sysid`` and ``python``
  first on ``PATH`` (and standing for ``.venv/bin/sysid``, ``.venv/bin/python``, which the
  README's install step makes); it must exit with status 0;
* ``python``: the block runs as a script in such a folder;
* ``toml``: the block must parse; a configuration (one with a ``[device]`` table) must validate
  and its components must build, every plugin option checked;
* ``text``, ``mermaid`` and other languages are shown, not run (synopses with placeholders).

A block may be marked on the line before it: ``<!-- docs-test: slow -->`` runs it only with
``-m slow``; ``<!-- docs-test: skip (reason) -->`` never runs it, and must give the reason.
"""

from __future__ import annotations

import os
import re
import shutil
import subprocess
import sys
import tomllib
from dataclasses import dataclass
from pathlib import Path

import pytest
from installing import environment

from sysid_core.plugin.registry import get_registry
from sysid_core.run.components import build_components
from sysid_core.run.config import parse_config

ROOT = Path(__file__).resolve().parents[1]
FILES = sorted(
    [ROOT / "README.md", ROOT / "benchmarks" / "README.md", *(ROOT / "docs").rglob("*.md")]
)
RUN = {"bash", "sh", "python", "toml"}
MARK = re.compile(r"<!--\s*docs-test:\s*(slow|skip)\s*(\((.+)\))?\s*-->")


@dataclass(frozen=True)
class Block:
    path: Path
    line: int
    lang: str
    text: str
    mark: str | None
    reason: str | None

    @property
    def id(self) -> str:
        return f"{self.path.relative_to(ROOT)}:{self.line}"


def blocks() -> list[Block]:
    found = []
    for path in FILES:
        lines = path.read_text().splitlines()
        i = 0
        while i < len(lines):
            if lines[i].startswith("```"):
                lang = lines[i][3:].strip()
                j = i + 1
                while j < len(lines) and not lines[j].startswith("```"):
                    j += 1
                mark = MARK.search(lines[i - 1]) if i > 0 else None
                found.append(
                    Block(
                        path,
                        i + 1,
                        lang,
                        "\n".join(lines[i + 1 : j]),
                        mark.group(1) if mark else None,
                        mark.group(3) if mark else None,
                    )
                )
                i = j
            i += 1
    return found


ALL = blocks()
RUNNABLE = [b for b in ALL if b.lang in RUN]


def _param(b: Block) -> object:
    marks = [pytest.mark.slow] if b.mark == "slow" else []
    return pytest.param(b, id=b.id, marks=marks)


@pytest.fixture
def sandbox(tmp_path: Path) -> Path:
    shutil.copytree(ROOT / "examples", tmp_path / "examples")
    shutil.copytree(ROOT / "benchmarks", tmp_path / "benchmarks")
    shutil.copytree(ROOT / "tests", tmp_path / "tests", ignore=shutil.ignore_patterns("plugins"))
    shutil.copytree(ROOT / "docs" / "examples", tmp_path / "docs" / "examples")
    return tmp_path


def _env() -> dict[str, str]:
    env = environment()
    env["PATH"] = os.pathsep.join([str(Path(sys.executable).parent), env.get("PATH", "")])
    env["MPLBACKEND"] = "Agg"
    return env


def test_every_block_says_how_it_is_checked() -> None:
    unlabelled = [b.id for b in ALL if not b.lang]
    assert not unlabelled, f"fenced blocks without a language (use text for synopses): {unlabelled}"
    no_reason = [b.id for b in ALL if b.mark == "skip" and not b.reason]
    assert not no_reason, f"docs-test: skip needs a reason: {no_reason}"
    assert len(RUNNABLE) >= 10  # the collector found the docs' examples


@pytest.mark.parametrize("block", [_param(b) for b in RUNNABLE if b.mark != "skip"])
def test_block_runs_as_written(
    block: Block, sandbox: Path, example_plugin: Path, faulty_plugin: Path
) -> None:
    if block.lang == "toml":
        data = tomllib.loads(block.text)
        if "device" in data:
            cfg = parse_config(data, block.id)
            build_components(cfg, get_registry())
        return
    if block.lang == "python":
        command = [sys.executable, "-c", block.text]
    else:  # `.venv/bin/x`: the README's install step made it; here it is this environment's x
        command = ["bash", "-e", "-o", "pipefail", "-c", block.text.replace(".venv/bin/", "")]
    done = subprocess.run(
        command, cwd=sandbox, env=_env(), capture_output=True, text=True, timeout=1800
    )
    assert done.returncode == 0, (
        f"{block.id}:\n{block.text}\n--- stdout\n{done.stdout}\n--- stderr\n{done.stderr}"
    )


def test_the_main_job_runs(sandbox: Path) -> None:
    """The README's first command, after its install step: tune the cloverleaf end to end."""
    first = next(b for b in ALL if b.path.name == "README.md" and b.lang == "bash")
    tune = first.text.split("&& .venv/bin/", 2)[-1]
    assert tune.startswith("sysid tune examples/"), tune
    done = subprocess.run(
        ["bash", "-c", tune], cwd=sandbox, env=_env(), capture_output=True, text=True, timeout=600
    )
    assert done.returncode == 0, done.stderr
    assert (sandbox / "runs" / "cloverleaf" / "bias_path.png").exists()
