"""Plugin options: one rule and one check for every kind of component.

A plugin's options are the keyword parameters of its factory (a class's ``__init__`` or a
function). :func:`check_options` checks the options a configuration gives against them:

* an option the factory does not take is an error naming it and listing the ones it takes
  (a factory with ``**kwargs`` accepts anything, and is then trusted to check it: an
  "unexpected keyword argument" from it is reported the same way by :func:`build`);
* a value must match the parameter's annotation: ``bool``, ``int`` (not a bool), ``float`` (an
  int is fine), ``str``, ``None``, unions, ``list``/``tuple``/``Sequence`` of those, and any
  class (by ``isinstance``). Bounds come from ``typing.Annotated`` metadata of the
  ``annotated_types`` package (``Gt``, ``Ge``, ``Lt``, ``Le``), e.g.
  ``tolerance_hz: Annotated[float, Gt(0)] = 1e-3``.

Every message names the component and the option, shows the value given and says what it must
be. :func:`build` checks, then calls the factory.
"""

from __future__ import annotations

import inspect
import math
import sys
import types
import typing
from collections.abc import Callable, Mapping, Sequence
from typing import Any

from sysid_core.errors import ConfigError

__all__ = ["accepted_options", "build", "check_options"]

_NO_HINT = object()


def _signature(factory: Callable[..., Any]) -> inspect.Signature | None:
    try:
        return inspect.signature(factory)
    except (TypeError, ValueError):  # builtins without a signature
        return None


def _hint(factory: Callable[..., Any], param: inspect.Parameter) -> Any:
    """The parameter's annotation, resolved, or :data:`_NO_HINT` if it cannot be."""
    ann = param.annotation
    if ann is inspect.Parameter.empty:
        return _NO_HINT
    if not isinstance(ann, str):
        return ann
    target = factory.__init__ if inspect.isclass(factory) else factory
    module = sys.modules.get(getattr(target, "__module__", ""), None)
    namespace = {**vars(typing), **(vars(module) if module else {})}
    try:
        return eval(ann, namespace)
    except Exception:  # a name only imported for type checking: no check
        return _NO_HINT


def accepted_options(factory: Callable[..., Any]) -> tuple[list[str], bool]:
    """The factory's keyword options, and whether it also takes ``**kwargs``."""
    sig = _signature(factory)
    if sig is None:
        return [], True
    named = [
        p.name
        for p in sig.parameters.values()
        if p.kind in (p.POSITIONAL_OR_KEYWORD, p.KEYWORD_ONLY) and p.name != "self"
    ]
    var_kw = any(p.kind is p.VAR_KEYWORD for p in sig.parameters.values())
    return named, var_kw


def _describe(hint: Any) -> str:
    origin = typing.get_origin(hint)
    if origin is typing.Annotated:
        base, *meta = typing.get_args(hint)
        bounds = [_bound_text(m) for m in meta if _bound_text(m)]
        return _describe(base) + (f" {' and '.join(bounds)}" if bounds else "")
    if origin in (typing.Union, types.UnionType):
        return " or ".join(_describe(a) for a in typing.get_args(hint))
    if hint is type(None) or hint is None:
        return "none"
    if hint is bool:
        return "true or false"
    if hint is int:
        return "an integer"
    if hint is float:
        return "a finite number"
    if hint is str:
        return "a string"
    if origin in (list, tuple, Sequence) or hint in (list, tuple):
        return "a list"
    return f"a {getattr(hint, '__name__', str(hint))}"


_BOUNDS = {"gt": ">", "ge": ">=", "lt": "<", "le": "<="}


def _bound_text(meta: Any) -> str:
    for attr, sign in _BOUNDS.items():
        if hasattr(meta, attr) and type(meta).__name__.lower() == attr:
            return f"{sign} {getattr(meta, attr)}"
    return ""


