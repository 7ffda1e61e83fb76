"""softrnn calibrate DATA --scenario FILE.toml --fit KEY[,KEY...] -o FITTED.toml: fit chosen values of a
scenario to a recorded dataset; writes the fitted scenario, a JSON report and a figure (resumable)."""

import json
import shutil
from pathlib import Path

from ..errors import SoftrnnInputError, bad
from ..files import atomic_write_bytes, atomic_write_text, json_default, prepare_output
from ._progress import Bar
from ._vocabulary import deprecate, output

NAME = "calibrate"
HELP = ("fit chosen values of a scenario (dotted keys, e.g. rod.youngs_modulus) to a recorded dataset: the "
        "fitted scenario file, a JSON report with standard errors, and a figure")


def add_args(p):
    from ..fitting import FitOptions

    p.add_argument("data", metavar="DATA",
                   help="the recorded dataset (.h5, e.g. from softrnn simulate -o or import-csv)")
    p.add_argument("--group", default=None, help="the trajectory's group inside a sweep file")
    p.add_argument("--scenario", required=True, metavar="FILE.toml",
                   help="the scenario of the recorded rod (a .toml file or a shipped scenario's name); bounds of the "
                        "fitted values from its [calibrate] table (or their [randomize] ranges)")
    p.add_argument("--fit", required=True, metavar="KEY[,KEY...]",
                   help="dotted keys of the values to fit, e.g. rod.youngs_modulus,damping.translational")
    output(p, dest="out", required=True, metavar="FITTED.toml", help="the scenario with the fitted values")
    p.add_argument("--span", default="train", metavar="SPAN",
                   help="the samples fitted: train (default: the first 60 %%), all, or T0:T1 in seconds")
    p.add_argument("--nodes", default=None, metavar="NODES",
                   help="the recorded nodes to fit, e.g. 25,50,75 or 20..30 (-1: the last; default: all)")
    p.add_argument("--workers", type=int, default=1,
                   help="simulations at once: 1 (default) in this process, N > 1 on a local Dask cluster")
    p.add_argument("--scheduler", default=None, metavar="tcp://HOST:PORT",
                   help="run the simulations on an existing Dask cluster")
    p.add_argument("--max-evaluations", type=int, default=FitOptions().max_evaluations, metavar="N",
                   help=f"most points the optimiser evaluates, each 1 simulation plus 1 per key for its "
                        f"derivatives (default {FitOptions().max_evaluations})")
    deprecate(p, p.add_argument("--json", dest="report", default=None, metavar="PATH",
                                help="the JSON report (default: FITTED.json)"), "--report")
    p.add_argument("--figure", default=None, metavar="PATH.png", help="the figure of the fit (default: FITTED.png)")
    p.add_argument("--overwrite", action="store_true", help="replace the output files if they exist (default: refuse)")
    p.add_argument("--quiet", action="store_true", help="no progress bar")


def _outputs(args) -> tuple[Path, Path, Path]:
    """(-o, --json, --figure) checked before any work: suffixes, distinct, writable."""
    from ..figures.data import FIGURE_SUFFIXES, check_suffix

    out = Path(args.out)
    if out.suffix.lower() != ".toml":
        raise bad("-o", args.out, "a scenario file name ending in .toml")
    report = Path(args.report) if args.report is not None else out.with_suffix(".json")
    figure = Path(args.figure) if args.figure is not None else out.with_suffix(".png")
    if report.suffix.lower() != ".json":
        raise bad("--json", str(report), "a file name ending in .json")
    check_suffix(figure, FIGURE_SUFFIXES, "--figure")
    paths = [("-o", out), ("--json", report), ("--figure", figure)]
    for i, (argument, path) in enumerate(paths):
        for other, earlier in paths[:i]:
            if path.absolute() == earlier.absolute():
                raise bad(argument, str(path), f"a path other than {other}'s")
        prepare_output(path, argument, overwrite=args.overwrite)
    return out, report, figure


def _nodes(text):
    """The recorded nodes to fit: ``_vocabulary.node_list`` with -1 the last node (None: all)."""
    from ._vocabulary import node_list

    return None if text is None else node_list(text, "--nodes", negative=True)


def _figure_bytes(cal, suffix: str, title: str) -> bytes:
    """The figure of the fit, rendered in memory (written with the other outputs at the end)."""
    from ..figures.calibration import calibration_fit, moving_node
    from ..figures.saving import figure_bytes

    column = moving_node(cal.measured)
    fig = calibration_fit(cal.time, cal.measured, cal.start, cal.fitted, column, cal.nodes[column],
                          f"{title}: node {cal.nodes[column]}")
    return figure_bytes(fig, suffix)


