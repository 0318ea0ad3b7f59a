"""Plugin discovery and lookup.

Plugins are modules registered under the entry-point group ``sysid`` (see
:mod:`sysid_core.plugin.spec`). The built-in components in ``plugins/`` and ``devices/`` are found
the same way as a third party's. A plugin that fails to import is a warning naming it and its
error; the others keep working. Set ``SYSID_DISABLE_PLUGIN_AUTOLOAD=1`` to skip entry points
(tests then register modules by hand with :meth:`Registry.register`).
"""

from __future__ import annotations

import importlib.metadata
import os
import warnings
from collections.abc import Callable, Iterable
from dataclasses import dataclass
from typing import Any, TypeVar

import pluggy

from sysid_core.conic.program import Solver
from sysid_core.device.protocol import Device, check_device
from sysid_core.errors import PluginError, PluginNotFoundError
from sysid_core.identification.objective import Objective
from sysid_core.model.structures import ModelStructure
from sysid_core.plugin import spec as hookspec
from sysid_core.plugin.options import build
from sysid_core.tuning.criteria import TuningCriterion

T = TypeVar("T")

__all__ = [
    "Component",
    "PluginLoadWarning",
    "Registry",
    "get_registry",
    "reset_registry",
]

KINDS = tuple(hookspec.KIND_HOOKS)


class PluginLoadWarning(UserWarning):
    """A plugin could not be loaded; the rest of the toolkit keeps working."""


@dataclass(frozen=True)
class Component:
    """One named component provided by a plugin."""

    kind: str
    name: str
    factory: Callable[..., Any]
    plugin: str
    distribution: str

    @property
    def description(self) -> str:
        """The component's one-line description, if it has one."""
        text = getattr(self.factory, "description", "") or (self.factory.__doc__ or "")
        return text.strip().splitlines()[0] if text.strip() else ""


