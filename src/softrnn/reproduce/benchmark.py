"""Reproduce step: ``softrnn bench`` (``softrnn.bench.run_all``) into ``bench.json``."""

import json
from pathlib import Path

from .. import __version__
from ..bench import run_all
from ..files import atomic_write_text
from ..progress import ProgressFactory
from .dynamic import CONFIGS
from .stepfiles import load_step


def benchmark_step(out: Path, quick: bool, progress_factory: ProgressFactory | None = None) -> dict:
    """Every benchmark of ``softrnn bench`` (the quick set when ``quick``), skipped when ``bench.json``
    holds a finished result of this version with the same settings."""
    bench_file = out / "bench.json"
    bench = load_step(bench_file, quick)
    if bench is None or "model" not in bench:
        progress = progress_factory("benchmark") if progress_factory else None
        bench = {"quick": quick, "softrnn_version": __version__,
                 **run_all(quick=quick, progress=progress, dynamic_configs=CONFIGS)}
        atomic_write_text(bench_file, json.dumps(bench, indent=2))
    return bench
