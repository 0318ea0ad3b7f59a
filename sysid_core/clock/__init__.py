"""The bench a run measures on, and its clock.

Lives here: every measurement checked, saved first and counted, the device's time stamps read
and checked once (:mod:`.bench`), the run's folder that holds them, locked while a run writes
it (:mod:`.runfolder`), what a measurement costs in seconds when the bench does
not say (:mod:`.benchtime`), the run's bench-time budget (:mod:`.budget`) and the run's clock,
which answers every question a run asks of time (:mod:`.runclock`).

May import: everything below it (errors, data, conic, model, identification, tuning, device,
plugin). Not the configuration file: the run hands its values in.
"""
