"""Identification: from data and a model structure to a fitted model (step 2 of the method).

Lives here: the scaled fit problem and its equation-error operator (:mod:`.problem`), the conic
programs of the objectives (:mod:`.programs`), the objective interface (:mod:`.objective`), the
least-squares covariance (:mod:`.covariance`) and the fit itself with its checks
(:mod:`.fitting`); the gyro in time: a model anchored on its latest sweeps (:mod:`.anchor`),
drift terms in the fit (:mod:`.drift`) and the split's estimator in time (:mod:`.splittrend`).

May import: :mod:`sysid_core.errors`, :mod:`sysid_core.data`, :mod:`sysid_core.conic`,
:mod:`sysid_core.model`. Not :mod:`sysid_core.tuning` or :mod:`sysid_core.device` (siblings).
"""
