"""A study file: the ``sysid tune`` tables plus ``[study]``, and one run's spec."""

from __future__ import annotations

import os
import re
from dataclasses import dataclass
from typing import Any

from pydantic import BaseModel, ConfigDict, Field, ValidationError

from sysid_core.errors import ConfigError
from sysid_core.run.config import PipelineConfig, describe_validation_error, parse_config, read_toml

__all__ = [
    "AUTO_STRUCTURE",
    "SAFE_NAME",
    "RunSpec",
    "StudyConfig",
    "StudySettings",
    "load_study_config",
]

#: Names that become part of a run's key, hence of file names.
SAFE_NAME = re.compile(r"[A-Za-z0-9][A-Za-z0-9_.+-]*")

#: ``[study] structures`` entry for the structure each device names (its ``structure``).
AUTO_STRUCTURE = "auto"


class StudySettings(BaseModel):
    """``[study]``: the grid and what is compared."""

    model_config = ConfigDict(extra="forbid", frozen=True)
    grid: list[float] = Field(default_factory=lambda: [-9.0, -6.0, -3.0, 0.0, 3.0, 6.0, 9.0])
    starts: list[list[float]] | None = None
    structures: list[str] = Field(default_factory=lambda: ["act", "sen"])
    objectives: list[str] | None = None
    iterations: int = Field(2, ge=1, le=10)
    tuned_bias: list[float] | None = None
    seed: int = 0
    gyros: int | None = Field(None, ge=1, le=100_000)


class _StudyTable(BaseModel):
    model_config = ConfigDict(extra="forbid")
    study: StudySettings = StudySettings()


class StudyConfig(BaseModel):
    """A pipeline configuration plus a ``[study]`` table."""

    model_config = ConfigDict(extra="forbid", frozen=True)
    pipeline: PipelineConfig
    study: StudySettings

    @property
    def objectives(self) -> list[str]:
        """Objectives compared (default: the ``[objective]`` name)."""
        if self.study.objectives is None:
            return [self.pipeline.objective.name]
        return list(self.study.objectives)


def load_study_config(path: str | os.PathLike[str]) -> StudyConfig:
    """Read a study configuration (the ``sysid tune`` tables plus ``[study]``).

    Only the syntax and the types are checked here; :func:`~.plan.plan_study` checks the rest.
    """
    data = read_toml(path)
    study = data.pop("study", {})
    parse_config(data, str(path))  # the pipeline tables, with their messages
    try:
        pipeline = PipelineConfig.model_validate(data)
        settings = _StudyTable.model_validate({"study": study}).study
    except ValidationError as exc:
        raise ConfigError(f"{path}: {describe_validation_error(exc)}") from None
    return StudyConfig(pipeline=pipeline, study=settings)


@dataclass(frozen=True)
class RunSpec:
    """One independent run of the study.

    In a population study (``[study] gyros``) ``index`` is the gyro's position, ``seed`` its
    device seed and ``structure`` the name in ``[study] structures`` (``auto`` for the
    structure the device names); ``config`` holds what the run really uses.
    """

    key: str
    index: int
    objective: str
    structure: str
    start: tuple[float, ...]
    seed: int
    config: dict[str, Any]
    out: str