class Registry:
    """A pluggy ``PluginManager`` for project ``sysid`` with a typed lookup facade.

    Parameters
    ----------
    autoload : bool, optional
        Load the entry points of group ``sysid``. Default: true unless the environment variable
        ``SYSID_DISABLE_PLUGIN_AUTOLOAD`` is set to a non-empty value.
    """

    def __init__(self, autoload: bool | None = None) -> None:
        self._pm = pluggy.PluginManager(hookspec.PROJECT)
        self._pm.add_hookspecs(hookspec)
        self._dist: dict[str, str] = {}
        self._table: dict[str, dict[str, list[Component]]] | None = None
        self.failures: list[tuple[str, str]] = []
        if autoload is None:
            autoload = not os.environ.get("SYSID_DISABLE_PLUGIN_AUTOLOAD")
        if autoload:
            self.load_entry_points(importlib.metadata.entry_points(group=hookspec.PROJECT))

    def load_entry_points(self, entry_points: Iterable[importlib.metadata.EntryPoint]) -> None:
        """Register the plugin behind each entry point; warn about (and skip) broken ones."""
        for ep in entry_points:
            dist = ep.dist.name if ep.dist is not None else "unknown"
            if self._pm.has_plugin(ep.name):
                continue
            try:
                plugin = ep.load()
            except Exception as exc:
                message = (
                    f'sysid plugin "{ep.name}" ({ep.value}, from {dist}) failed to load: '
                    f"{type(exc).__name__}: {exc}"
                )
                self.failures.append((ep.name, message))
                warnings.warn(message, PluginLoadWarning, stacklevel=2)
                continue
            self.register(plugin, name=ep.name, distribution=dist)

    def register(
        self, plugin: object, name: str | None = None, distribution: str = "local"
    ) -> None:
        """Register a plugin module or object (as a built-in or third-party plugin would be)."""
        registered = self._pm.register(plugin, name=name)
        if registered is None:
            raise PluginError(f"plugin {name or plugin!r} is already registered or blocked")
        self._dist[registered] = distribution
        self._table = None

    def _build(self) -> dict[str, dict[str, list[Component]]]:
        table: dict[str, dict[str, list[Component]]] = {kind: {} for kind in KINDS}
        for kind, hook_name in hookspec.KIND_HOOKS.items():
            hook = getattr(self._pm.hook, hook_name)
            for impl in hook.get_hookimpls():
                plugin_name = self._pm.get_name(impl.plugin) or repr(impl.plugin)
                try:
                    provided = impl.function()
                    items = dict(provided).items()
                except Exception as exc:
                    message = (
                        f'sysid plugin "{plugin_name}" failed in {hook_name}(): '
                        f"{type(exc).__name__}: {exc}"
                    )
                    self.failures.append((plugin_name, message))
                    warnings.warn(message, PluginLoadWarning, stacklevel=3)
                    continue
                for comp_name, factory in items:
                    table[kind].setdefault(str(comp_name), []).append(
                        Component(
                            kind=kind,
                            name=str(comp_name),
                            factory=factory,
                            plugin=plugin_name,
                            distribution=self._dist.get(plugin_name, "local"),
                        )
                    )
        return table

    @property
    def table(self) -> dict[str, dict[str, list[Component]]]:
        """Every component, by kind and name (a name may have several providers)."""
        if self._table is None:
            self._table = self._build()
        return self._table

    def components(self, kind: str) -> list[Component]:
        """All components of ``kind``, sorted by name."""
        self._check_kind(kind)
        return [c for name in sorted(self.table[kind]) for c in self.table[kind][name]]

    def names(self, kind: str) -> list[str]:
        """Installed names of ``kind``, sorted."""
        self._check_kind(kind)
        return sorted(self.table[kind])

    def get(self, kind: str, name: str) -> Component:
        """The component ``name`` of ``kind``.

        Raises
        ------
        PluginNotFoundError
            If no installed plugin provides it; the message lists the installed names.
        PluginError
            If two plugins provide the same name.
        """
        self._check_kind(kind)
        providers = self.table[kind].get(name)
        if not providers:
            installed = ", ".join(self.names(kind)) or "none"
            hint = (
                f"; {len(self.failures)} plugin(s) failed to load, see the warnings"
                if self.failures
                else ""
            )
            raise PluginNotFoundError(
                f"no {kind} named {name!r} is installed; installed: {installed}{hint}. "
                f"Third-party {kind}s are added by packages with a 'sysid' entry point."
            )
        if len(providers) > 1:
            who = ", ".join(f"{c.plugin} ({c.distribution})" for c in providers)
            raise PluginError(f"{kind} {name!r} is provided by several plugins: {who}")
        return providers[0]

    def create(self, kind: str, name: str, /, **options: Any) -> Any:
        """Look up ``name`` of ``kind``, check ``options`` and call its factory.

        The options are checked against the factory's keyword parameters
        (:func:`sysid_core.plugin.options.check_options`), the same way for every kind. Prefer the
        typed accessors (:meth:`device`, :meth:`structure`, :meth:`objective`, :meth:`solver`,
        :meth:`criterion`), which also check what the plugin returns.
        """
        return build(kind, name, self.get(kind, name).factory, options)

    def _typed(self, kind: str, name: str, cls: type[T], options: dict[str, Any]) -> T:
        made = self.create(kind, name, **options)
        if not isinstance(made, cls):
            raise PluginError(
                f"{kind} {name!r} ({self.get(kind, name).plugin}) returned a "
                f"{type(made).__name__}, not a {cls.__name__}"
            )
        return made

    def device(self, name: str, /, **options: Any) -> Device:
        """The device ``name`` built with ``options`` (its protocol attributes checked)."""
        return check_device(self.create("device", name, **options), name)

    def structure(self, name: str, /, **options: Any) -> ModelStructure:
        """The model structure ``name`` (options: ``order`` and the structure's own)."""
        return self._typed("model structure", name, ModelStructure, options)

    def objective(self, name: str, /, **options: Any) -> Objective:
        """The fit objective ``name`` built with ``options``."""
        # mypy rejects an abstract class as type[T] (python/mypy#4717); _typed only isinstance()s it
        return self._typed("objective", name, Objective, options)  # type: ignore[type-abstract]

    def solver(self, name: str, /, **options: Any) -> Solver:
        """The solver backend ``name`` built with ``options``."""
        # mypy rejects an abstract class as type[T] (python/mypy#4717); _typed only isinstance()s it
        return self._typed("solver", name, Solver, options)  # type: ignore[type-abstract]

    def criterion(self, name: str, /, **options: Any) -> TuningCriterion:
        """The tuning criterion ``name`` built with ``options`` (``solver=``, ``target_hz=``...)."""
        # mypy rejects an abstract class as type[T] (python/mypy#4717); _typed only isinstance()s it
        return self._typed("tuning criterion", name, TuningCriterion, options)  # type: ignore[type-abstract]

    @staticmethod
    def _check_kind(kind: str) -> None:
        if kind not in KINDS:
            raise PluginError(f"unknown component kind {kind!r}; kinds: {', '.join(KINDS)}")


_REGISTRY: Registry | None = None


def get_registry() -> Registry:
    """The process-wide registry, loaded on first use."""
    global _REGISTRY
    if _REGISTRY is None:
        _REGISTRY = Registry()
    return _REGISTRY


def reset_registry(registry: Registry | None = None) -> None:
    """Replace (or, with no argument, forget) the process-wide registry."""
    global _REGISTRY
    _REGISTRY = registry
