"""Statistical studies (``sysid study``): plan, execution, report and plots.

Lives here: the study file and its runs (:mod:`.plan`), running one study run
(:mod:`.execute`), the report tables (:mod:`.report`), the figures (:mod:`.plots`) and the
whole study (:mod:`.runner`).

May import: everything below :mod:`sysid_core.batch`, and :mod:`sysid_core.batch.executor`.
"""
