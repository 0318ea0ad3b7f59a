"""Verdicts: what a verification lets the run claim, and whether an answer may be applied.

Lives here: the goals of a verified split and the run's verdict, converged, keep going or stop
(:mod:`.judgement`; at the DAC's floor, :mod:`.dacfloor`), the answer from the model, rounded to
the DAC (:mod:`.answer`, :mod:`.dac`), what a model's "unreachable" leads to (:mod:`.unreachable`),
and the rules that keep an answer within what the data support (:mod:`.trust`).

May import: everything below it, :mod:`sysid_core.clock`, :mod:`sysid_core.measure` and
:mod:`sysid_core.drift`.
"""
