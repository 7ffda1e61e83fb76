"""Where a calibration's independent simulations run: in this process, or on Dask (a local cluster of
single-threaded worker processes, or a running scheduler given by its address, as for sweeps)."""

from __future__ import annotations

from contextlib import ExitStack

from ..errors import bad
from ..sweeps.dask import dask_client, require


class Evaluator:
    """Runs ``fn(model, values)`` for a list of ``values`` and returns the results in order.

    ``Evaluator()`` runs them one after the other in this process. ``Evaluator(workers=N)`` with
    N > 1, or ``Evaluator(scheduler=ADDRESS)``, runs them on Dask (the ``softrnn[dask]`` extra);
    use it as a context manager so the cluster is started once and closed at the end. The model is
    sent to the workers once (``Client.scatter``).
    """

    def __init__(self, workers: int = 1, scheduler: str | None = None):
        if isinstance(workers, bool) or not isinstance(workers, int) or workers < 1:
            raise bad("--workers", workers, "an integer >= 1")
        if scheduler is not None and (not isinstance(scheduler, str) or not scheduler):
            raise bad("--scheduler", scheduler, "a Dask scheduler address such as tcp://HOST:8786")
        self.scheduler = scheduler
        self._workers = workers
        self._client = None
        self._stack = None
        self._scattered = {}

    @property
    def uses_dask(self) -> bool:
        """Whether the simulations run on Dask."""
        return self.scheduler is not None or self._workers > 1

    @property
    def workers(self) -> int:
        """Simulations that run at the same time (a remote cluster's thread count once connected)."""
        if self._client is not None and self.scheduler is not None:
            return max(1, sum(self._client.nthreads().values()))
        return self._workers

    def __enter__(self):
        if self.uses_dask:
            require()
            self._stack = ExitStack()
            self._client = self._stack.enter_context(dask_client(self.scheduler, self._workers))
        return self

    def __exit__(self, *exc):
        if self._stack is not None:
            self._stack.close()
        self._client = self._stack = None
        self._scattered = {}
        return False

    def map(self, fn, model, values: list) -> list:
        """[fn(model, v) for v in values], in order."""
        if self._client is None:
            if self.uses_dask:
                raise RuntimeError("use the Evaluator as a context manager (with Evaluator(...) as ev:)")
            return [fn(model, v) for v in values]
        held, remote = self._scattered.get("model", (None, None))
        if held is not model:
            remote = self._client.scatter(model, broadcast=True)
            self._scattered = {"model": (model, remote)}
        futures = [self._client.submit(fn, remote, tuple(v), pure=False) for v in values]
        try:
            return self._client.gather(futures)
        finally:
            for f in futures:
                f.cancel()
