"""A format added from a third party's package is read and written like a built-in one.

The example in docs/examples/sysid-example-format (sweeps in numpy ``.npz`` archives) is
pip-installed like a third party's package (``tests/installing.py``); every check runs in a
subprocess, as a user's program would: the registry lists it, ``read_sweep``/``write_sweep``
round-trip a sweep exactly, a manifest of ``.npz`` files loads into the same data set as its CSV
twin, ``export_dataset(format="npz")`` writes one, and a broken archive is refused in one line.
"""

from __future__ import annotations

import json
from pathlib import Path

import pytest
from installing import run_python
from truths import cloverleaf_truth, simulate

from sysid_core.data.schema import save_dataset
from sysid_core.formats.engine import format_names

DISTRIBUTION = "sysid-example-format"


@pytest.fixture(scope="module")
def installed(example_format: Path) -> None:
    """The example format package, installed for this session only (see conftest.py)."""


def test_the_built_in_engines_are_registered_as_plugins() -> None:
    assert set(format_names()) >= {"csv", "touchstone", "mat", "netcdf", "columns"}
    assert set(format_names(writes=True)) >= {"csv", "touchstone", "mat", "netcdf"}
    assert "columns" not in format_names(writes=True)


def test_the_registry_lists_the_format_with_its_distribution(installed: None) -> None:
    out = run_python(
        "import json\n"
        "from sysid_core.plugin.registry import Registry\n"
        "from sysid_core.formats.engine import sweep_extensions\n"
        "c = Registry().get('response format', 'npz')\n"
        "print(json.dumps([c.distribution, c.plugin, list(sweep_extensions())]))\n"
    )
    distribution, plugin, extensions = json.loads(out)
    assert (distribution, plugin) == (DISTRIBUTION, "example-npz")
    assert extensions[:4] == [".csv", ".s2p", ".mat", ".nc"] and ".npz" in extensions


def test_a_sweep_round_trips_through_the_format(installed: None, tmp_path: Path) -> None:
    out = run_python(
        "import numpy as np\n"
        "from sysid_core.data.sweep import make_sweep\n"
        "from sysid_core.formats.sweepfiles import read_sweep, write_sweep\n"
        "rng = np.random.default_rng(4)\n"
        "f = np.linspace(4300.0, 4500.0, 37)\n"
        "r = rng.normal(size=(37, 2, 2)) + 1j * rng.normal(size=(37, 2, 2))\n"
        "t = 10.0 + np.arange(37.0)\n"
        f"path = write_sweep({str(tmp_path / 'a.npz')!r}, make_sweep(f, r, time_s=t), 'V/V')\n"
        "back = read_sweep(path)\n"
        "print(np.array_equal(back.values, r), np.array_equal(back['frequency'].values, f),\n"
        "      np.array_equal(back['time_s'].values, t), back.attrs['units'])\n"
    )
    assert out.split() == ["True", "True", "True", "V/V"]


def test_a_manifest_of_its_files_loads_as_its_csv_twin(installed: None, tmp_path: Path) -> None:
    save_dataset(simulate(cloverleaf_truth(), noise_rel=1e-3, seed=3), tmp_path / "data.nc")
    out = run_python(
        "import numpy as np\n"
        "from sysid_core.data.schema import load_dataset\n"
        "from sysid_core.formats.manifest import export_dataset, load_manifest\n"
        f"ds = load_dataset({str(tmp_path / 'data.nc')!r})\n"
        f"a = load_manifest(export_dataset(ds, {str(tmp_path / 'npz')!r}, format='npz'))\n"
        f"b = load_manifest(export_dataset(ds, {str(tmp_path / 'csv')!r}, format='csv'))\n"
        "print(np.array_equal(a['response'].values, b['response'].values),\n"
        "      np.array_equal(a['response'].values, ds['response'].values),\n"
        "      np.array_equal(a['bias'].values, b['bias'].values))\n"
    )
    assert out.split() == ["True", "True", "True"]
    assert sorted(p.name for p in (tmp_path / "npz").iterdir())[:2] == ["exp0.npz", "exp1.npz"]


def test_a_broken_archive_is_one_line_naming_the_file(installed: None, tmp_path: Path) -> None:
    (tmp_path / "bad.npz").write_bytes(b"not a zip archive")
    out = run_python(
        "from sysid_core.errors import FileFormatError\n"
        "from sysid_core.formats.sweepfiles import read_sweep\n"
        "try:\n"
        f"    read_sweep({str(tmp_path / 'bad.npz')!r})\n"
        "except FileFormatError as exc:\n"
        "    print(exc)\n"
    )
    assert "bad.npz: not a numpy .npz archive" in out and len(out.splitlines()) == 1
