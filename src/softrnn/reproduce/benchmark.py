"""Reproduce step: ``softrnn bench`` (``softrnn.bench.run_all``) into ``bench.json``; and the
background process that compiles its kernels early (``warm_start``)."""

import json
import multiprocessing
import signal
from pathlib import Path

from .. import __version__
from ..bench import run_all
from ..bench.simulator import warm_simulator
from ..files import atomic_write_text
from ..progress import ProgressFactory
from .dynamic import CONFIGS
from .stepfiles import load_step


def _finished(bench_file: Path, quick: bool) -> dict | None:
    """The finished benchmark in ``bench_file`` (this version, these settings), else None."""
    bench = load_step(bench_file, quick)
    return bench if bench is not None and "model" in bench else None


def benchmark_step(out: Path, quick: bool, progress_factory: ProgressFactory | None = None) -> dict:
    """Every benchmark of ``softrnn bench`` (the quick set when ``quick``), skipped when ``bench.json``
    holds a finished result of this version with the same settings."""
    bench_file = out / "bench.json"
    bench = _finished(bench_file, quick)
    if bench is None:
        progress = progress_factory("benchmark") if progress_factory else None
        bench = {"quick": quick, "softrnn_version": __version__,
                 **run_all(quick=quick, progress=progress, dynamic_configs=CONFIGS)}
        atomic_write_text(bench_file, json.dumps(bench, indent=2))
    return bench


def _warm(quick: bool) -> None:
    """The background process of ``warm_start``: ``bench.simulator.warm_simulator``, Ctrl-C left to
    the parent; a failure changes nothing (the benchmark then compiles the kernels itself)."""
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    try:
        warm_simulator(quick)
    except Exception:  # noqa: BLE001  # only numba's cache was to be filled
        pass


def warm_start(out: Path, quick: bool):
    """Start compiling the benchmark's kernels (``bench.simulator.warm_simulator``: the batch, the
    integrator and the contact entries' kernels) in a background process, into numba's cache,
    unless the benchmark is finished: a cold run spends that minute while its first steps leave a
    core idle, not in its last step. Returns the process (join it before the benchmark runs: it
    must not time against it) or None. The figures are unchanged: the same kernels, compiled
    elsewhere."""
    if _finished(out / "bench.json", quick) is not None:
        return None
    process = multiprocessing.get_context("spawn").Process(target=_warm, args=(quick,), name="softrnn-warm-benchmark",
                                                           daemon=True)
    process.start()
    return process
