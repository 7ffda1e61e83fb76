"""Independent pieces of the lab benchmark run in worker processes: ``WorkerPool``.

``WorkerPool(workers)`` runs functions (module-level, with picklable arguments and results) in
``workers`` processes started by ``spawn`` (no fork of a process that holds PyTorch's and numba's
threads), PyTorch and the BLAS libraries (OpenBLAS under NumPy and SciPy) on one thread in each; with
``workers`` 1 each runs in this process when its result is asked for, in the order asked, BLAS on one
thread during it. The arithmetic is the same either way (every piece seeds its own random numbers and
runs PyTorch and BLAS on one thread: a blocked solve sums in another order on another thread count), so
the results depend neither on the worker count nor on the machine's cores. One thread each is also the
faster: the workers are the parallelism, and BLAS threads beside them only contend for the cores (the
shared robot's calibration took 60 % more CPU time with two).
Jobs go to the workers in the order they are submitted: submitting the longest first keeps the cores
busy to the end. Every job's CPU and wall time is kept (``timings``).

The workers ignore Ctrl-C (SIGINT reaches the whole foreground process group): this process alone
stops, and leaving the ``with`` block by an exception (``KeyboardInterrupt`` included) terminates the
workers at once. An error raised in a worker is raised again here by ``Job.get``: as itself, or where
it cannot be sent between processes (it does not pickle), as the nearest of its base classes that can,
with its message.
"""

from __future__ import annotations

import multiprocessing
import os
import pickle
import signal
import time
from contextlib import contextmanager

from ..learned.threads import one_blas_thread

WAIT_S = 0.05
"""How often ``WorkerPool.as_completed`` looks for a finished job [s]."""


def _init_worker() -> None:
    """A worker's start: Ctrl-C left to the parent, the BLAS libraries (loaded after this) and PyTorch
    (where installed) on one thread."""
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    os.environ["OPENBLAS_NUM_THREADS"] = "1"
    try:
        import torch  # optional extra: learn (PyTorch)
    except ImportError:
        return
    torch.set_num_threads(1)


def _timed(fn, args) -> tuple:
    """(fn(*args), CPU time of this process [s], wall time [s]) of the call, the BLAS libraries loaded
    on one thread during it."""
    cpu, wall = time.process_time(), time.perf_counter()
    with one_blas_thread():
        result = fn(*args)
    return result, time.process_time() - cpu, time.perf_counter() - wall


def _sendable(err: BaseException) -> BaseException:
    """``err`` where it survives pickling, else the first of its base classes that does, made from its
    message (a worker's error that cannot be unpickled here would stop the pool's result thread and
    leave ``Job.get`` waiting for ever)."""
    for cls in type(err).__mro__:
        try:
            out = err if cls is type(err) else cls(str(err))
            pickle.loads(pickle.dumps(out))
        except Exception:
            continue
        return out
    return RuntimeError(str(err))


def _sent(fn, args) -> tuple:
    """``_timed`` in a worker: an error raised as one that can be sent back (``_sendable``)."""
    try:
        return _timed(fn, args)
    except Exception as err:
        out = _sendable(err)
        if out is err:
            raise
        raise out from None


@contextmanager
def _sigint_ignored():
    """SIGINT ignored while the workers start, so that they start with it ignored (a process started
    with SIGINT ignored never raises ``KeyboardInterrupt``), the caller's handler restored after."""
    try:
        old = signal.signal(signal.SIGINT, signal.SIG_IGN)
    except ValueError:                   # not the main thread: nothing to change
        yield
        return
    try:
        yield
    finally:
        signal.signal(signal.SIGINT, old)


class Job:
    """A submitted piece of work, named ``label``: ``get()`` returns its result (a worker's error is
    raised there); ``ready()`` says whether ``get()`` would wait for a worker."""

    def __init__(self, pool: WorkerPool, label: str, fn, args: tuple):
        self.pool, self.label = pool, label
        self._pending = None if pool._pool is None else pool._pool.apply_async(_sent, (fn, args))
        self._call = (fn, args) if self._pending is None else None
        self._result = None

    def ready(self) -> bool:
        """Whether the job has finished (or, in this process, can run now)."""
        return self._pending is None or self._pending.ready()

    def wait(self, timeout: float) -> None:
        """Wait at most ``timeout`` [s] for a worker to finish the job."""
        if self._pending is not None:
            self._pending.wait(timeout)

    def get(self):
        """The job's result (in this process: computed now, the first time)."""
        if self._call is not None:
            self._result, cpu, wall = _timed(*self._call)
            self._call = None
            self.pool.timed(self.label, cpu, wall)
        elif self._pending is not None:
            self._result, cpu, wall = self._pending.get()
            self._pending = None
            self.pool.timed(self.label, cpu, wall)
        return self._result


class WorkerPool:
    """``workers`` worker processes (1: none); use as a context manager: a normal exit waits for the
    workers to finish, an exception terminates them.

    Attributes
    ----------
    workers : int
        the worker processes (1: every job runs in this process)
    timings : dict of str to (float, float)
        {job label: (CPU time [s], wall time [s])} of every finished job, in the order finished; the
        jobs of one label summed (their wall times too: worker-seconds)
    """

    def __init__(self, workers: int = 1):
        self.workers = int(workers)
        self.timings: dict[str, tuple[float, float]] = {}
        self._pool = None

    def __enter__(self) -> WorkerPool:
        if self.workers > 1:
            with _sigint_ignored():
                self._pool = multiprocessing.get_context("spawn").Pool(self.workers, initializer=_init_worker)
        return self

    def __exit__(self, kind, error, trace) -> None:
        if self._pool is None:
            return
        if kind is None:
            self._pool.close()
        else:
            self._pool.terminate()
        self._pool.join()
        self._pool = None

    def timed(self, label: str, cpu: float, wall: float) -> None:
        """Add a finished job's CPU and wall time [s] to ``timings[label]``."""
        c, w = self.timings.get(label, (0.0, 0.0))
        self.timings[label] = (c + cpu, w + wall)

    def seconds(self) -> dict:
        """``timings``, JSON-ready: {label: {"cpu": CPU time [s], "wall": wall time [s]}}, rounded to 0.1 s."""
        return {k: {"cpu": round(c, 1), "wall": round(w, 1)} for k, (c, w) in self.timings.items()}

    def submit(self, label: str, fn, *args) -> Job:
        """``fn(*args)`` as a job named ``label``: started in a worker now, or with 1 worker run in this
        process when its result is asked for."""
        return Job(self, label, fn, args)

    def here(self, label: str, fn, *args):
        """``fn(*args)`` run now in this process, as a job named ``label`` that waits for no other (its
        times in ``timings``, BLAS on one thread)."""
        result, cpu, wall = _timed(fn, args)
        self.timed(label, cpu, wall)
        return result

    def map(self, labels, fn, arguments) -> list:
        """[fn(*args) for args in ``arguments``], the calls (named by ``labels``) spread over the workers."""
        return [job.get() for job in [self.submit(label, fn, *args) for label, args in zip(labels, arguments)]]

    def as_completed(self, jobs):
        """Yield each of ``jobs`` as it finishes (with 1 worker: in the order given)."""
        pending = list(jobs)
        while pending:
            done = [j for j in pending if j.ready()]
            if not done:
                pending[0].wait(WAIT_S)
                continue
            job = done[0]
            pending.remove(job)
            yield job
