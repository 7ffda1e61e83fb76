"""softrnn simulate SCENARIO [-o data.h5]: run a scenario, print a summary, optionally save it."""

import json
from dataclasses import replace

from ..errors import bad
from ..files import atomic_write_text, prepare_output
from ._names import INTEGRATORS, SCENARIO_NAMES
from ._progress import Bar
from ._vocabulary import output

NAME = "simulate"
HELP = "run a scenario (" + ", ".join(SCENARIO_NAMES) + ", or a .toml file) and print a summary"


def add_args(p):
    p.add_argument("scenario", help="a shipped scenario name or a path to a .toml file")
    output(p, dest="out", default=None, metavar="PATH.h5", help="save every node to this HDF5 dataset")
    p.add_argument("--samples", type=int, default=None, help="saved samples (default: the scenario's)")
    p.add_argument("--duration", type=float, default=None, metavar="SECONDS",
                   help="simulated time in s: the saved samples that span it at the saved interval (instead of "
                        "--samples; default: the scenario's)")
    p.add_argument("--substeps", type=int, default=None, help="solver steps per saved dt (default: the scenario's)")
    p.add_argument("--dt", type=float, default=None, help="saved interval in s (default: the scenario's)")
    p.add_argument("--integrator", choices=INTEGRATORS, default=None,
                   help="the solver (default: the scenario's): explicit, or implicit for stiff rods")
    p.add_argument("--radius", type=float, default=None, help="override the rod radius [m]")
    p.add_argument("--youngs-modulus", type=float, default=None, help="override Young's modulus [Pa]")
    p.add_argument("--density", type=float, default=None, help="override the density [kg/m^3]")
    p.add_argument("--poisson-ratio", type=float, default=None, help="override Poisson's ratio")
    p.add_argument("--json", default=None, metavar="PATH", help="also write the summary as JSON")
    p.add_argument("--overwrite", action="store_true",
                   help="replace the -o and --json files if they exist (default: refuse)")
    p.add_argument("--quiet", action="store_true", help="no progress bar")


def run(args) -> int:
    from ..scenarios.scenario import load_scenario
    from ..scenarios.summary import simulate_summary

    scenario = load_scenario(args.scenario)
    if args.samples is not None and args.samples < 1:
        raise bad("--samples", args.samples, "an integer >= 1")
    if args.out is not None and not str(args.out).endswith((".h5", ".hdf5")):
        raise bad("-o", args.out, "a file name ending in .h5 or .hdf5")
    for argument, path in (("-o", args.out), ("--json", args.json)):
        if path is not None:
            prepare_output(path, argument, overwrite=args.overwrite)
    setup, config = scenario.setup, scenario.config
    rod = {k: getattr(args, k) for k in ("radius", "youngs_modulus", "density", "poisson_ratio")
           if getattr(args, k) is not None}
    if scenario.magnetic is not None:
        _check_magnetic(args, rod)
    if rod:
        setup = replace(setup, rod=replace(setup.rod, **rod))
    samples = args.samples if args.duration is None else _samples(args, config.dt)
    changes = {k: v for k, v in (("dt", args.dt), ("n_samples", samples), ("substeps", args.substeps),
                                 ("integrator", args.integrator)) if v is not None}
    if changes:
        config = replace(config, **changes)
    with Bar(f"simulate {scenario.name}", enabled=not args.quiet) as bar:
        summary = simulate_summary(name=scenario.name, title=scenario.title, setup=setup, config=config,
                                   node=scenario.nodes_of_interest[0], out_path=args.out,
                                   scenario_text=scenario.text, seed=scenario.seed,
                                   attrs={"scenario_name": scenario.name}, progress=bar,
                                   magnetic=scenario.magnetic, record=scenario.record)
    print(format_summary(summary))
    if args.json:
        atomic_write_text(args.json, json.dumps(summary, indent=2))
    return 0


def _samples(args, scenario_dt: float) -> int:
    """The saved samples whose span is ``--duration`` s at the saved interval (``(samples - 1) dt``)."""
    if args.samples is not None:
        raise bad("--duration", args.duration, "one of --duration and --samples, not both")
    dt = scenario_dt if args.dt is None else args.dt
    if not 0 < args.duration < float("inf") or not dt > 0:
        raise bad("--duration", args.duration, "a simulated time > 0 s")
    return max(2, round(args.duration / dt) + 1)


def _check_magnetic(args, rod: dict) -> None:
    """Refuse the options a magnetic scenario (the manipulator's run) does not honour."""
    for name in rod:
        flag = "--" + name.replace("_", "-")
        raise bad(flag, rod[name], "no rod override for a magnetic scenario (its rod is the manipulator's: set "
                                   "[magnetic] keys in the scenario file)")


def format_summary(s: dict) -> str:
    lines = [
        f"{s['case']}: {s['title']}",
        f"  rod: L = {s['length_m']:.4g} m, {s['n_nodes']} nodes, r = {s['radius_m'] * 1e3:.3g} mm, "
        f"E = {s['youngs_modulus_pa'] / 1e6:.3g} MPa",
        f"  samples: {s['n_samples']} at dt = {s['dt_s']:g} s ({s['duration_s']:g} s simulated); "
        f"{s['integrator']} solver step h = {s['step_s']:.3g} s ({s['substeps']} substeps, explicit stable limit "
        f"{s['stable_step_s']:.3g} s)",
        f"  time: {s['total_time_s']:.2f} s in all ({s['wall_time_s']:.2f} s stepping and saving, "
        f"{s['us_per_node_step']:.3f} us per node-step, real-time factor {s['realtime_factor']:.1f})",
        f"  node {s['node']}: start {_fmt(s['node_start_m'])} m, min {_fmt(s['node_min_m'])}, "
        f"max {_fmt(s['node_max_m'])}",
        f"  energy [J]: start {s['energy_start_j']:.4g}, end {s['energy_end_j']:.4g}; "
        f"max |R^T R - I| = {s['max_orthogonality_error']:.1e}",
    ]
    if s.get("currents_a") is not None:
        where = f", tip in: {s['tip_branch']}" if s.get("tip_branch") else ""
        lines.append("  coil currents [A]: " + ", ".join(f"{i if abs(i) >= 5e-3 else 0.0:.2f}" for i in s["currents_a"])
                     + where)
    if s["output"]:
        lines.append(f"  wrote {s['output']} ({s['saved_nodes']} nodes x {s['n_samples']} samples)")
    return "\n".join(lines)


def _fmt(v) -> str:
    return "[" + ", ".join(f"{x:+.4f}" for x in v) + "]"
