"""Run a case and summarise it (library side of ``softrnn simulate``; returns plain data)."""

import numpy as np

from .cases import Case
from .rod import RunConfig, Simulator


def simulate_case(case: Case, *, n_samples: int | None = None, substeps: int | None = None,
                  progress=None, save_all: bool = False) -> dict:
    """Simulate ``case`` and return a JSON-ready summary (floats and lists only).

    Saves the node of interest only unless ``save_all`` (the timing then includes all outputs).
    """
    cfg = case.config
    config = RunConfig(dt=cfg.dt, n_samples=n_samples or cfg.n_samples,
                       substeps=substeps if substeps is not None else cfg.substeps,
                       save_nodes=None if save_all else (case.node_of_interest,), safety=cfg.safety)
    sim = Simulator(case.setup)
    traj = sim.run(config, progress=progress)
    a = case.node_of_interest if save_all else 0
    p = traj.positions[:, a]
    rod = case.setup.rod
    E = traj.energy.sum(axis=1)
    R = sim.state.rotations
    ortho = float(np.max(np.abs(np.swapaxes(R, 1, 2) @ R - np.eye(3))))
    simulated = traj.time[-1] - traj.time[0]
    return {
        "case": case.name, "title": case.title, "paper_section": case.paper_section,
        "length_m": rod.length, "radius_m": rod.radius, "youngs_modulus_pa": rod.youngs_modulus,
        "n_nodes": rod.n_nodes, "n_samples": int(traj.time.size), "dt_s": config.dt,
        "duration_s": float(simulated), "step_s": traj.step, "substeps": traj.substeps,
        "stable_step_s": sim.stable_step(config.safety), "wall_time_s": traj.wall_time,
        "us_per_node_step": 1e6 * traj.wall_time / max(traj.n_steps * rod.n_nodes, 1),
        "realtime_factor": float(simulated / traj.wall_time) if traj.wall_time > 0 else float("inf"),
        "node": case.node_of_interest, "node_start_m": p[0].tolist(), "node_min_m": p.min(0).tolist(),
        "node_max_m": p.max(0).tolist(), "energy_start_j": float(E[0]), "energy_end_j": float(E[-1]),
        "max_orthogonality_error": ortho,
    }
