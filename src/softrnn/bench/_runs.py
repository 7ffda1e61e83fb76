"""What the simulator benchmark's parts share: the samples a timed span covers, the node an entry
tracks, the warm-up runs that fill numba's cache, the goal mark of a table row."""

import dataclasses
from collections.abc import Callable, Iterable

from ..rod import RunConfig, Simulator
from ..scenarios import load_scenario


def covering_samples(config: RunConfig, duration_s: float) -> int:
    """Samples covering the first ``duration_s`` [s] of a run (at most the config's own)."""
    return int(min(config.n_samples, max(2, 1 + round(duration_s / config.dt))))


def tracked_node(scenario) -> int:
    """The node an integrator or contact entry follows: the scenario's last node of interest (0-based)."""
    nodes = tuple(scenario.nodes_of_interest) or (-1,)
    return scenario.setup.node_index(int(nodes[-1]))


def goal_mark(flag) -> str:
    """A table's goal column: "-" (not measured), "ok" or "MISS"."""
    return "-" if flag is None else ("ok" if flag else "MISS")


def warm_runs(cases, runs: Callable[[object], Iterable[tuple]]) -> None:
    """Run, untimed, each (setup, config) of ``runs(scenario)`` for the scenario of every one of ``cases``
    over 2 samples: the kernels compile into numba's cache (or load from it), so that a later timing in
    another process only loads them. A case that fails is skipped (its timing records the error)."""
    for case in cases:
        try:
            for setup, config in runs(load_scenario(case)):
                Simulator(setup).run(dataclasses.replace(config, n_samples=2))
        except Exception:  # noqa: BLE001  # only numba's cache was to be filled
            continue
