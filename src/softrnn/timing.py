"""How softrnn measures speed, one way everywhere: the machine a measurement ran on
(``machine_info``, what ``softrnn bench``, ``softrnn reproduce``'s report.json, the Fig. 13 and
Fig. 14 studies and benchmarks/ record beside their timings) and how fast one call is made again
and again (``step_rate``, so that ``softrnn bench``, the Fig. 14 study's bandwidths, Table 1's
``rnn_steps_per_second`` and ``softrnn reproduce``'s stepper speeds are comparable).

The step-rate method: ``warmup`` untimed calls, then ``steps`` calls, each timed alone with
``time.perf_counter_ns`` and the garbage collector paused, split into ``repeats`` consecutive runs.
The rate is the **median over the runs of each run's mean rate** (its calls / the sum of their
times): robust to one run disturbed by other work on the machine, and a mean within a run, so rare
slow calls count. The single call times give the percentiles.
"""

from __future__ import annotations

import gc
import os
import platform
import time
from collections.abc import Callable
from dataclasses import dataclass
from importlib.metadata import PackageNotFoundError, version

import numba
import numpy as np

from .errors import bad, integer


def cpu_model() -> str:
    """The CPU's model name from /proc/cpuinfo (Linux), else ``platform.processor()`` or, when that
    is empty, ``platform.machine()`` (e.g. 'x86_64')."""
    model = platform.processor() or platform.machine()
    try:
        with open("/proc/cpuinfo") as fh:
            for line in fh:
                if line.startswith("model name"):
                    return line.split(":", 1)[1].strip()
    except OSError:
        pass
    return model


def load_average() -> list[float] | None:
    """The 1, 5 and 15 minute load averages, rounded to 0.01 (None where the system has none)."""
    try:
        return [round(x, 2) for x in os.getloadavg()]
    except (AttributeError, OSError):
        return None


def _installed(package: str) -> str | None:
    """The installed version of ``package`` from its metadata (None when not installed); the
    package itself is not imported."""
    try:
        return version(package)
    except PackageNotFoundError:
        return None


def machine_info() -> dict:
    """The machine and software a timing ran on, JSON-ready.

    Returns
    -------
    dict
        ``cpu`` (model name), ``processor`` (``platform.processor()`` or the architecture),
        ``cores`` (``os.cpu_count()``), ``usable_cores`` (those this process may run on),
        ``platform`` (``platform.platform()``), ``system`` (e.g. 'Linux'), ``python``, ``numpy``,
        ``numba``, ``torch`` (None when PyTorch is not installed; read from its metadata, so
        PyTorch is not imported), ``numba_max_threads`` (numba's thread limit) and
        ``load_average`` (1, 5 and 15 min, or None) when this was called.
    """
    usable = len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else os.cpu_count()
    return {
        "cpu": cpu_model(),
        "processor": platform.processor() or platform.machine(),
        "cores": os.cpu_count(),
        "usable_cores": usable,
        "platform": platform.platform(),
        "system": platform.system(),
        "python": platform.python_version(),
        "numpy": np.__version__,
        "numba": numba.__version__,
        "torch": _installed("torch"),
        "numba_max_threads": numba.config.NUMBA_NUM_THREADS,
        "load_average": load_average(),
    }


@dataclass(frozen=True, kw_only=True)
class StepRate:
    """The result of ``step_rate``.

    Attributes
    ----------
    median_hz : float
        Median over the runs of each run's calls per second [Hz].
    mean_hz : float
        All timed calls over their total time [Hz].
    p50_us, p90_us, p99_us : float
        Percentiles of the single call times [us].
    steps : int
        Timed calls, all runs together.
    repeats : int
        Runs the timed calls were split into.
    """

    median_hz: float
    mean_hz: float
    p50_us: float
    p90_us: float
    p99_us: float
    steps: int
    repeats: int

    @property
    def step_us(self) -> float:
        """Time per call at the median rate, 1e6 / ``median_hz`` [us]."""
        return 1e6 / self.median_hz


def _timed_calls(step: Callable[[], object], n: int) -> np.ndarray:
    """Wall time [ns] of each of ``n`` calls of ``step``, timed alone, the garbage collector paused."""
    times = np.empty(n, dtype=np.int64)
    clock = time.perf_counter_ns
    enabled = gc.isenabled()
    gc.disable()
    try:
        for i in range(n):
            t = clock()
            step()
            times[i] = clock() - t
    finally:
        if enabled:
            gc.enable()
    return times


def step_rate(step: Callable[[], object], *, steps: int, repeats: int = 5, warmup: int = 200) -> StepRate:
    """Time ``step()``: ``warmup`` (>= 0) untimed calls, then ``steps`` (>= 1) timed calls in
    ``repeats`` (>= 1) runs of (nearly) equal length (fewer runs when ``steps < repeats``).

    Parameters
    ----------
    step : callable
        Called with no arguments; whatever it returns is ignored. A step that walks through data
        keeps its own position (e.g. ``itertools.cycle`` over row indices).

    Returns
    -------
    StepRate
        The median and mean rates [Hz] and the call-time percentiles [us].
    """
    steps, repeats, warmup = integer("steps", steps), integer("repeats", repeats), integer("warmup", warmup, 0)
    if not callable(step):
        raise bad("step", step, "a callable taking no arguments (one step of what is timed)")
    for _ in range(warmup):
        step()
    times = _timed_calls(step, steps)
    runs = np.array_split(times, min(repeats, steps))
    rates = [run.size / (max(int(run.sum()), 1) * 1e-9) for run in runs]
    p50, p90, p99 = np.percentile(times, (50, 90, 99)) * 1e-3
    return StepRate(median_hz=float(np.median(rates)), mean_hz=steps / (max(int(times.sum()), 1) * 1e-9),
                    p50_us=float(p50), p90_us=float(p90), p99_us=float(p99), steps=steps, repeats=len(runs))
