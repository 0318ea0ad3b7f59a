"""The run's fitter: its structure, objective and solver, one call per data set."""

from __future__ import annotations

from dataclasses import dataclass

import xarray as xr

from sysid_core.conic.program import Solver
from sysid_core.identification.fitting import fit_structure
from sysid_core.identification.objective import Objective
from sysid_core.model.fitted import FittedModel
from sysid_core.model.structures import ModelStructure
from sysid_core.run.evidence import WindowAssessment, assess_window

__all__ = ["Fitter"]


@dataclass(frozen=True)
class Fitter:
    """Fits with the run's components (built once, from the run's registry)."""

    structure: ModelStructure
    objective: Objective
    solver: Solver

    def fit(
        self, ds: xr.Dataset, structure: ModelStructure | None = None
    ) -> tuple[FittedModel, list[str]]:
        """The model of ``ds`` and the notes of the fit (reasons to distrust it)."""
        return fit_structure(ds, structure or self.structure, self.objective, self.solver)

    def model(self, ds: xr.Dataset, structure: ModelStructure | None = None) -> FittedModel:
        """The model of ``ds`` alone (its notes are not wanted where this is called)."""
        return self.fit(ds, structure)[0]

    def window(self, sweep: xr.Dataset, band: bool) -> tuple[FittedModel, WindowAssessment]:
        """A single sweep's model and the evidence that it shows both modes.

        A window without both modes is expected here: the evidence says so, not the fit's notes.
        """
        model = self.model(sweep.isel(electrode=[]))
        return model, assess_window(sweep, model, band=band)
