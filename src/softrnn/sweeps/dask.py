"""Running independent tasks on Dask: a local cluster or a scheduler's address (sweeps, studies)."""

from __future__ import annotations

import os
from contextlib import contextmanager, nullcontext

from ..errors import SoftrnnInputError

WORKER_ENV = {"NUMBA_NUM_THREADS": "1"}
"""Environment of local worker processes only: one task per single-threaded process. The parent's
environment is never changed: numba re-reads it at every compile and refuses a thread count that
differs from the one its thread pool was launched with."""


@contextmanager
def restored_environ():
    """Run the body, then put ``os.environ`` back exactly as it was (Dask's nannies run in this
    process and write variables meant for the workers they spawn, e.g. ``PYTHONHASHSEED``)."""
    saved = dict(os.environ)
    try:
        yield
    finally:
        for key in set(os.environ) - set(saved):
            del os.environ[key]
        for key, value in saved.items():
            if os.environ.get(key) != value:
                os.environ[key] = value


def require() -> None:
    """Raise ``ModuleNotFoundError`` (named ``distributed``) now, before any output is written,
    when the ``softrnn[dask]`` extra is not installed."""
    import distributed  # noqa: F401  # optional extra: dask


@contextmanager
def dask_client(scheduler: str | None, n_workers: int, *, alternatives: str = "", local_guard=None):
    """A ``distributed.Client``, closed at the end.

    ``scheduler`` None: a ``LocalCluster`` of ``n_workers`` single-threaded processes (their numba
    pinned to one thread through the workers' own environment, ``WORKER_ENV``), closed at the end;
    otherwise the address of a running Dask scheduler (one that does not answer is a one-line
    ``SoftrnnInputError`` naming ``--scheduler``; ``alternatives`` adds other options to its
    message). ``local_guard``: a context manager entered while the local cluster starts (e.g. to
    make its workers ignore Ctrl-C).
    """
    from distributed import Client, LocalCluster  # optional extra: dask

    cluster = None
    try:
        if scheduler is None:
            with restored_environ(), (local_guard() if local_guard is not None else nullcontext()):
                cluster = LocalCluster(n_workers=n_workers, threads_per_worker=1, processes=True,
                                       dashboard_address=None, silence_logs=50, env=dict(WORKER_ENV))
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
            yield client
    finally:
        if cluster is not None:
            with restored_environ():
                cluster.close()


def completed(tasks, scheduler: str | None, n_workers: int, *, alternatives: str = "", local_guard=None):
    """Yield the results of ``tasks`` (a list of ``(function, args, key)``) as they finish, on the
    client of ``dask_client(scheduler, n_workers, alternatives=..., local_guard=...)``. Tasks not
    yet finished are cancelled when the generator is closed."""
    from distributed import as_completed  # optional extra: dask

    with dask_client(scheduler, n_workers, alternatives=alternatives, local_guard=local_guard) as client:
        futures = [client.submit(fn, *args, key=key) for fn, args, key in tasks]
        try:
            for fut in as_completed(futures):
                yield fut.result()
        finally:
            for fut in futures:
                fut.cancel()
