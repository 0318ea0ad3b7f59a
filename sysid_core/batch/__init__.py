"""Many runs at once: the executor on dask.distributed, fleets of gyros and studies.

Lives here: the parallel executor (:mod:`.executor`), ``sysid tune-fleet`` (:mod:`.fleet`)
and the statistical studies (:mod:`.study`).

May import: everything below it, :mod:`sysid_core.run` included.
"""
