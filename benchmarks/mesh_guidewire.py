"""A guidewire in a meshed vessel tree: real-time factor on one core, the deepest wall penetration
and the kernels' distance error against the exact reference.

    NUMBA_NUM_THREADS=1 .venv/bin/python benchmarks/mesh_guidewire.py --json benchmarks/results/mesh_guidewire.json
    NUMBA_NUM_THREADS=1 .venv/bin/python benchmarks/mesh_guidewire.py --quick      # the shipped scenario only

Cases:

* ``scenario``: the shipped ``mesh-arch-guidewire`` as shipped (a 0.18 m guidewire, 37 nodes, pushed
  0.1 m up the descending aorta of ``mesh-arch.vtu`` in 2 s, the implicit integrator, 2.5 s);
* ``one_metre``: the same wire 1 m long (101 nodes, 10 mm segments) in ``arch_tree(descending=1.05)``
  (built here, not shipped), its base at z = -1.02 m, pushed 0.1 m in 2 s; the implicit integrator.

Per case: the wall time of the run after a warm-up run (numba compiled), the real-time factor
(simulated / wall time), the deepest penetration of a node's surface into the mesh over the saved
samples (the exact reference ``MeshVessel.gap``, % of the rod radius; goal < 5 %), the tip's final
position and the branch of the centreline it is nearest, and the kernels' distance error: the
kernels' gap (the walk, ``rod.contact_kernels._obstacle_gap``) against the exact one over every node
of every saved sample, in order (the walk starts from each node's face of the sample before): the
largest difference where the exact gap is under 1 mm, and the least kernel - exact anywhere (a walk
that stops on a farther face deep in the lumen only overestimates a positive gap).
The cost of the mesh contact: the wall time per node-step of the first 0.5 s with it and of the same
setup with contact=None at the same solver step (the wire then falls through the wall: only the
contact work differs). A benchmark, not a test: pytest never collects it.
"""

import argparse
import json
import sys
import time
from dataclasses import replace

import numpy as np
from numba import njit

from softrnn.files import atomic_write_text
from softrnn.geometry.mesh import arch_tree
from softrnn.rod import Contact, RunConfig, Setup, Simulator, straight
from softrnn.rod.contact import MeshVessel, initial_segments, kernel_arrays
from softrnn.rod.contact_kernels import _obstacle_gap
from softrnn.rod.kernel_records import StepInputs
from softrnn.scenarios import load_scenario
from softrnn.timing import machine_info


@njit(cache=False)
def _kernel_gaps(path, ra, inputs, out):
    for s in range(path.shape[0]):
        for a in range(path.shape[1]):
            out[s, a] = _obstacle_gap(a, 0, path[s, a, 0], path[s, a, 1], path[s, a, 2], ra, inputs)[0]


def kernel_error(setup: Setup, positions: np.ndarray) -> dict:
    """The kernels' gaps against the exact ones over the saved positions (S, n, 3), walked in order:
    the largest |difference| [m] where the exact gap is under 1 mm (near the wall), and the least
    kernel - exact [m] anywhere (negative: a false touch)."""
    rod = setup.rod
    arrays = kernel_arrays(setup.contact, rod, np.array(setup.gravity, dtype=float))
    inputs = StepInputs(ext_idx=np.zeros(0, np.int64), ext_w=np.zeros((1, 0, 12)), pd_idx=np.zeros(0, np.int64),
                        pd_target=np.zeros((1, 0, 3)), pd_gain=np.zeros((0, 2)), presc_idx=np.zeros(0, np.int64),
                        presc_r=np.zeros((2, 0, 3)), presc_R=np.zeros((2, 0, 3, 3)),
                        contact_segment=initial_segments(setup.contact, positions[0]), **arrays)
    out = np.zeros(positions.shape[:2])
    _kernel_gaps(positions, rod.radius, inputs, out)
    mesh = setup.contact.obstacles[0]
    exact = mesh.gap(positions.reshape(-1, 3), np.full(positions.shape[0] * positions.shape[1], rod.radius))[0]
    diff = out.reshape(-1) - exact
    near = exact < 0.001
    return {"near_wall_max_abs_m": float(np.max(np.abs(diff[near]), initial=0.0)), "near_wall_nodes": int(near.sum()),
            "least_kernel_minus_exact_m": float(diff.min()), "nodes": int(diff.size),
            "farther_face_share": float(np.mean(np.abs(diff) > 1e-12))}


