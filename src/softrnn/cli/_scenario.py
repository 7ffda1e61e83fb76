"""softrnn scenario list | show NAME | copy NAME -o FILE: the shipped scenarios, their TOML text, a
short description, and an editable copy to simulate or calibrate."""

from __future__ import annotations

import json
import os
import sys
from pathlib import Path
from typing import TYPE_CHECKING

from ..errors import SoftrnnInputError, bad
from ..files import atomic_write_text, prepare_output
from ._names import SCENARIO_NAMES
from ._vocabulary import output

if TYPE_CHECKING:
    from ..scenarios.scenario import Scenario

NAME = "scenario"
READS_DATASETS = False
"""``scenario list``, ``show`` and ``copy`` read no data set: ``main`` need not register the reader of
older files' scenario records (``softrnn.scenarios``, which imports the simulator) first."""
HELP = ("the shipped scenarios: list them, show one's TOML text or a summary, copy one to a file to edit, "
        "simulate or calibrate")


def add_args(p):
    sub = p.add_subparsers(title="subcommands", dest="scenario_command", required=True,
                           metavar="{list,show,copy}")
    ls = sub.add_parser("list", help="one line per shipped scenario: name, nodes, duration, integrator, title",
                        description="One line per shipped scenario: its name, nodes, simulated duration, "
                                    "integrator and title.")
    ls.add_argument("--json", default=None, metavar="PATH", help="also write the list as JSON to PATH")
    ls.add_argument("--overwrite", action="store_true", help="replace the --json file if it exists (default: refuse)")
    ls.set_defaults(scenario_run=_list)
    sh = sub.add_parser("show", help="print a scenario's TOML text (exactly as shipped), or --summary",
                        description="Print the TOML text of a shipped scenario exactly as shipped (or of a .toml "
                                    "file, after loading and checking it); --summary: a short description.")
    sh.add_argument("name", metavar="NAME", help="a shipped scenario's name (softrnn scenario list) or a .toml file")
    sh.add_argument("--summary", action="store_true",
                    help="a short description (rod, shapes, boundary, loads, run, tables, assumptions) instead")
    sh.set_defaults(scenario_run=_show)
    cp = sub.add_parser("copy", help="write a shipped scenario's TOML to a file, to edit, simulate or calibrate",
                        description="Write a shipped scenario's TOML text to FILE (atomically; an existing FILE "
                                    "only with --overwrite), then edit it and run softrnn simulate FILE or "
                                    "softrnn calibrate DATA --scenario FILE.")
    cp.add_argument("name", metavar="NAME", help="a shipped scenario's name (softrnn scenario list)")
    output(cp, dest="out", default=None, metavar="FILE.toml", help="the file to write (required)")
    cp.add_argument("--overwrite", action="store_true", help="replace FILE if it exists (default: refuse)")
    cp.set_defaults(scenario_run=_copy)


def run(args) -> int:
    return args.scenario_run(args)


def _emit(text: str) -> None:
    """Write ``text`` to stdout; a reader that stops early (``| head``) ends the output quietly."""
    try:
        sys.stdout.write(text)
        sys.stdout.flush()
    except BrokenPipeError:
        os.dup2(os.open(os.devnull, os.O_WRONLY), sys.stdout.fileno())   # no second error at exit


def _names() -> str:
    return ", ".join(SCENARIO_NAMES)


def _shipped(name: str) -> str:
    """``name`` if it is a shipped scenario, else the one-line error listing them."""
    if name not in SCENARIO_NAMES:
        raise bad("NAME", name, f"a shipped scenario, one of {_names()} (softrnn scenario list describes them)")
    return name


def _load(name: str) -> Scenario:
    """A shipped scenario by name, or a scenario file by path (loaded and checked)."""
    from ..scenarios.scenario import load_scenario

    if name in SCENARIO_NAMES:
        return load_scenario(name)
    path = Path(name)
    if path.is_file():
        return load_scenario(path)
    if path.is_dir():
        raise bad("NAME", name, "a .toml file, not a folder, or a shipped scenario's name")
    if path.suffix.lower() == ".toml" or "/" in name or "\\" in name:
        raise bad("NAME", name, f"an existing .toml file (no such file), or a shipped scenario: one of {_names()}")
    return load_scenario(_shipped(name))


