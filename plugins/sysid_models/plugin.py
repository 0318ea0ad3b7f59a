"""Entry point of the built-in model structures."""

from __future__ import annotations

from collections.abc import Callable, Mapping

from sysid_core import hookimpl
from sysid_core.plugin.interfaces import ModelStructure
from sysid_models.structures import ActStructure, SenStructure


@hookimpl
def sysid_model_structures() -> Mapping[str, Callable[..., ModelStructure]]:
    return {"act": ActStructure, "sen": SenStructure}
