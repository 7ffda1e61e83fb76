"""softrnn simulate CASE: run one of the paper's cases and print a summary."""

import json

from ..cases import CASE_NAMES, build_case, with_overrides
from ..errors import bad
from ..io_util import atomic_write_text
from ..summary import simulate_case
from ._progress import Bar

NAME = "simulate"
HELP = "run a simulated case (" + ", ".join(CASE_NAMES) + ") and print a summary"


def add_args(p):
    p.add_argument("case", help="case name: " + ", ".join(CASE_NAMES))
    p.add_argument("--samples", type=int, default=None, help="saved samples (default: the paper's count)")
    p.add_argument("--substeps", type=int, default=None, help="solver steps per saved dt (default: automatic)")
    p.add_argument("--dt", type=float, default=None, help="saved interval in s (default: the paper's)")
    p.add_argument("--radius", type=float, default=None, help="override the rod radius [m]")
    p.add_argument("--youngs-modulus", type=float, default=None, help="override Young's modulus [Pa]")
    p.add_argument("--density", type=float, default=None, help="override the density [kg/m^3]")
    p.add_argument("--poisson-ratio", type=float, default=None, help="override Poisson's ratio")
    p.add_argument("--json", default=None, metavar="PATH", help="also write the summary as JSON")
    p.add_argument("--quiet", action="store_true", help="no progress bar")


def run(args) -> int:
    case = build_case(args.case)
    if args.samples is not None and args.samples < 1:
        raise bad("--samples", args.samples, "an integer >= 1")
    rod = {k: getattr(args, k) for k in ("radius", "youngs_modulus", "density", "poisson_ratio")
           if getattr(args, k) is not None}
    case = with_overrides(case, rod=rod, dt=args.dt)
    with Bar(f"simulate {args.case}", enabled=not args.quiet) as bar:
        summary = simulate_case(case, n_samples=args.samples, substeps=args.substeps, progress=bar)
    print(format_summary(summary))
    if args.json:
        atomic_write_text(args.json, json.dumps(summary, indent=2))
    return 0


def format_summary(s: dict) -> str:
    lines = [
        f"{s['case']}: {s['title']}",
        f"  rod: L = {s['length_m']:.4g} m, {s['n_nodes']} nodes, r = {s['radius_m'] * 1e3:.3g} mm, "
        f"E = {s['youngs_modulus_pa'] / 1e6:.3g} MPa",
        f"  samples: {s['n_samples']} at dt = {s['dt_s']:g} s ({s['duration_s']:g} s simulated); "
        f"solver step h = {s['step_s']:.3g} s ({s['substeps']} substeps, stable limit {s['stable_step_s']:.3g} s)",
        f"  wall time: {s['wall_time_s']:.3f} s run, {s['us_per_node_step']:.3f} us per node-step, "
        f"real-time factor {s['realtime_factor']:.1f}",
        f"  node {s['node']}: start {_fmt(s['node_start_m'])} m, min {_fmt(s['node_min_m'])}, max {_fmt(s['node_max_m'])}",
        f"  energy [J]: start {s['energy_start_j']:.4g}, end {s['energy_end_j']:.4g}; "
        f"max |R^T R - I| = {s['max_orthogonality_error']:.1e}",
    ]
    return "\n".join(lines)


def _fmt(v) -> str:
    return "[" + ", ".join(f"{x:+.4f}" for x in v) + "]"