def one_metre(base: Setup) -> Setup:
    """The shipped scenario's wire made 1 m long in a 1.05 m descending aorta."""
    mesh = MeshVessel(*arch_tree(descending=1.05), inlet=(0.0, 0.0, -1.05))
    rod = replace(base.rod, length=1.0, n_nodes=101)
    shape = straight(101, 1.0, origin=(0.0, -0.0054, -1.02), direction=(0.0, 0.0, 1.0), normal=(0.0, 1.0, 0.0))
    contact = Contact(obstacles=(mesh,), friction=base.contact.friction, stiffness=base.contact.stiffness)
    clamp = base.boundary[0]
    clamp = replace(clamp, motion=replace(clamp.motion, position=tuple(shape.positions[0])))
    return replace(base, rod=rod, reference=shape, initial=shape, contact=contact, boundary=(clamp,))


def contact_cost(setup: Setup, config: RunConfig, substeps: int, span_s: float = 0.5) -> dict:
    """Wall time per node-step [us] of the first ``span_s`` s with the mesh contact and of the same
    setup with contact=None at the same solver step (only the tracked tip saved)."""
    timed = replace(config, n_samples=int(round(span_s / config.dt)) + 1, substeps=substeps,
                    save_nodes=(setup.rod.n_nodes - 1,))
    out = {}
    for name, case in (("with_contact", setup), ("without_contact", replace(setup, contact=None))):
        Simulator(case).run(replace(timed, n_samples=3))
        start = time.perf_counter()
        Simulator(case).run(timed)
        out[f"us_per_node_step_{name}"] = (time.perf_counter() - start) / (substeps * (timed.n_samples - 1)
                                                                          * setup.rod.n_nodes) * 1e6
    out["overhead"] = out["us_per_node_step_with_contact"] / out["us_per_node_step_without_contact"] - 1
    return out


def measure(setup: Setup, config: RunConfig) -> dict:
    """One case's figures (see the module docstring)."""
    Simulator(setup).run(replace(config, n_samples=3))                   # compile
    start = time.perf_counter()
    traj = Simulator(setup).run(config)
    wall = time.perf_counter() - start
    cost = contact_cost(setup, config, traj.substeps)
    mesh, r = setup.contact.obstacles[0], setup.rod.radius
    gaps = np.array([mesh.gap(p, np.full(len(p), r))[0] for p in traj.positions])
    simulated = float(traj.time[-1] - traj.time[0])
    tip = traj.positions[-1, -1]
    centre = mesh.centreline
    return {"nodes": setup.rod.n_nodes, "length_m": setup.rod.length, "simulated_s": simulated, "wall_s": wall,
            "real_time_factor": simulated / wall, "solver_steps": int(traj.substeps * (len(traj.time) - 1)),
            "deepest_penetration_percent_of_r": float(max(0.0, -gaps.min()) / r * 100),
            "tip_final_m": tip.tolist(), "tip_branch": centre.nearest_branch(tip),
            "tip_progress_m": float(mesh.centreline_progress(tip[None], centre.nearest_branch(tip))[0]),
            "kernel_distance_error": kernel_error(setup, traj.positions), **cost}


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--json", help="write the results here")
    parser.add_argument("--quick", action="store_true", help="the shipped scenario only")
    args = parser.parse_args(argv)
    sc = load_scenario("mesh-arch-guidewire")
    config = RunConfig(dt=sc.config.dt, n_samples=sc.config.n_samples, integrator=sc.config.integrator)
    results = {"machine": machine_info(), "scenario": measure(sc.setup, config)}
    if not args.quick:
        results["one_metre"] = measure(one_metre(sc.setup), config)
    text = json.dumps(results, indent=2)
    if args.json:
        atomic_write_text(args.json, text + "\n")
    sys.stdout.write(text + "\n")
    return 0


if __name__ == "__main__":
    sys.exit(main())
