"""Plugin discovery: entry points, broken plugins, unknown names."""

from __future__ import annotations

import importlib.metadata as md
import sys
import types

import pytest

from sysid_core import errors, hookimpl
from sysid_core.plugin.registry import PluginLoadWarning, Registry


def _ep(name: str, value: str) -> md.EntryPoint:
    return md.EntryPoint(name=name, value=value, group="sysid")


def test_builtins_are_entry_point_plugins():
    reg = Registry(autoload=True)
    assert set(reg.names("model structure")) >= {"act", "sen"}
    assert set(reg.names("solver")) >= {"clarabel", "scs"}
    assert set(reg.names("objective")) >= {"minimax", "least-squares"}
    assert reg.get("solver", "clarabel").distribution == "sysid-toolkit"


def test_broken_plugin_warns_and_the_rest_works():
    reg = Registry(autoload=False)
    with pytest.warns(PluginLoadWarning, match='"broken".*ModuleNotFoundError'):
        reg.load_entry_points(
            [_ep("broken", "no_such_module_xyz.plugin"), _ep("models", "sysid_models.plugin")]
        )
    assert reg.names("model structure") == ["act", "sen"]
    assert reg.failures and "broken" in reg.failures[0][1]


def test_unknown_name_lists_installed():
    reg = Registry(autoload=False)
    reg.load_entry_points([_ep("solvers", "sysid_solvers.plugin")])
    with pytest.raises(errors.PluginNotFoundError, match="installed: clarabel, scs"):
        reg.get("solver", "mosek")
    with pytest.raises(LookupError):
        reg.get("solver", "mosek")


def test_third_party_module_registers_like_builtin(monkeypatch):
    mod = types.ModuleType("fake_sysid_plugin")

    class Dummy:
        """A dummy device."""

    @hookimpl
    def sysid_devices():
        return {"dummy": Dummy}

    mod.sysid_devices = sysid_devices
    monkeypatch.setitem(sys.modules, "fake_sysid_plugin", mod)
    reg = Registry(autoload=False)
    reg.load_entry_points([_ep("fake", "fake_sysid_plugin")])
    comp = reg.get("device", "dummy")
    assert comp.factory is Dummy and comp.plugin == "fake"
    assert comp.description == "A dummy device."


def test_hook_that_raises_is_a_warning(monkeypatch):
    mod = types.ModuleType("bad_hook_plugin")

    @hookimpl
    def sysid_solvers():
        raise RuntimeError("no licence")

    mod.sysid_solvers = sysid_solvers
    monkeypatch.setitem(sys.modules, "bad_hook_plugin", mod)
    reg = Registry(autoload=False)
    reg.load_entry_points([_ep("bad", "bad_hook_plugin"), _ep("solvers", "sysid_solvers.plugin")])
    with pytest.warns(PluginLoadWarning, match="no licence"):
        names = reg.names("solver")
    assert names == ["clarabel", "scs"]


def test_duplicate_names_are_an_error(monkeypatch):
    mod = types.ModuleType("dup_plugin")

    @hookimpl
    def sysid_solvers():
        return {"scs": object}

    mod.sysid_solvers = sysid_solvers
    monkeypatch.setitem(sys.modules, "dup_plugin", mod)
    reg = Registry(autoload=False)
    reg.load_entry_points([_ep("dup", "dup_plugin"), _ep("solvers", "sysid_solvers.plugin")])
    with pytest.raises(errors.PluginError, match="several plugins"):
        reg.get("solver", "scs")


def test_autoload_can_be_disabled(monkeypatch):
    monkeypatch.setenv("SYSID_DISABLE_PLUGIN_AUTOLOAD", "1")
    assert Registry().names("solver") == []


@pytest.mark.parametrize(
    ("kind", "name", "bad"),
    [
        ("solver", "clarabel", {"tol_gapp": 1}),
        ("solver", "scs", {"epsabs": 1}),
        ("objective", "minimax", {"tietol": 1}),
        ("objective", "least-squares", {"x": 1}),
    ],
)
def test_unknown_options_named(kind, name, bad):
    reg = Registry(autoload=True)
    with pytest.raises(errors.ConfigError, match=repr(next(iter(bad)))):
        reg.create(kind, name, **bad)


def test_model_order_checked():
    reg = Registry(autoload=True)
    with pytest.raises(errors.ConfigError, match="0 to 6"):
        reg.create("model structure", "act", order=9)