def _matches(value: Any, hint: Any) -> bool:
    """Whether ``value`` matches the annotation ``hint`` (the rules of the module docstring)."""
    if hint is _NO_HINT or hint is Any:
        return True
    origin = typing.get_origin(hint)
    if origin is typing.Annotated:
        base, *meta = typing.get_args(hint)
        return _matches(value, base) and _within_bounds(value, meta)
    if origin in (typing.Union, types.UnionType):
        return any(_matches(value, a) for a in typing.get_args(hint))
    plain = _matches_plain(value, hint)
    if plain is not None:
        return plain
    if origin in (list, tuple, Sequence) or hint in (list, tuple):
        return _matches_sequence(value, hint)
    if origin is not None:  # another generic (dict[...], Callable[...]): no deeper check
        return isinstance(value, origin) if isinstance(origin, type) else True
    return isinstance(value, hint) if isinstance(hint, type) else True


def _within_bounds(value: Any, meta: list[Any]) -> bool:
    """Whether ``value`` meets every ``annotated_types`` bound (``Gt``, ``Ge``, ...) in ``meta``."""
    for m in meta:
        for attr, sign in _BOUNDS.items():
            if type(m).__name__.lower() == attr:
                bound = getattr(m, attr)
                ok = {
                    ">": value > bound,
                    ">=": value >= bound,
                    "<": value < bound,
                    "<=": value <= bound,
                }[sign]
                if not ok:
                    return False
    return True


def _matches_plain(value: Any, hint: Any) -> bool | None:
    """Whether ``value`` matches a plain ``hint`` (None, bool, int, float, str); else None."""
    if hint is type(None) or hint is None:
        return value is None
    if hint is bool:
        return isinstance(value, bool)
    if hint is int:
        return isinstance(value, int) and not isinstance(value, bool)
    if hint is float:
        number = isinstance(value, (int, float)) and not isinstance(value, bool)
        return number and math.isfinite(value)
    if hint is str:
        return isinstance(value, str)
    return None


def _matches_sequence(value: Any, hint: Any) -> bool:
    """Whether ``value`` is a list or tuple whose items match one of ``hint``'s item types."""
    if isinstance(value, (str, bytes)) or not isinstance(value, (list, tuple)):
        return False
    args = [a for a in typing.get_args(hint) if a is not Ellipsis]
    return all(any(_matches(v, a) for a in args) for v in value) if args else True


def check_options(
    kind: str, name: str, factory: Callable[..., Any], options: Mapping[str, Any]
) -> None:
    """Check ``options`` against ``factory``'s keyword parameters (see the module docstring).

    Raises
    ------
    ConfigError
        For an option the factory does not take, or a value that does not match its
        parameter's annotation.
    """
    named, var_kw = accepted_options(factory)
    sig = _signature(factory)
    params = sig.parameters if sig is not None else {}
    for key, value in options.items():
        if key not in named:
            if var_kw:
                continue
            known = ", ".join(sorted(named)) or "none"
            raise ConfigError(f"unknown option {key!r} for {kind} {name!r}; known options: {known}")
        hint = _hint(factory, params[key])
        if not _matches(value, hint):
            raise ConfigError(
                f"option {key!r} of {kind} {name!r} must be {_describe(hint)}, got {value!r}"
            )


def build(kind: str, name: str, factory: Callable[..., Any], options: Mapping[str, Any]) -> Any:
    """Check ``options`` (:func:`check_options`) and call ``factory(**options)``.

    An "unexpected keyword argument" ``TypeError`` raised by the factory itself (a factory that
    passes ``**kwargs`` on) becomes the same :class:`ConfigError` as an unknown option.
    """
    check_options(kind, name, factory, options)
    try:
        return factory(**options)
    except TypeError as exc:
        text = str(exc)
        if "unexpected keyword argument" not in text:
            raise
        key = text.split("'")[-2] if text.count("'") >= 2 else "?"
        named, _ = accepted_options(factory)
        known = ", ".join(sorted(n for n in named if n != "kwargs")) or "see its documentation"
        raise ConfigError(
            f"unknown option {key!r} for {kind} {name!r}; known options: {known}"
        ) from None
