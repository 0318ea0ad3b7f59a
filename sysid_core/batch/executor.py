"""Independent jobs on dask.distributed, each result handed back as soon as it arrives.

Used by studies (:mod:`sysid_core.batch.study.execute`) and fleets (:mod:`sysid_core.batch.fleet`):
the jobs go to a ``LocalCluster`` of worker processes on this machine, to a running scheduler, or
to a client the caller already has. A job that raises, a worker that dies for good (dask first moves
the job to another worker), a cancelled job or a cluster that cannot start never stops the
others: each becomes a failure record from ``failure(item, exception)``.
"""

from __future__ import annotations

import asyncio
import os
from collections.abc import Callable, Iterator, Sequence
from typing import TYPE_CHECKING, Any, TypeVar

if TYPE_CHECKING:
    from distributed import Client

__all__ = ["run_batch"]

T = TypeVar("T")


def run_batch(
    items: Sequence[T],
    job: Callable[[T], dict[str, Any]],
    keys: Sequence[str],
    record: Callable[[dict[str, Any]], None],
    failure: Callable[[T, BaseException], dict[str, Any]],
    workers: int | None = None,
    scheduler: str | None = None,
    client: Client | None = None,
) -> None:
    """Run ``job(item)`` for every item on dask; ``record`` every result as it completes.

    Parameters
    ----------
    items : sequence
        The jobs' inputs (picklable).
    job : callable
        Runs one item in a worker; should return a dict and not raise (a raise is a failure).
    keys : sequence of str
        One unique dask key per item.
    record : callable
        Called in this process with each result (or failure record), in completion order.
    failure : callable
        Makes the failure record of an item from the exception.
    workers : int, optional
        Worker processes of the local cluster (default: the machine's cores).
    scheduler : str, optional
        Address of a running scheduler to use instead of a local cluster.
    client : distributed.Client, optional
        An open client to use (left open).
    """
    if not items:
        return
    from dask.distributed import Client, LocalCluster, as_completed

    cluster = None
    own = client is None
    pending = dict(zip(keys, items, strict=True))
    completed: Iterator[Any] = iter(())
    try:
        if client is None:
            if scheduler:
                client = Client(scheduler)
            else:
                n = workers or os.cpu_count() or 1
                cluster = LocalCluster(
                    n_workers=n, threads_per_worker=1, processes=True, dashboard_address=":0"
                )
                client = Client(cluster)
        futures = client.map(job, list(items), key=list(keys), pure=False)
        completed = as_completed(futures)
    except Exception as exc:  # no cluster to run on: every job failed
        _fail_all(pending, exc, record, failure)
    try:
        _collect(completed, pending, record, failure)
    finally:
        if own and client is not None:
            client.close()
        if cluster is not None:
            cluster.close()


def _collect(
    completed: Iterator[Any],
    pending: dict[str, T],
    record: Callable[[dict[str, Any]], None],
    failure: Callable[[T, BaseException], dict[str, Any]],
) -> None:
    """``record`` the result of every ``pending`` job (by key) as its future completes.

    A job that raised or was cancelled, or every job left when the cluster itself fails or stops
    reporting, gets its failure record instead.
    """
    while pending:
        try:
            future = next(completed)
        except StopIteration:
            break
        except Exception as exc:  # the cluster itself failed: the rest failed
            _fail_all(pending, exc, record, failure)
            break
        finished = pending.pop(future.key, None)
        if finished is None:
            continue
        try:
            outcome = future.result()
        except (Exception, asyncio.CancelledError) as exc:  # KilledWorker, cancelled
            outcome = failure(finished, exc)
        record(outcome)
    for item in pending.values():  # never reported back (should not happen)
        record(failure(item, RuntimeError("the cluster never reported this job")))


def _fail_all(
    pending: dict[str, T],
    exc: BaseException,
    record: Callable[[dict[str, Any]], None],
    failure: Callable[[T, BaseException], dict[str, Any]],
) -> None:
    """``record`` a failure from ``exc`` for every ``pending`` job, and empty ``pending``."""
    for item in pending.values():
        record(failure(item, exc))
    pending.clear()
