"""Built-in model structures: ``act`` (output dynamics, eq. 2-3) and ``sen`` (input dynamics, 4-5)."""

from sysid_models.structures import ActStructure, SenStructure

__all__ = ["ActStructure", "SenStructure"]
