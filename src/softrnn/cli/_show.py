"""softrnn show DATA.h5: print a summary of a dataset file (text or JSON)."""

import json

from ..errors import SoftrnnInputError
from ..files import atomic_write_text, prepare_output
from ._progress import DelayedBar
from ._vocabulary import STDOUT, JsonOrSwitch, note

NAME = "show"
HELP = "print a summary of a softrnn dataset file (HDF5)"


def add_args(p):
    p.add_argument("path", nargs="?", default=None, help="dataset file (.h5) written by softrnn")
    p.add_argument("--group", default=None, help="trajectory of a sweep file (default: the first)")
    p.add_argument("--json", action=JsonOrSwitch, nargs="?", default=None, metavar="PATH",
                   help="also write the summary as JSON to PATH; '-': print it as JSON instead of the text")
    p.add_argument("--overwrite", action="store_true", help="replace the --json file if it exists (default: refuse)")
    p.add_argument("--quick", action="store_true",
                   help="do not read and check every value (only the time axis and three nodes)")
    p.add_argument("--quiet", action="store_true", help="no progress bar while every value is checked")


SHOW_AFTER = 1.0
"""Seconds the check of every value runs before its progress bar appears."""


def _path(args) -> str:
    """The dataset's path; ``show --json DATA.h5`` (the old switch before the path) still reads DATA.h5."""
    if args.path is not None:
        return args.path
    if args.json not in (None, STDOUT):
        note(f"--json before the dataset's path is read as the old switch; use 'softrnn show {args.json} --json -'")
        args.json, path = STDOUT, args.json
        return path
    raise SoftrnnInputError("softrnn show: the following arguments are required: path (see 'softrnn show --help')")


def run(args) -> int:
    from ..io.summary import describe

    path = _path(args)
    if args.json not in (None, STDOUT):
        prepare_output(args.json, "--json", overwrite=args.overwrite)
    with DelayedBar("show: checking every value", enabled=not (args.quiet or args.quick),
                    after=SHOW_AFTER) as progress:
        summary = describe(path, group=args.group, verify=not args.quick, progress=progress)
    print(json.dumps(summary, indent=2) if args.json == STDOUT else format_summary(summary))
    if args.json not in (None, STDOUT):
        atomic_write_text(args.json, json.dumps(summary, indent=2))
    return 0


def format_summary(s: dict) -> str:
    """The text ``softrnn show`` prints for a ``describe`` result."""
    a = s["attrs"]
    mb = s["file_size_bytes"] / 1e6
    lines = [f"{s['path']}: softrnn dataset (schema {a['schema_version']}, written by softrnn "
             f"{a['softrnn_version']}), {mb:.3g} MB, {s['bytes_per_value']:.2f} bytes per stored value"]
    if s["kind"] == "sweep":
        groups = s["groups"]
        shown = ", ".join(groups[:4]) + (", ..." if len(groups) > 4 else "")
        lines.append(f"  sweep of {len(groups)} trajectories ({shown}); showing {s['group']}")
    uniform = "uniform" if s["dt_uniform"] else "non-uniform, dt is the median step"
    lines.append(f"  samples: {s['n_samples']}, t = {s['time_start_s']:g} .. {s['time_end_s']:g} s "
                 f"({s['duration_s']:g} s), dt = {s['dt_s']:g} s ({uniform})")
    lines.append(f"  nodes: {s['n_nodes']} of {s['n_nodes_total']} stored ({_nodes(s['nodes'])})")
    rod = a.get("rod")
    if isinstance(rod, dict) and rod:
        parts = []
        for key, label, scale, unit in (("length", "L", 1.0, "m"), ("radius", "r", 1e3, "mm"),
                                        ("youngs_modulus", "E", 1e-6, "MPa"), ("density", "rho", 1.0, "kg/m^3"),
                                        ("n_nodes", "nodes", 1, "")):
            if rod.get(key) is not None:
                parts.append(f"{label} = {rod[key] * scale:g} {unit}".rstrip())
        lines.append("  rod: " + ", ".join(parts))
    else:
        lines.append("  rod: not recorded")
    text = a.get("scenario_text") or ""
    first = text.strip().splitlines()[0] if text.strip() else "(none)"
    n_lines = len(text.strip().splitlines())
    seed = a.get("seed")
    lines.append(f"  seed: {seed if seed is not None else 'none'}; scenario: {first[:70]}"
                 + (f" ... ({n_lines} lines)" if n_lines > 1 or len(first) > 70 else ""))
    for r in s["node_ranges"]:
        lo, hi = r["position_min_m"], r["position_max_m"]
        span = ", ".join(f"{ax} [{l:+.4f}, {h:+.4f}]" for ax, l, h in zip("xyz", lo, hi))
        lines.append(f"  node {r['node']}: {span} m; max |f| = {r['max_force_n']:.4g} N, "
                     f"max |tau| = {r['max_torque_nm']:.4g} N m")
    channels = s.get("actuation") or []
    if channels:
        shown = ", ".join(f"{c['name']} [{c['unit']}] {c['min']:.4g} .. {c['max']:.4g}" for c in channels)
        lines.append(f"  actuation: {len(channels)} channel{'s' if len(channels) > 1 else ''}: {shown}")
    else:
        lines.append("  actuation: none (no inputs recorded: the loads are the nodes' forces and torques)")
    c = s.get("contact")
    if c:
        largest = ("largest not read (--quick)" if c["max_force_n"] is None else
                   f"max |f_c| = {c['max_force_n']:.4g} N, max |tau_c| = {c['max_torque_nm']:.4g} N m")
        lines.append(f"  contact: {', '.join(c['fields'])}; {largest}; obstacles: "
                     f"{', '.join(c['obstacles']) or 'not recorded'}")
    rec = a.get("scenario_record")
    if rec:
        variant = "" if rec.get("variant_index") is None else f", variant {rec['variant_index']}"
        lines.append(f"  scenario record: {rec['name']}{variant}; {len(rec.get('pd', []))} PD law(s), moving "
                     f"clamps {rec.get('moving_clamps') or 'none'}")
    extra = {k: v for k, v in a.items() if k not in ("schema_version", "softrnn_version", "units", "rod",
                                                      "scenario_text", "seed", "dt", "n_nodes_total", "contact",
                                                      "scenario_record")}
    if extra:
        shown = ", ".join(f"{k}={json.dumps(v)}" for k, v in extra.items())
        lines.append(f"  attrs: {shown if len(shown) <= 200 else shown[:197] + '...'}")
    st = s["storage"]["positions"]
    lines.append(f"  storage: {st['dtype']}, chunks {tuple(st['chunks'])}, {st['compression']} "
                 f"level {st['compression_opts']}{' + shuffle' if st['shuffle'] else ''}; "
                 + ("every value checked" if s.get("verified") else "values not checked (--quick)"))
    return "\n".join(lines)


def _nodes(nodes) -> str:
    if len(nodes) > 3 and nodes == list(range(nodes[0], nodes[-1] + 1)):
        return f"{nodes[0]}..{nodes[-1]}"
    if len(nodes) > 10:
        return ", ".join(map(str, nodes[:8])) + ", ..."
    return ", ".join(map(str, nodes))
