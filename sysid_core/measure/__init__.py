"""Measuring: where and what a run measures, and what its measurements show.

Lives here: experiment designs and sweep grids (:mod:`.sweeps`), the lean protocol's grids
(:mod:`.lean`; around predicted modes :mod:`.modegrid`, its shape by what the points tell per
second of bench clock, :mod:`.information`), how far known modes may have moved
(:mod:`.motion`), what earlier sweeps already tell (:mod:`.knowledge`; a previous run's model:
:mod:`.previous`), locating the modes in the band (:mod:`.locating`, :mod:`.zoom`), the
evidence that a sweep shows both modes (:mod:`.evidence`), a verification window and its
reading (:mod:`.verification`), repeated passes of a noisy window (:mod:`.passes`), when a slow
contraction calls for a new design (:mod:`.contraction`), which pair of electrodes degenerate
modes need (:mod:`.pairing`) and the run's fits of what it measured (:mod:`.fitter`).

May import: everything below it, and :mod:`sysid_core.clock`.
"""