def run(args) -> int:
    from ..calibration.parallel import Evaluator
    from ..calibration.scenario import HEADER, fitted_text, prepare
    from ..calibration.scenario import run as run_calibration
    from ..fitting import FitOptions
    from ..io.reader import read_dataset
    from ..scenarios.scenario import load_scenario, parse_scenario

    out, report_path, figure_path = _outputs(args)
    if isinstance(args.max_evaluations, bool) or args.max_evaluations < 2:
        raise bad("--max-evaluations", args.max_evaluations, "an integer >= 2")
    nodes = _nodes(args.nodes)
    try:
        scenario = load_scenario(args.scenario)
    except SoftrnnInputError as err:    # the library's scenario=... is this command's --scenario=...
        if str(err).startswith("scenario="):
            raise SoftrnnInputError(f"--{err}") from None
        raise
    if scenario.magnetic is not None:
        raise bad("--scenario", scenario.name, "a plain rod scenario: softrnn calibrate does not fit magnetic "
                                               "scenarios (the manipulator's rod and loads are set in [magnetic])")
    dataset = read_dataset(args.data, group=args.group)
    cache = out.parent / f".{out.name}.trials"
    options = FitOptions(max_evaluations=args.max_evaluations)
    problem = prepare(scenario, dataset, args.fit, span=args.span, nodes=nodes, data=str(args.data))
    with Evaluator(workers=args.workers, scheduler=args.scheduler) as evaluator, \
            Bar(f"calibrate {scenario.name}", unit="trial", enabled=not args.quiet) as bar:
        cal = run_calibration(problem, evaluator=evaluator, options=options, progress=bar, cache_dir=cache)
    values = cal.values()
    header = (f"{HEADER} calibrate from {Path(args.data).name} (span {args.span}): "
              + ", ".join(f"{k} = {v:.7g} (was {p.start:.7g})" for (k, v), p in zip(values.items(), cal.parameters)))
    text = fitted_text(scenario.text, values, header)
    parse_scenario(text, scenario.source)          # loadable by softrnn simulate, or a bug here
    report = {"data": str(args.data), "scenario": str(args.scenario), "output": str(out), **cal.to_dict()}
    picture = _figure_bytes(cal, figure_path.suffix.lower(), f"calibrate {scenario.name}")
    atomic_write_text(out, text)
    atomic_write_text(report_path, json.dumps(report, indent=2, default=json_default, allow_nan=False) + "\n")
    atomic_write_bytes(figure_path, picture)
    shutil.rmtree(cache, ignore_errors=True)
    print(summary(cal, report, [out, report_path, figure_path]))
    return 0


def summary(cal, report: dict, written) -> str:
    """The lines ``softrnn calibrate`` prints."""
    r, sp, e = cal.result, report["span"], report["error"]
    width = max(len(n) for n in r.names)
    lines = [f"calibrate {', '.join(r.names)} to {report['data']}: span {sp['label']} ({sp['start_s']:g}-"
             f"{sp['stop_s']:g} s, {sp['samples'][1] - sp['samples'][0]} samples), {len(cal.nodes)} node"
             f"{'s' if len(cal.nodes) != 1 else ''}, {cal.model.substeps} solver steps per sample"]
    for p, f, s in zip(cal.parameters, r.fitted, r.std_error):
        lines.append(f"  {p.name:<{width}}  {p.start:.7g} -> {f:.7g} +- {s:.2g}  (bounds {p.lower:g}..{p.upper:g})")
    lines.append(f"  error over the span, rms / max in % of L: start {e['start']['rms_percent_of_length']:.4g} / "
                 f"{e['start']['max_percent_of_length']:.4g}, fitted {e['fitted']['rms_percent_of_length']:.4g} / "
                 f"{e['fitted']['max_percent_of_length']:.4g}")
    lines.append(f"  {r.trials} trials ({r.failed_trials} failed, {r.cached_trials} from an earlier run) in "
                 f"{r.seconds:.1f} s; {'converged' if r.success else 'not converged'}: {r.message}")
    lines += [f"  warning: not identifiable: {w}" for w in r.not_identifiable]
    lines.append("  wrote " + ", ".join(str(p) for p in written))
    return "\n".join(lines)
