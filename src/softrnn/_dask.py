"""Running independent tasks on Dask: a local cluster or a scheduler's address (sweeps, studies)."""

from __future__ import annotations

import os
from contextlib import nullcontext

from .errors import SoftrnnInputError


def completed(tasks, scheduler: str | None, n_workers: int, *, alternatives: str = "", local_guard=None):
    """Yield the results of ``tasks`` (a list of ``(function, args, key)``) as they finish.

    ``scheduler`` None: a ``LocalCluster`` of ``n_workers`` single-threaded processes (their numba
    pinned to one thread), closed at the end; otherwise the address of a running Dask scheduler
    (one that does not answer is a one-line ``SoftrnnInputError`` naming ``--scheduler``;
    ``alternatives`` adds other options to its message). ``local_guard``: a context manager
    entered while the local cluster starts (e.g. to make its workers ignore Ctrl-C). Tasks not yet
    finished are cancelled when the generator is closed.
    """
    from distributed import Client, LocalCluster, as_completed

    os.environ.setdefault("NUMBA_NUM_THREADS", "1")  # inherited by local worker processes
    cluster = None
    try:
        if scheduler is None:
            with (local_guard() if local_guard is not None else nullcontext()):
                cluster = LocalCluster(n_workers=n_workers, threads_per_worker=1, processes=True,
                                       dashboard_address=None, silence_logs=50)
            client = Client(cluster)
        else:
            try:
                client = Client(scheduler, timeout="10s")
            except (OSError, TimeoutError, ValueError) as err:
                raise SoftrnnInputError(
                    f"--scheduler={scheduler!r} is invalid: no Dask scheduler answered there ({err}); start one "
                    f"with 'dask scheduler' and 'dask worker ADDRESS', {alternatives}or omit --scheduler for a "
                    f"local cluster") from None
        with client:
            futures = [client.submit(fn, *args, key=key) for fn, args, key in tasks]
            try:
                for fut in as_completed(futures):
                    yield fut.result()
            finally:
                for fut in futures:
                    fut.cancel()
    finally:
        if cluster is not None:
            cluster.close()
