"""Entry point of the built-in model structures."""

from __future__ import annotations

from collections.abc import Callable, Mapping

from sysid_core.hookspec import hookimpl
from sysid_core.interfaces import ModelStructure
from sysid_models.structures import ActStructure, SenStructure


@hookimpl
def sysid_model_structures() -> Mapping[str, Callable[..., ModelStructure]]:
    return {"act": ActStructure, "sen": SenStructure}
