"""Built-in model structures: ``act`` (output dynamics, eqs. 2-3) and ``sen`` (input, 4-5)."""

from sysid_models.structures import ActStructure, SenStructure

__all__ = ["ActStructure", "SenStructure"]
