"""The rods of a batch over threads: a batched kernel that advances rods ``b0 .. b1 - 1`` (compiled
with ``nogil=True``) is called on contiguous blocks of rods, one block per thread, the calling
thread taking the first.

Why not numba's ``prange``: a ``parallel=True`` kernel outlines its loop body into a function of its
own and optimises the whole inlined integrator once more there; on an empty cache the first call
of the batched kernels took 52 s (explicit) and 131 s (implicit, the environments') with it, against
21 s and 64-68 s now. The work per rod is the same either way, so every rod's results are the same to the bit.

The thread count is numba's (``numba.get_num_threads()``; ``numba.set_num_threads`` or
``NUMBA_NUM_THREADS`` sets it), at most one thread per rod.
"""

import os
import threading
from concurrent.futures import ThreadPoolExecutor, wait

import numba

_LOCK = threading.Lock()
_POOL: dict = {}   # "pool", "size", "pid": the helper threads (none made before the first batch of 2+ threads)


def thread_count(n_rods: int) -> int:
    """The threads a batch of ``n_rods`` rods runs on: numba's thread count, at most ``n_rods``, at least 1."""
    return max(1, min(int(numba.get_num_threads()), int(n_rods)))


def blocks(n_rods: int, n_threads: int) -> list:
    """``n_threads`` contiguous blocks (b0, b1) covering rods 0 .. n_rods - 1, as even as can be."""
    edges = [n_rods * i // n_threads for i in range(n_threads + 1)]
    return list(zip(edges[:-1], edges[1:]))


def _helpers(n: int) -> ThreadPoolExecutor:
    """A pool of ``n`` helper threads, made again after a fork (a child inherits no running threads)
    or when more are needed."""
    with _LOCK:
        if _POOL.get("pid") != os.getpid() or _POOL["size"] < n:
            old = _POOL.get("pool") if _POOL.get("pid") == os.getpid() else None
            if old is not None:
                old.shutdown(wait=False)
            _POOL.update(pool=ThreadPoolExecutor(max_workers=n, thread_name_prefix="softrnn-rods"), size=n,
                         pid=os.getpid())
        return _POOL["pool"]


def over_rods(kernel, n_rods: int, *args) -> None:
    """``kernel(*args, b0, b1)`` for every block of rods (``blocks``), at once on ``thread_count``
    threads; an exception in any block is raised here once every block has ended."""
    n_threads = thread_count(n_rods)
    spans = blocks(n_rods, n_threads)
    if n_threads == 1:
        kernel(*args, 0, n_rods)
        return
    futures = [_helpers(n_threads - 1).submit(kernel, *args, b0, b1) for b0, b1 in spans[1:]]
    try:
        kernel(*args, *spans[0])
    finally:
        wait(futures)   # no block still runs on the caller's arrays when this returns
    for future in futures:
        future.result()
