"""A griffe extension: the docstrings' Sphinx roles as mkdocstrings cross-references.

The docstrings of ``sysid_core`` name other objects with Sphinx roles (``:func:`fit```,
``:class:`~sysid_core.model.fitted.FittedModel```, ``:mod:`.schema```). mkdocstrings reads
Markdown, where a cross-reference is ``[`text`][full.path]``. Before the docstrings are parsed,
this extension rewrites every role:

* a name of the toolkit is resolved as Python would in the docstring's scope (imports, members,
  parents; a leading dot is relative to the module, a full path is looked up as it is), then
  followed to where it is defined, and becomes a link to that object's entry in the API pages;
* a name of another library (``xarray.Dataset``) becomes code, without a link (the site is
  built without network, so other projects' inventories are not loaded);
* a private name (``_helper``) or one without a docstring becomes code: it has no entry;
* a name of the toolkit that does not resolve is a warning, which fails ``mkdocs build
  --strict``: the docstring names something that does not exist (any more).

``~`` shows the last part of the name only, as in Sphinx. The reStructuredText marker of a
literal block is shown as Sphinx shows it (``text::`` as ``text:``); the block itself, indented,
is a code block in Markdown too. Formulas (``:math:`x```, ``.. math::``) are shown as LaTeX code,
as the guide writes its formulas: the site loads no script to typeset them.
"""

from __future__ import annotations

import builtins
import re
from typing import Any

import griffe

# reStructuredText's literal-block marker: "text::" is shown "text:", " ::" alone is dropped
LITERAL = re.compile(r"(\s?)::\n(?=[ \t]*\n)")
MATH = re.compile(r":math:`([^`]+)`")
MATH_BLOCK = re.compile(r"^([ \t]*)\.\. math::[ \t]*(.*)$")
ROLE = re.compile(r":(?:py:)?(?:func|class|mod|data|meth|attr|exc|obj|const):`([~!]?)([^`]+)`")

log = griffe.get_logger("sphinx_roles")


def _walk(obj: griffe.Object) -> Any:
    yield obj
    for member in obj.members.values():
        if not member.is_alias and member.parent is obj:
            yield from _walk(member)


def _lookup(collection: griffe.ModulesCollection, path: str) -> griffe.Object | None:
    try:
        found = collection[path]
    except (KeyError, ValueError):
        return None
    try:
        return found.final_target if found.is_alias else found
    except (griffe.AliasResolutionError, griffe.CyclicAliasError):
        return None


def _resolve(obj: griffe.Object, name: str, collection: griffe.ModulesCollection) -> str | None:
    """The full path ``name`` stands for in the scope of ``obj`` (``None``: not found)."""
    if name.startswith("."):  # as a relative import in the module: from a package's own level
        module = obj.module
        base = module.path if module.is_init_module else module.path.rsplit(".", 1)[0]
        rest = name[1:]
        while rest.startswith("."):
            base = base.rsplit(".", 1)[0]
            rest = rest[1:]
        return f"{base}.{rest}"
    if _lookup(collection, name) is not None:
        return name
    first, _, rest = name.partition(".")
    try:
        head = obj.resolve(first)
    except griffe.NameResolutionError:
        return None
    return f"{head}.{rest}" if rest else head


def _math(text: str) -> str:
    """Formulas as LaTeX code: ``:math:`x``` inline, a ``.. math::`` directive as a block."""
    lines = MATH.sub(lambda m: f"`{m.group(1)}`", text).split("\n")
    out: list[str] = []
    i = 0
    while i < len(lines):
        directive = MATH_BLOCK.match(lines[i])
        if directive is None:
            out.append(lines[i])
            i += 1
            continue
        indent, first = directive.groups()
        body = [first] if first.strip() else []
        i += 1
        while i < len(lines) and (
            not lines[i].strip() or len(lines[i]) - len(lines[i].lstrip()) > len(indent)
        ):
            if lines[i].strip():
                body.append(lines[i].strip())
            i += 1
        out += [f"{indent}```latex", *(indent + b for b in body), f"{indent}```", ""]
    return "\n".join(out)


def _public(target: griffe.Object) -> bool:
    names = target.path.split(".")
    return not any(n.startswith("_") and not n.startswith("__") for n in names)


class SphinxRoles(griffe.Extension):
    """Rewrite Sphinx roles in every docstring of ``packages`` (see the module)."""

    def __init__(self, packages: tuple[str, ...] | list[str] = ("sysid_core",)) -> None:
        super().__init__()
        self.packages = tuple(packages)

    def on_package(self, *, pkg: griffe.Module, loader: griffe.GriffeLoader, **kwargs: Any) -> None:
        """Rewrite the docstrings once the whole package is loaded."""
        if pkg.name not in self.packages:
            return
        for obj in _walk(pkg):
            if obj.docstring is not None:
                text = _math(obj.docstring.value)
                text = ROLE.sub(lambda m, o=obj: self._link(m, o, loader), text)
                obj.docstring.value = LITERAL.sub(lambda m: "\n" if m.group(1) else ":\n", text)

    def _link(self, match: re.Match[str], obj: griffe.Object, loader: griffe.GriffeLoader) -> str:
        """The Markdown for one role in the docstring of ``obj``."""
        collection = loader.modules_collection
        tilde, name = match.group(1), match.group(2).strip()
        text = name.rsplit(".", 1)[-1] if tilde == "~" else name
        path = _resolve(obj, name, collection)
        if path is None or path.split(".")[0] not in self.packages:
            ours = name.startswith(".") or name.split(".")[0] in self.packages
            if ours or (path is None and "." not in name and not hasattr(builtins, name)):
                log.warning(f"{obj.path}: docstring names {name!r}, which does not resolve")
            return f"`{text}`"
        target = _lookup(collection, path)
        if target is None:
            log.warning(f"{obj.path}: docstring names {name!r} ({path}): no such object")
            return f"`{text}`"
        if not _public(target) or (target.docstring is None and not target.is_module):
            return f"`{text}`"  # not in the API pages: nothing to link to
        return f"[`{text}`][{target.path}]"
