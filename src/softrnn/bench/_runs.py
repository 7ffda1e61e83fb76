"""What the simulator benchmark's parts share: the samples a timed span covers, the node an entry
tracks, the goal mark of a table row."""

from ..rod import RunConfig


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
