"""A tuning run: the configuration, the loop of experiments, fits, answers and verifications.

Lives here: the configuration file (:mod:`.config`; ``[model] drift`` parsed:
:mod:`.driftpolicy`), building a run's components
(:mod:`.components`), experiment designs and sweep grids (:mod:`.sweeps`), the lean protocol
(:mod:`.lean`, :mod:`.knowledge`; from a previous model: :mod:`.previous`), the evidence that
a sweep shows both modes (:mod:`.evidence`), verification (:mod:`.verification`) and what it
can claim (:mod:`.judgement`), whether an answer may be applied (:mod:`.trust`), the gyro in
time (:mod:`.tracking`, :mod:`.own_splits`), DAC codes (:mod:`.dac`), bench time
(:mod:`.benchtime`), the run's clock and its bench-time budget (:mod:`.clock`,
:mod:`.budget`), the summary (:mod:`.summary`), the plots (:mod:`.plots`; the split over the
bench clock: :mod:`.timeline`) and the loop (:mod:`.pipeline`).

May import: everything below it (errors, data, conic, model, identification, tuning, device,
plugin).
"""