# ------------------------------------------------------------------------------------------- list
def entry(sc: Scenario) -> dict:
    """The JSON-ready line of ``softrnn scenario list`` for one scenario."""
    config = sc.config
    return {"name": sc.name, "title": sc.title, "n_nodes": sc.setup.rod.n_nodes,
            "duration_s": (config.n_samples - 1) * config.dt, "dt_s": config.dt, "n_samples": config.n_samples,
            "integrator": config.integrator.name, "paper_section": sc.paper.get("section"),
            "role": sc.paper.get("role"),
            "randomize": list(sc.randomize), "calibrate": list(sc.calibrate)}


def format_list(entries: list[dict]) -> str:
    """The lines ``softrnn scenario list`` prints: a header, one line per scenario, a hint."""
    width = max(len("name"), *(len(e["name"]) for e in entries))
    lines = [f"{'name':<{width}}  {'nodes':>5}  {'duration':>8}  {'integrator':<10}  title"]
    for e in entries:
        lines.append(f"{e['name']:<{width}}  {e['n_nodes']:>5}  {e['duration_s']:>6.4g} s  {e['integrator']:<10}  "
                     f"{e['title']}")
    lines.append("softrnn scenario show NAME [--summary] prints one; softrnn scenario copy NAME -o FILE.toml "
                 "writes one to edit")
    return "\n".join(lines)


def built_listing() -> list[dict]:
    """The lines of ``softrnn scenario list``, built from the shipped scenarios (imports the simulator)."""
    from ..scenarios.scenario import load_scenario

    return [entry(load_scenario(name)) for name in SCENARIO_NAMES]


def built_summaries() -> dict:
    """{name: the lines of ``softrnn scenario show NAME --summary``} of the shipped scenarios, built
    from them (imports the simulator)."""
    from ..scenarios.scenario import load_scenario

    return {name: summary(load_scenario(name)).split("\n") for name in SCENARIO_NAMES}


SUMMARIES = "scenario-summaries.json"
"""The kept lines of ``scenario show NAME --summary`` of the shipped scenarios: ``{name: [line, ...]}``
in the package's ``data/`` folder (``write_listing``)."""


def _data_file(name: str):
    """A file of the package's ``data/`` folder (a ``Traversable``), found without importing the simulator."""
    from importlib import resources

    return resources.files("softrnn").joinpath("data").joinpath(name)


def write_listing() -> None:
    """Rewrite the kept lines of ``scenario list`` (``_scenario_list.py``) and of each ``scenario show
    NAME --summary`` (``data/scenario-summaries.json``) from the shipped scenarios, after editing one."""
    import pprint

    path = Path(__file__).with_name("_scenario_list.py")
    text = path.read_text(encoding="utf-8")
    head = text[:text.index("SCENARIO_LIST = ")]
    body = pprint.pformat(built_listing(), width=116, sort_dicts=False)
    atomic_write_text(path, f"{head}SCENARIO_LIST = {body}\n")
    atomic_write_text(Path(__file__).parents[1] / "data" / SUMMARIES, json.dumps(built_summaries(), indent=1) + "\n")


def kept_summaries() -> dict:
    """The kept lines of ``scenario show NAME --summary``: ``{name: [line, ...]}`` (``write_listing``)."""
    return json.loads(_data_file(SUMMARIES).read_text(encoding="utf-8"))


def _list(args) -> int:
    from ._scenario_list import SCENARIO_LIST

    if args.json is not None:
        prepare_output(args.json, "--json", overwrite=args.overwrite)
    entries = SCENARIO_LIST
    print(format_list(entries))
    if args.json is not None:
        atomic_write_text(args.json, json.dumps({"scenarios": entries}, indent=2) + "\n")
    return 0


# ------------------------------------------------------------------------------------------- show
def shipped_text(name: str) -> str:
    """The TOML text of the shipped scenario ``name`` as shipped (``scenarios.scenario.scenario_text``),
    read without importing the simulator."""
    from importlib import resources

    return resources.files("softrnn").joinpath("scenarios").joinpath(f"{name}.toml").read_text(encoding="utf-8")


def _show(args) -> int:
    if args.name in SCENARIO_NAMES:     # shipped text, kept lines (tests/cli/test_startup.py): no simulator imported
        _emit("\n".join(kept_summaries()[args.name]) + "\n" if args.summary else shipped_text(args.name))
        return 0
    sc = _load(args.name)
    if args.summary:
        _emit(summary(sc) + "\n")
    else:
        _emit(sc.text)      # exactly the file's text: a shipped one as shipped
    return 0


def _num(x) -> str:
    return f"{x:g}" if isinstance(x, (int, float)) and not isinstance(x, bool) else json.dumps(x)


def _pa(x: float) -> str:
    return f"{x / 1e9:.4g} GPa" if x >= 1e9 else f"{x / 1e6:.4g} MPa" if x >= 1e6 else f"{x:.4g} Pa"


