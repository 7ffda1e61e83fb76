"""How long a command takes to start: ``softrnn --version``, ``softrnn --help`` and ``softrnn scenario
list``, each in a fresh interpreter, interpreter start-up included (what a user waits for). Part of the
simulator benchmark (``simulator.commands``; benchmarks/README.md)."""

import os
import resource
import statistics
import subprocess
import sys
import time

from ._runs import goal_mark

COMMANDS = {"version": ("--version",), "help": ("--help",), "scenario_list": ("scenario", "list")}
"""The commands timed: name -> the arguments of ``softrnn``."""

GOALS = {"version": 0.3, "help": 0.3, "scenario_list": 1.0}
"""Each command's goal for its median wall time [s]."""


def _children_cpu() -> float:
    """CPU time [s] of the finished child processes so far (user + system)."""
    usage = resource.getrusage(resource.RUSAGE_CHILDREN)
    return usage.ru_utime + usage.ru_stime


def time_command(argv, reps: int) -> dict:
    """``python -m softrnn.cli.main ARGV`` run ``reps`` times, each in a fresh interpreter with
    NUMBA_NUM_THREADS=1: the wall times [s] of every run (``runs_s``), their median, and the median
    CPU time [s] of a run (below the wall time when the run waited for a core or the disk)."""
    env = dict(os.environ, NUMBA_NUM_THREADS="1")
    walls, cpus = [], []
    for _ in range(reps):
        cpu = _children_cpu()
        start = time.perf_counter()
        proc = subprocess.run([sys.executable, "-m", "softrnn.cli.main", *argv], env=env, capture_output=True,
                              text=True, timeout=300)
        walls.append(time.perf_counter() - start)
        cpus.append(_children_cpu() - cpu)
        if proc.returncode != 0:
            raise RuntimeError(f"softrnn {' '.join(argv)} failed ({proc.returncode}): {proc.stderr.strip()[-2000:]}")
    return {"argv": list(argv), "median_s": statistics.median(walls), "runs_s": walls,
            "cpu_s": statistics.median(cpus), "goal_s": GOALS.get(_name(argv))}


def _name(argv) -> str | None:
    return next((name for name, args in COMMANDS.items() if tuple(argv) == args), None)


def time_commands(reps: int, commands: dict | None = None) -> dict:
    """``time_command`` of each of ``commands`` (default ``COMMANDS``), by name."""
    return {name: time_command(argv, reps) for name, argv in (commands or COMMANDS).items()}


def commands_met(commands: dict) -> dict:
    """``<name>_start_s`` -> whether the command's median wall time met its goal (None: no goal)."""
    return {f"{name}_start_s": (e["median_s"] <= e["goal_s"]) if e.get("goal_s") is not None else None
            for name, e in commands.items()}


def format_commands(commands: dict) -> list[str]:
    """The table lines of ``time_commands``' result."""
    lines = ["command start-up (fresh interpreter, interpreter start included; median wall of the runs)"]
    for e in commands.values():
        goal = e.get("goal_s")
        judged = "" if goal is None else f"   goal <= {goal:.1f} s   {goal_mark(e['median_s'] <= goal)}"
        runs = ", ".join(f"{w:.2f}" for w in e["runs_s"])
        lines.append(f"  softrnn {' '.join(e['argv']):<16}{e['median_s']:>6.2f} s{judged}   (cpu {e['cpu_s']:.2f} s; "
                     f"runs {runs})")
    return lines
