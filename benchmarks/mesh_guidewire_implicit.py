"""Linearly implicit contact (``Contact(implicit=True)``) on a 1 m guidewire in a meshed vessel: the
real-time factor on one core (CPU time) and the deepest wall penetration against the step, and the
tip's error against a small-step reference.

    NUMBA_NUM_THREADS=1 .venv/bin/python benchmarks/mesh_guidewire_implicit.py --json out.json

The case: ``softrnn.rod.guidewire`` 1 m long, 101 nodes (10 mm segments), a nitinol core tapering to a
soft tip pre-bent by 20 deg over its last 30 mm (``bend=(20, 0.03, 0)``: the stock angled tip needs 5 mm
segments), in ``arch_tree(descending=1.05)`` (as ``benchmarks/mesh_guidewire.py``'s ``one_metre``),
its base held by a ``Hub`` at z = -1.02 m that inserts it 0.05 m and turns it by pi over ``--duration``
s (smoothstep tables); friction 0.1, stiffness 2e6 N/m^2 per length, the implicit integrator. Runs:
explicit contact at its automatic step (the step it needs), then implicit contact at each step of
``--steps``; the reference is the smallest implicit-contact step. ``--scenario`` also runs the shipped
``mesh-arch-guidewire-1m`` (the same wire and arch, inserted 0.1 m and turned by pi in 2 s, 2.5 s)
as shipped and at the automatic step. A benchmark, not a test.
"""

import argparse
import json
import sys
import time
from dataclasses import replace

import numpy as np

from softrnn.errors import SimulationError
from softrnn.files import atomic_write_text
from softrnn.geometry.mesh import arch_tree
from softrnn.rod import Clamp, Contact, Damping, Hub, RunConfig, Setup, Simulator, guidewire
from softrnn.rod.contact import MeshVessel
from softrnn.scenarios import load_scenario
from softrnn.timing import machine_info


def setup_1m(duration: float, implicit: bool) -> Setup:
    """The guidewire of the module docstring, its hub inserting and turning it over ``duration`` s."""
    device = guidewire(1.0, 101, bend=(20.0, 0.03, 0.0), origin=(0.0, -0.0054, -1.02), direction=(0.0, 0.0, 1.0),
                       normal=(0.0, 1.0, 0.0))
    t = np.linspace(0.0, duration, 21)
    s = t / duration
    smooth = s * s * (3 - 2 * s)
    hub = Hub(entry=tuple(device.reference.positions[0]), axis=(0.0, 0.0, 1.0),
              rotation0=device.reference.rotations[0], insertion=(t, 0.05 * smooth), rotation=(t, np.pi * smooth))
    mesh = MeshVessel(*arch_tree(descending=1.05), inlet=(0.0, 0.0, -1.05))
    contact = Contact(obstacles=(mesh,), friction=0.1, stiffness=2e6, implicit=implicit)
    return Setup(rod=device.rod, reference=device.reference, boundary=(Clamp(0, motion=hub),),
                 gravity=(0.0, -9.81, 0.0), damping=Damping(translational=0.05), contact=contact)


def run_case(setup: Setup, config: RunConfig) -> dict:
    """One run's CPU time, real-time factor, deepest penetration (% of r) and tip path."""
    Simulator(setup).run(replace(config, n_samples=3))                   # compile
    start = time.process_time()
    traj = Simulator(setup).run(config)
    cpu = time.process_time() - start
    mesh = setup.contact.obstacles[0]
    radius = setup.rod.node_properties()["radius"]
    gaps = np.array([mesh.gap(p, radius)[0] for p in traj.positions])
    simulated = float(traj.time[-1] - traj.time[0])
    return {"step_s": traj.step, "cpu_s": cpu, "real_time_factor_cpu": simulated / cpu,
            "deepest_penetration_percent_of_r": float(np.max(np.maximum(0.0, -gaps) / radius) * 100),
            "tip": traj.positions[:, -1]}


SCENARIO = "mesh-arch-guidewire-1m"


def scenario_runs(results: dict, substeps=()) -> None:
    """results["scenario"] <- the shipped ``mesh-arch-guidewire-1m`` as shipped, at the automatic step
    and at each number of ``substeps`` per saved interval."""
    sc = load_scenario(SCENARIO)
    out = {}
    configs = [("as_shipped", sc.config), ("auto", replace(sc.config, substeps=None))]
    configs += [(f"substeps_{k}", replace(sc.config, substeps=k)) for k in substeps]
    for name, config in configs:
        try:
            run = run_case(sc.setup, config)
        except SimulationError as err:
            out[name] = {"error": str(err)}
            continue
        run["tip_final_m"] = run.pop("tip")[-1].tolist()
        out[name] = run
        sys.stderr.write(f"{SCENARIO} {name}: {json.dumps(run)}\n")
    results["scenario"] = {SCENARIO: out}


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--json", help="write the results here")
    parser.add_argument("--duration", type=float, default=1.0, help="simulated time [s]")
    parser.add_argument("--steps", type=float, nargs="+", default=[2e-5, 1e-4, 2.5e-4, 5e-4, 1e-3, 2e-3])
    parser.add_argument("--no-explicit", action="store_true", help="skip the explicit-contact run")
    parser.add_argument("--scenario", action="store_true", help=f"also run the shipped {SCENARIO}")
    parser.add_argument("--only-scenario", action="store_true", help=f"run the shipped {SCENARIO} only")
    parser.add_argument("--scenario-substeps", type=int, nargs="*", default=[],
                        help="also run the scenario at these solver steps per saved interval")
    args = parser.parse_args(argv)
    dt = max(args.steps)
    config = RunConfig(dt=dt, n_samples=int(round(args.duration / dt)) + 1, integrator="implicit")
    results = {"machine": machine_info(), "runs": {}}
    cases = [] if args.no_explicit else [("explicit_contact_auto", setup_1m(args.duration, False), None)]
    cases += [(f"implicit_contact_h{h:g}", setup_1m(args.duration, True), int(round(dt / h)))
              for h in sorted(args.steps)]
    if args.only_scenario:
        cases = []
    if args.scenario or args.only_scenario:
        scenario_runs(results, args.scenario_substeps)
    ref = None
    for name, setup, substeps in cases:
        try:
            out = run_case(setup, replace(config, substeps=substeps))
        except SimulationError as err:
            results["runs"][name] = {"error": str(err)}
            continue
        if ref is None and name.startswith("implicit"):
            ref = out["tip"]
        out["tip_final_m"] = out["tip"][-1].tolist()
        if ref is not None:
            out["tip_error_vs_reference_max_m"] = float(np.linalg.norm(out["tip"] - ref, axis=1).max())
        del out["tip"]
        results["runs"][name] = out
        sys.stderr.write(f"{name}: {json.dumps(out)}\n")
    text = json.dumps(results, indent=2)
    if args.json:
        atomic_write_text(args.json, text + "\n")
    sys.stdout.write(text + "\n")
    return 0


if __name__ == "__main__":
    sys.exit(main())