def _node(value, n: int) -> str:
    return str(value % n) if isinstance(value, int) and not isinstance(value, bool) else _num(value)


def _kind(table) -> str:
    """The kind of a profile table (or ``constant`` for a bare value), with a schedule noted."""
    if not isinstance(table, dict):
        return f"constant {_num(table)}"
    kind = table.get("kind", "profile")
    return f"{kind}, scheduled" if "schedule" in table else kind


def _shapes(data: dict) -> str:
    ref = data.get("reference", {}).get("kind", "?")
    initial = data.get("initial")
    if initial is None:
        start = "the reference"
    elif "from" in initial:
        start = f"from {initial['from']}"
    else:
        start = initial.get("kind", "?")
    return f"  shapes: reference {ref}, initial {start}"


def _boundary_and_loads(data: dict, n: int) -> list[str]:
    bounds = []
    for b in data.get("boundary", []):
        moving = [k for k in ("displacement", "rotation") if k in b]
        bounds.append(f"{b.get('kind')} at node {_node(b.get('node'), n)}"
                      + (f" ({' and '.join(moving)} {', '.join(_kind(b[k]) for k in moving)})" if moving else ""))
    hub = data.get("hub")
    if isinstance(hub, dict):            # insertion and rotation at the hub (scenario-format.md#hub)
        inputs = [f"{k} {_kind(hub[k])}" for k in ("insertion", "rotation", "force", "torque") if k in hub]
        bounds.append(f"hub at node {_node(hub.get('node', 0), n)}" + (f" ({' and '.join(inputs)})" if inputs else ""))
    loads = []
    for ld in data.get("loads", []):
        what = ld.get("target") if ld.get("kind") == "pd" else ld.get("profile")
        loads.append(f"{ld.get('kind')} on node {_node(ld.get('node'), n)} ({_kind(what)})")
    tendons = []
    for t in data.get("tendons", []):
        drive = "displacement" if "displacement" in t else "tension"
        tendons.append(f"{t.get('name')} ({drive} {_kind(t.get(drive))})")
    return [f"  boundary: {'; '.join(bounds) or 'none (free)'}",
            f"  loads: {'; '.join(loads) or 'none'}" + (f"; tendons: {'; '.join(tendons)}" if tendons else "")]


def _environment(data: dict) -> str:
    gravity = data.get("gravity", [0.0, 0.0, 0.0])
    g = f"[{', '.join(_num(x) for x in gravity)}] m/s^2" if isinstance(gravity, list) else f"{_kind(gravity)} profile"
    damping = ", ".join(f"{k} {_num(v)}" for k, v in data.get("damping", {}).items()) or "none"
    return f"  gravity: {g}; damping: {damping}"


def _magnetic(sc: Scenario) -> list[str]:
    """The lines of a magnetic scenario's manipulator, coils and environment."""
    m = sc.magnetic
    spec, d = m.spec, m.spec.damping
    magnets = ", ".join(f"{mg.grade} at {mg.arc_length * 1e3:.4g} mm" for mg in spec.magnets)
    drive = (f"field [{', '.join(_num(b * 1e3) for b in m.field)}] mT at the centre, " if m.field is not None
             else "") + "currents [" + ", ".join(f"{i if abs(i) >= 5e-3 else 0.0:.2f}" for i in m.currents) + "] A"
    a = spec.advance
    base = ("" if a is None else f", advanced {a.distance * 1e3:.4g} mm along +x from {a.start:g} s over {a.ramp:g} s")
    return [f"  magnetic: the manipulator, magnets {magnets}; base clamped at "
            f"[{', '.join(_num(x) for x in spec.base)}] m, straight along +x{base}",
            f"  coils: {drive}; zero until {m.start:g} s, ramp {m.ramp:g} s, then held; settling {m.settle:g} s",
            f"  gravity: [{', '.join(_num(x) for x in spec.gravity)}] m/s^2; damping: translational "
            f"{_num(d.translational)}, rotational {_num(d.rotational)}, kelvin_voigt {_num(d.kelvin_voigt)}"]


def _run(sc: Scenario) -> str:
    c, n = sc.config, sc.setup.rod.n_nodes
    substeps = "auto" if c.substeps is None else str(c.substeps)
    interest = ", ".join(str(a % n) for a in sc.nodes_of_interest)
    return (f"  run: {c.n_samples} samples every {c.dt:g} s ({(c.n_samples - 1) * c.dt:g} s), substeps {substeps}, "
            f"{c.integrator} integrator; nodes of interest {interest}")


