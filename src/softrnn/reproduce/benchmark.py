"""Reproduce step: ``softrnn bench`` (``softrnn.bench.run_all``) into ``bench.json``; and the
background processes that compile its kernels early (``warm_start``)."""

import json
import multiprocessing
import signal
from pathlib import Path

from .. import __version__
from ..bench import run_all
from ..bench.model import warm_manipulator
from ..bench.simulator import warm_simulator
from ..errors import bad
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


WARM_PARTS = ("simulator", "model")
"""What ``warm_start`` compiles: the simulator benchmark's kernels (``bench.simulator.warm_simulator``:
the batch, the integrator and the contact entries') or the model benchmark's manipulator kernels
(``bench.model.warm_manipulator``)."""


def _warm(quick: bool, part: str = "simulator") -> None:
    """The background process of ``warm_start``: ``part``'s warm-up (``WARM_PARTS``), Ctrl-C left to
    the parent; a failure changes nothing (the benchmark then compiles the kernels itself)."""
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    try:
        if part == "simulator":
            warm_simulator(quick)
        else:
            warm_manipulator()
    except Exception:  # noqa: BLE001  # only numba's cache was to be filled
        pass


def warm_start(out: Path, quick: bool, part: str = "simulator"):
    """Start compiling the kernels of the benchmark's ``part`` (``WARM_PARTS``) in a background process,
    into numba's cache, unless the benchmark is finished: a cold run spends that time where a step leaves
    a core idle (the simulator's minute while the first steps run, the model's while the magnetic step
    starts), not in its last step, which runs on one core. Returns the process (join it before the
    benchmark runs: it must not time against it) or None. The figures are unchanged: the same kernels,
    compiled elsewhere."""
    if part not in WARM_PARTS:
        raise bad("part", part, f"one of {', '.join(WARM_PARTS)}")
    if _finished(out / "bench.json", quick) is not None:
        return None
    process = multiprocessing.get_context("spawn").Process(target=_warm, args=(quick, part),
                                                           name=f"softrnn-warm-benchmark-{part}", daemon=True)
    process.start()
    return process
