"""Run a scenario, optionally into a dataset file, and summarise it (library side of
``softrnn simulate``; returns plain data, prints nothing)."""

import time
from dataclasses import replace

import numpy as np

from ..io.writer import DatasetWriter
from ..progress import Progress
from ..rod import RunConfig, Setup, Simulator
from ..rod.hub import driven_hub, run_channels, run_sink
from ._contact import describe
from .magnetic import MagneticScenario, magnetic_summary
from .record import record_of_text


class _NodeCollector:
    """Sink keeping one saved column's positions and the energy of every chunk."""

    def __init__(self, column: int, forward=None):
        self.column, self.forward = column, forward
        self.positions, self.energy = [], []

    def __call__(self, chunk):
        self.positions.append(chunk.positions[:, self.column])
        self.energy.append(chunk.energy)
        if self.forward is not None:
            self.forward(chunk)


def simulate_summary(*, name: str, title: str, setup: Setup, config: RunConfig, node: int,
                     out_path=None, scenario_text: str = "", seed: int | None = None, attrs: dict | None = None,
                     progress: Progress | None = None, series: dict | None = None,
                     magnetic: MagneticScenario | None = None, record=None) -> dict:
    """Simulate; with ``out_path`` write every saved node to an HDF5 dataset (atomically), with the
    tensions of the setup's tendons as its actuation channels ``tendon_<name>`` [N] (then a hub's,
    ``rod.hub.HUB_CHANNELS``: insertion [m], rotation [rad], a driven one's force and torque) and, with
    contact, the obstacles and the contact loads on the saved nodes, and ``record`` (the scenario's
    ``Scenario.record``, ``softrnn.io.record``; None: that of ``scenario_text``, where it reads, with
    the draws ``attrs["sampled"]`` of variant ``attrs["variant_index"]``) as the file's scenario record.

    Returns a JSON-ready summary: timing, step, the node of interest's range, energy, orthogonality.
    If a dict is passed as ``series`` it receives the arrays time (T,), node_positions (T, 3) [m]
    and energy (T, 3) [J] (kinetic, elastic, gravitational).

    With ``magnetic`` (a magnetic scenario's ``Scenario.magnetic``) it runs the manipulator instead,
    a rod with the magnets' load (``magnetic.magnetic_summary``: every node saved, the coil currents
    as actuation channels); ``setup`` is then unused.
    """
    if out_path is not None and record is None:     # that of the text, with a sweep variant's draws in attrs
        extra = attrs or {}
        index = extra.get("variant_index")
        record = record_of_text(scenario_text, extra.get("sampled"), index if isinstance(index, int) else None)
    if magnetic is not None:
        return magnetic_summary(name=name, title=title, magnetic=magnetic, config=config, node=node,
                                out_path=out_path, scenario_text=scenario_text, seed=seed, attrs=attrs,
                                progress=progress, series=series, record=record)
    node = setup.node_index(node, "node of interest")
    if out_path is None:
        config = replace(config, save_nodes=(node,))
    nodes = list(range(setup.rod.n_nodes)) if config.save_nodes is None else [
        setup.node_index(a, "save_nodes") for a in config.save_nodes]
    hub = driven_hub(setup) if out_path is not None else None   # a driven hub is measured on its node
    for needed in [node] + ([] if hub is None else [hub[0]]):
        if needed not in nodes:
            nodes.append(needed)
            config = replace(config, save_nodes=tuple(nodes))
    sim = Simulator(setup)
    # refuse an absurd run before the file is opened (the node's positions and the energy are kept)
    sim.check_size(config, streamed=True, extra_bytes_per_sample=8 * 6)
    start = time.perf_counter()
    if out_path is None:
        sink = _NodeCollector(nodes.index(node))
        stats = sim.run(config, progress=progress, sink=sink)
    else:
        # tendon tensions are stored as the actuation channels tendon_<name> [N], then the hub's
        with DatasetWriter(out_path, nodes=nodes, n_samples=config.n_samples, dt=config.dt, rod=setup.rod,
                           scenario_text=scenario_text, seed=seed, attrs=attrs, actuation_units=run_channels(setup),
                           contact=setup.contact, record=record) as writer:
            sink = _NodeCollector(nodes.index(node), forward=run_sink(writer.append, setup, nodes))
            stats = sim.run(config, progress=progress, sink=sink)
    total = time.perf_counter() - start
    p = np.concatenate(sink.positions)
    energy = np.concatenate(sink.energy)
    E = energy.sum(axis=1)
    if series is not None:
        series.update(time=sim_time(config, p.shape[0]), node_positions=p, energy=energy)
    R = sim.state.rotations
    rod = setup.rod
    simulated = (config.n_samples - 1) * config.dt
    return {
        "case": name, "title": title, "length_m": rod.length, "radius_m": rod.radius,
        "youngs_modulus_pa": rod.youngs_modulus, "n_nodes": rod.n_nodes, "n_samples": config.n_samples,
        "dt_s": config.dt, "duration_s": simulated, "integrator": config.integrator.name, "step_s": stats.step,
        "substeps": stats.substeps,
        "stable_step_s": sim.stable_step(config.safety), "wall_time_s": stats.wall_time,
        "total_time_s": total, "us_per_node_step": stats.us_per_node_step,
        "realtime_factor": simulated / stats.wall_time if stats.wall_time > 0 else float("inf"),
        "node": node, "node_start_m": p[0].tolist(), "node_min_m": p.min(0).tolist(),
        "node_max_m": p.max(0).tolist(), "energy_start_j": float(E[0]), "energy_end_j": float(E[-1]),
        "max_orthogonality_error": float(np.max(np.abs(np.swapaxes(R, 1, 2) @ R - np.eye(3)))),
        "output": None if out_path is None else str(out_path), "saved_nodes": len(nodes),
    }


def sim_time(config: RunConfig, n: int) -> np.ndarray:
    """Saved times (n,) [s] of a run started at t = 0."""
    return config.dt * np.arange(n)


def contact_lines(setup: Setup) -> list[str]:
    """Lines of ``softrnn scenario show --summary`` on the setup's contact: the law's parameters and
    one line per obstacle (none without contact)."""
    return [] if setup.contact is None else describe(setup.contact)
