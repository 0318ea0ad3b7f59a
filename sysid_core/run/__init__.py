"""A tuning run: the configuration, the loop of experiments, fits, answers and verifications.

Lives here: the configuration file (:mod:`.config`), building a run's components
(:mod:`.components`) and the context its steps share (:mod:`.context`), the protocols that say
what each iteration measures (:mod:`.protocols`; which electrodes a lean run tunes:
:mod:`.electrodes`), the loop (:mod:`.pipeline`), the summary
(:mod:`.summary`) and the plots (:mod:`.plots`; the split over the bench clock:
:mod:`.timeline`). The jobs the loop calls have rooms of their own: the bench and its clock
(:mod:`sysid_core.clock`), measuring (:mod:`sysid_core.measure`), the gyro in time
(:mod:`sysid_core.drift`) and the verdicts (:mod:`sysid_core.verdict`).

May import: everything below it (errors, data, conic, model, identification, tuning, device,
plugin, bench, measure, drift, verdict).
"""