def _tables(sc: Scenario) -> list[str]:
    lines = []
    if sc.randomize:
        lines.append(f"  randomize (softrnn sweep): {', '.join(sc.randomize)}")
    if sc.calibrate:
        lines.append("  calibrate (softrnn calibrate --fit): "
                     + ", ".join(f"{k} in [{lo:g}, {hi:g}]" for k, (lo, hi, _) in sc.calibrate.items()))
    else:
        lines.append("  calibrate: no [calibrate] table (add one to fit values, docs/scenario-format.md)")
    return lines


def summary(sc: Scenario) -> str:
    """The short description ``softrnn scenario show NAME --summary`` prints."""
    from ..scenarios.summary import contact_lines

    rod, data = sc.setup.rod, sc.data
    paper = ", ".join(f"{k} {v}" for k, v in sc.paper.items() if k in ("section", "dataset", "role"))
    lines = [f"{sc.name}: {sc.title}", f"  source: {sc.source}" + (f"; paper: {paper}" if paper else "")]
    if sc.paper.get("note"):
        lines.append(f"  note: {sc.paper['note']}")
    overrides = len(data.get("rod", {}).get("overrides", []))
    shear = f"G = {_pa(rod.shear_modulus)}" if rod.shear_modulus is not None else f"nu = {rod.poisson_ratio:g}"
    lines.append(f"  rod: L = {rod.length:.4g} m, r = {rod.radius * 1e3:.4g} mm, {rod.n_nodes} nodes, "
                 f"E = {_pa(rod.youngs_modulus)}, rho = {rod.density:g} kg/m^3, {shear}"
                 + (f", {overrides} section override{'s' if overrides > 1 else ''}" if overrides else "")
                 + (f", {len(rod.sections)} material sections" if rod.sections else ""))
    if sc.magnetic is not None:
        lines += _magnetic(sc)
    else:
        lines.append(_shapes(data))
        lines += _boundary_and_loads(data, rod.n_nodes)
        lines.append(_environment(data))
    lines += contact_lines(sc.setup)
    lines.append(_run(sc))
    lines.append(f"  seed: {sc.seed}")
    lines += _tables(sc)
    if sc.assumptions:
        lines.append("  assumptions:")
        lines += [f"    {k}: {v}" for k, v in sc.assumptions.items()]
    return "\n".join(lines)


# ------------------------------------------------------------------------------------------- copy
def _copy(args) -> int:
    from ..scenarios.scenario import load_scenario, scenario_text

    name = _shipped(args.name)
    if args.out is None:
        raise SoftrnnInputError(f"-o is missing: give the file to write, e.g. softrnn scenario copy {name} "
                                f"-o my-{name}.toml")
    out = Path(args.out)
    if out.suffix.lower() != ".toml":
        raise bad("-o", args.out, f"a scenario file name ending in .toml, e.g. my-{name}.toml")
    prepare_output(out, "-o", overwrite=args.overwrite)
    text = renamed(scenario_text(name), out.stem, f"A copy of the shipped scenario {name}, to edit")
    atomic_write_text(out, text)
    print(next_steps(load_scenario(name), out, len(text.splitlines())))
    return 0


def renamed(text: str, name: str, title: str) -> str:
    """A scenario's TOML ``text`` with its top-level ``name`` and ``title`` replaced (a copy is no
    longer the shipped scenario: its name and title must not describe that one)."""
    import re

    for key, value in (("name", name), ("title", title)):
        text, n = re.subn(rf"^{key} = .*$", f"{key} = {json.dumps(value)}", text, count=1, flags=re.M)
        if not n:                      # not set at the top: put it after ``format``
            text = re.sub(r"^(format = .*)$", rf"\1\n{key} = {json.dumps(value)}", text, count=1, flags=re.M)
    return text


def next_steps(sc: Scenario, out: Path, n_lines: int) -> str:
    """What ``softrnn scenario copy`` prints: where the copy went and the commands to run next."""
    fit = ",".join(list(sc.calibrate)[:2]) if sc.calibrate else "KEY"
    lines = [f"wrote {out} ({n_lines} lines, a copy of the shipped scenario {sc.name}, named {out.stem})",
             f"next: edit it, then: softrnn simulate {out}",
             f"  or fit it to a recording: softrnn calibrate DATA.h5 --scenario {out} --fit {fit} "
             f"-o {out.with_name(out.stem + '-fitted.toml')}"]
    if not sc.calibrate:
        lines.append("  (calibrate needs bounds for each fitted key: add a [calibrate] table, "
                     "docs/scenario-format.md)")
    return "\n".join(lines)
