"""The gyro in time: what a run does about a drifting gyro and its estimate of the drift.

Lives here: ``[model] drift`` parsed into a policy (:mod:`.policy`), the verification windows'
forecast of the split (:mod:`.forecast`, on the filter of
:mod:`sysid_core.identification.splittrend`) and the tracker, which keeps the verified windows
and moves the run's model to the time of the next verification (:mod:`.tracker`), holding each
look at the forecast to its level (:mod:`.looks`). The model of the drift is
docs/drift-model.md.

May import: everything below it, :mod:`sysid_core.clock` and :mod:`sysid_core.measure`.
"""
