"""Sweeps of randomised scenario variants (``run_sweep``, resumable) and the Dask runner that sweeps
and studies share (``dask.completed``: a local cluster or a scheduler's address). Needs the
``softrnn[dask]`` extra at run time."""

from .sweep import SweepResult as SweepResult
from .sweep import run_sweep as run_sweep
from .sweep import trajectory_path as trajectory_path
