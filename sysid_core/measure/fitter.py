"""The run's fitter: its structure, objective and solver, one call per data set.

A run that tracks the gyro (``[model] drift = "track"``, or ``"auto"`` on a bench with a clock)
fits its sweeps with a stiffness trend (a stiffness changing linearly in time, the ``trend``
term of :mod:`sysid_core.identification.drift`) once they span more than :data:`TREND_SPAN_S`.
The model: over hours, charging and temperature move the stiffness by as much as the bias law
does, and a time-invariant fit of those sweeps takes that motion for the law (its quadratic
terms grow, its answers' region widens); over minutes, the tracker's anchors already follow
the drift, and a trend fitted on sweeps measured one after the other competes with the bias
law they identify. Such a fit keeps the linear law
(:data:`sysid_core.identification.fitting.TREND_LAW`). The measurements behind the span and the
law are in docs/studies/drift-lab.md ("Long runs: a trend in the tracked fit").
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import xarray as xr

from sysid_core.clock.runclock import stamps_span_s
from sysid_core.conic.program import Solver
from sysid_core.data.schema import measured_mask
from sysid_core.identification.drift import has_time_stamps
from sysid_core.identification.fitting import fit_structure
from sysid_core.identification.objective import Objective
from sysid_core.identification.outputerror import refine_output_error
from sysid_core.identification.reweighting import refit
from sysid_core.measure.evidence import WindowAssessment, assess_window, response_error
from sysid_core.model.fitted import FittedModel
from sysid_core.model.structures import ModelStructure

__all__ = ["TREND_SPAN_S", "Fitter"]

#: A tracking run's fit carries the stiffness trend once its sweeps span more than this (s).
TREND_SPAN_S = 3600.0


@dataclass
class Fitter:
    """Fits with the run's components (built once, from the run's registry).

    ``tracked``: the run tracks the gyro, and its fits of sweeps over more than
    :data:`TREND_SPAN_S` carry the stiffness trend (see the module).
    """

    structure: ModelStructure
    objective: Objective
    solver: Solver
    #: The structure on the other side, for :meth:`twin`.
    twin_structure: ModelStructure | None = None
    tracked: bool = False

    def trend_for(self, ds: xr.Dataset) -> bool:
        """Whether a fit of ``ds`` carries the stiffness trend.

        In a tracking run, when its sweeps (of several iterations, with time stamps) span more
        than :data:`TREND_SPAN_S`.
        """
        epochs = len(np.unique(ds["epoch"].values)) if "epoch" in ds.coords else 1
        if epochs < 2 or not (self.tracked and has_time_stamps(ds)):
            return False
        return (stamps_span_s(ds) or 0.0) > TREND_SPAN_S

    def fit(
        self, ds: xr.Dataset, structure: ModelStructure | None = None
    ) -> tuple[FittedModel, list[str]]:
        """The model of ``ds`` and the notes of the fit (reasons to distrust it)."""
        return fit_structure(
            ds,
            structure or self.structure,
            self.objective,
            self.solver,
            trend=self.trend_for(ds),
            linear_trend=self.tracked,
        )

    def model(self, ds: xr.Dataset, structure: ModelStructure | None = None) -> FittedModel:
        """The model of ``ds``, for a guess of where the modes are (without the fit's notes)."""
        return self.fit(ds, structure)[0]

    def window(self, sweep: xr.Dataset, band: bool) -> tuple[FittedModel, WindowAssessment]:
        """A single sweep's model and the evidence that it shows both modes.

        A window without both modes is expected here: the evidence says so, not the fit's notes.
        A narrow window measures the split: its fit is weighted as the noise enters it
        (:func:`~sysid_core.identification.reweighting.refit`), which makes it, to first order,
        the fit of the response error. A whole-band sweep locates the modes: its plain fit
        stands if its evidence holds; if not, the weighted fit (started from the plain one)
        stands if its evidence holds; if neither holds, the least response error is searched
        from each (:func:`~sysid_core.identification.outputerror.refine_output_error`), and a
        result whose evidence holds stands; else the result of least response error (the plain
        fit if the search found none), whose modes place the windows that follow
        (:mod:`sysid_core.measure.zoom`). Where the peaks are sampled at a step of a few
        bandwidths, an equation-error fit misses their heights: a band of high-Q modes sampled
        at 2.5 bandwidths placed them within a bandwidth but missed the data by 0.8 of the
        response, where the weighted fit met them; a zoom at 2-3 bandwidths missed by 0.48
        (plain) and 0.63 (weighted) where the search met the noise, 0.11 (docs/fitting.md).
        """
        single = sweep.isel(electrode=[])
        if not band:
            model, _ = refit(single, self.structure, self.objective, self.solver)
            return model, assess_window(sweep, model)
        plain = fit_structure(single, self.structure, self.objective, self.solver)
        evidence = assess_window(sweep, plain[0], band=True)
        if evidence.ok:
            return plain[0], evidence
        weighted, _ = refit(single, self.structure, self.objective, self.solver, first=plain)
        again = assess_window(sweep, weighted, band=True)
        if again.ok:
            return weighted, again
        tried = []
        for start in (plain[0], weighted):
            refined = refine_output_error(single, start)
            if refined is not None:
                found = assess_window(sweep, refined, band=True)
                if found.ok:
                    return refined, found
                tried.append((response_error(sweep, refined), refined, found))
        if not tried:
            return plain[0], evidence
        _, refined, found = min(tried, key=lambda t: t[0])
        return refined, found

    def found(self, model: FittedModel) -> list[str]:
        """What a fit of this fitter found, for the run's progress: the law and the trend."""
        lines, facts = [], model.facts
        if facts.law is not None and not facts.from_model:
            lines.append(f"stiffness law {facts.law.describe()}")
        if self.tracked and facts.trend_per_s is not None:
            hours = facts.time_span_s / 3600.0
            lines.append(f"the sweeps span {hours:.2g} h; the fit carries their trend")
        return lines

    def twin(self, sweep: xr.Dataset) -> tuple[float, float] | None:
        """How many times better :attr:`twin_structure` fits a window, and its split (Hz).

        The ratio of the residual sums of squares of the two structures' plain fits; None
        without a twin.
        """
        if self.twin_structure is None:
            return None
        single = sweep.isel(electrode=[])
        mask = measured_mask(single)[0]
        f = np.asarray(single["frequency"].values, dtype=float)[mask]
        psi = np.asarray(single["response"].values[0])[mask]
        found = []
        for structure in (self.structure, self.twin_structure):
            model, _ = fit_structure(single, structure, self.objective, self.solver)
            rss = float(np.sum(np.abs(model.response(f, []) - psi) ** 2))
            modes = np.asarray(model.modal([]).frequencies_hz, dtype=float)
            found.append((rss, float(modes[1] - modes[0])))
        (own, _), (other, twin_split) = found
        return own / max(other, 1e-300), twin_split
