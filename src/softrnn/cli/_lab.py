"""softrnn lab benchmark | calibrate: a real robot's recordings (docs/guide/real-robots.md)."""

from __future__ import annotations

import dataclasses
import json
import re
import sys
from pathlib import Path
from typing import TYPE_CHECKING

from ..errors import SoftrnnInputError, bad
from ..files import atomic_write_text, prepare_output
from ._lazy import numpy as np
from ._names import FAMILIES
from ._progress import Bar, stop_code
from ._vocabulary import deprecate, output

if TYPE_CHECKING:
    from ..lab.benchmark import BenchmarkOptions
    from ..lab.recording import Layout
    from ..lab.suite import SuiteJob
    from ..scenarios.suite import Suite, SuiteRobot

NAME = "lab"
HELP = "a real robot's recordings: benchmark every model family against baselines, calibrate the tendon physics"


def _recording_args(q, suite: bool = False):
    q.add_argument("--length", type=float, required=not suite, metavar="L_M",
                   help="the robot's length in m" + (" (required without --suite)" if suite else ""))
    q.add_argument("--inputs", default=None, metavar="PATTERN[,PATTERN]",
                   help="the input columns, shell patterns in order (default: act_*, else servo_*)")
    q.add_argument("--tip", default=None, metavar="X,Y,Z", help="the tip columns (default: tip_x,tip_y,tip_z)")
    q.add_argument("--position-unit", default=None, choices=("m", "mm", "cm"),
                   help="the tip columns' unit (default: mm for tip_*, m for n<i>_*)")
    q.add_argument("--lag", default="auto", metavar="N|auto",
                   help="rows the tip lags its command (default: auto, estimated on the training sessions)")
    q.add_argument("--segments", default=None, metavar="L1,L2,...",
                   help="segment lengths in m, base to tip (default: the inputs split in segments of "
                        "--tendons-per-segment, of equal length)")
    q.add_argument("--tendons-per-segment", type=int, default=3, metavar="N",
                   help="tendons per segment; the inputs are in segment order (default: 3)")
    q.add_argument("--routing-radius", type=float, default=None, metavar="M",
                   help="the tendons' distance from the backbone in m, a start value the calibration fits; a "
                        "pull beyond pi x it per segment the tendon runs through is refused (default: not known: "
                        "0.0045 to start from, and only a pull beyond what the widest routing the calibration "
                        "fits allows is refused)")
    q.add_argument("--overwrite", action="store_true", help="replace the output files if they exist (default: refuse)")
    q.add_argument("--quiet", action="store_true", help="no progress bar")


_SINGLE_ONLY = ("train", "validate", "figure", "families", "length", "inputs", "tip", "position_unit", "lag",
                "segments", "tendons_per_segment", "routing_radius", "synthetic", "scenario")
"""``lab benchmark``'s options of one robot, which a suite file gives per robot instead."""


def add_args(p):
    sub = p.add_subparsers(title="subcommands", dest="lab_command", required=True)
    b = sub.add_parser("benchmark", help="fit every model family and baseline on training sessions and run them "
                                         "free over a validation session",
                       description="fit every model family and baseline on the training sessions only and run "
                                   "each free over the validation session from its start on the commands alone; "
                                   "report the Euclidean tip RMSE and mean error in mm and % of the length")
    b.add_argument("--train", nargs="+", default=None, metavar="TRAIN.csv",
                   help="training sessions (CSV; required without --suite)")
    b.add_argument("--validate", default=None, metavar="VAL.csv",
                   help="the validation session (CSV; required without --suite)")
    deprecate(b, b.add_argument("--json", required=True, metavar="PATH",
                                help="the benchmark's JSON (with --suite: the suite's table; each robot's report "
                                     "goes to the folder PATH's stem + '-robots' beside it)"), "-o", "--output")
    b.add_argument("--figure", default=None, metavar="PATH.png",
                   help="also draw the validation session's tip beside the best model and baseline")
    b.add_argument("--families", default=",".join(FAMILIES), metavar="NAME,...",
                   help=f"softrnn's model families to run (default: {','.join(FAMILIES)})")
    b.add_argument("--synthetic", type=float, default=None, metavar="N",
                   help="synthetic rows from the calibrated physics for the learned families, N times the real "
                        "rows (0: none; default: 5 where the physics can be calibrated, else none)")
    b.add_argument("--scenario", default=None, metavar="NAME|FILE",
                   help="the robot's dynamic description (a scenario name such as tendon-spatial, or a TOML file) "
                        "for the dynamic families on recordings of tendon tensions in N (default: none, skipped)")
    b.add_argument("--suite", default=None, metavar="FILE.toml",
                   help="run every robot of a suite file instead (docs/guide/real-robots.md); the robots' "
                        "sessions and options come from the file")
    b.add_argument("--markdown", default=None, metavar="PATH.md", help="also write the table in Markdown")
    b.add_argument("--resume", action="store_true",
                   help="with --suite: keep the robots an interrupted run finished (same sessions and options)")
    b.add_argument("--workers", default="2", metavar="N",
                   help="worker processes the independent fits run in at once (1: one after the other in this "
                        "process; the figures do not depend on it; default: 2)")
    _recording_args(b, suite=True)
    b.set_defaults(lab_run=_benchmark,
                   lab_single={a.dest: a.default for a in b._actions if a.dest in _SINGLE_ONLY})
    c = sub.add_parser("calibrate", help="fit the tendon robot's physics to recordings' quasi-static poses",
                       description="fit the displacement-driven tendon robot (piecewise constant curvature, "
                                   "series stiffness, slack) to the recorded tip; write its parameters as JSON")
    c.add_argument("recordings", nargs="+", metavar="TRAIN.csv", help="the sessions to fit on (CSV)")
    output(c, old=(), required=True, metavar="ROBOT.json", help="the calibrated robot (JSON)")
    c.add_argument("--validate", default=None, metavar="VAL.csv", help="also report the tip error on this session")
    c.add_argument("--gravity", action="store_true",
                   help="add the backbone's weight to the physics, its direction fitted (default: without)")
    c.add_argument("--friction", action="store_true",
                   help="add friction along the tendons' routing (capstan), its coefficient fitted (default: without)")
    c.add_argument("--play", action="store_true",
                   help="add the tendons' play (friction that sticks: a reversal of a servo reaches the robot only "
                        "after twice the play), its width fitted (default: without)")
    c.add_argument("--creep", action="store_true",
                   help="add the tendons' creep (every tendon's slack grows under load over the rows' times), its "
                        "rate fitted (default: without)")
    c.add_argument("--twist", action="store_true",
                   help="with --creep: the robot also turns about its axis as its tendons creep, the turn per mm of "
                        "creep slack fitted (default: without)")
    _recording_args(c)
    c.set_defaults(lab_run=_calibrate)


def _lag(text):
    if text == "auto":
        return "auto"
    try:
        value = int(text)
    except ValueError:
        value = -1
    if value < 0:
        raise bad("--lag", text, "a whole number of rows >= 0, or auto")
    return value


def _workers(text) -> int:
    try:
        value = int(text)
    except ValueError:
        value = 0
    if value < 1:
        raise bad("--workers", text, "a whole number of worker processes >= 1 (1: none, all in this process)")
    return value


def _segments(text):
    if text is None:
        return None
    try:
        values = tuple(float(x) for x in text.split(","))
    except ValueError:
        values = ()
    if not values or not all(v > 0 for v in values):
        raise bad("--segments", text, "positive segment lengths in m, base to tip, e.g. 0.1,0.1,0.022")
    return values


def _as_option(err: SoftrnnInputError) -> SoftrnnInputError:
    """The library's ``name=value is invalid`` as the command's ``--name=value is invalid``."""
    text = str(err)
    m = re.match(r"^([a-z_]+)=", text)
    return SoftrnnInputError("--" + m.group(1).replace("_", "-") + text[m.end(1):] if m else text)


def _layout(args) -> Layout:
    from ..lab.recording import Layout

    try:
        return Layout(inputs=args.inputs or (), tip=args.tip, position_unit=args.position_unit)
    except SoftrnnInputError as err:
        raise _as_option(err) from None


def _read(paths, layout):
    from ..lab.recording import check_sessions, read_recording

    recordings = [read_recording(p, layout) for p in paths]
    check_sessions(recordings)
    return recordings


def _synthetic(amount):
    from ..lab.synthetic import SyntheticOptions

    if amount is None:
        return None
    if not np.isfinite(amount) or amount < 0:
        raise bad("--synthetic", amount, "a multiple of the real rows >= 0 (0: no synthetic data)")
    return SyntheticOptions(amount=amount)


def _options(args, families) -> BenchmarkOptions:
    from ..lab.benchmark import BenchmarkOptions

    try:
        return BenchmarkOptions(length=args.length, lag=_lag(args.lag), segments=_segments(args.segments),
                                tendons_per_segment=args.tendons_per_segment, routing_radius=args.routing_radius,
                                families=families, synthetic=_synthetic(getattr(args, "synthetic", None)),
                                scenario=getattr(args, "scenario", None), workers=_workers(getattr(args, "workers", 1)))
    except SoftrnnInputError as err:
        raise _as_option(err) from None


def _benchmark(args) -> int:
    from ..figures.lab import benchmark_figure
    from ..figures.saving import save_figure
    from ..lab.benchmark import run_benchmark
    from ..lab.recording import read_recording
    from ..lab.suite import SuiteResult, SuiteRow

    if args.suite:
        return _suite(args)
    missing = [flag for flag, value in (("--train", args.train), ("--validate", args.validate),
                                        ("--length", args.length)) if value is None]
    if missing:
        raise SoftrnnInputError(f"the following arguments are required: {', '.join(missing)} (or give --suite "
                                "FILE.toml)")
    if args.resume:
        raise SoftrnnInputError("--resume keeps the finished robots of a --suite run; without --suite there is "
                                "nothing to resume: leave it out")
    prepare_output(args.json, "--json", overwrite=args.overwrite)
    for path, flag in ((args.figure, "--figure"), (args.markdown, "--markdown")):
        if path:
            prepare_output(path, flag, overwrite=args.overwrite)
    options = _options(args, tuple(f.strip() for f in args.families.split(",") if f.strip()))
    layout = _layout(args)
    train = _read(args.train, layout)
    validation = read_recording(args.validate, layout)
    with Bar("lab benchmark", unit="stage", enabled=not args.quiet) as bar:
        try:
            result = run_benchmark(train, validation, options, progress=bar)
        except SoftrnnInputError as err:
            raise (_as_option(err) if str(err).startswith(("lag=", "synthetic=", "scenario=")) else err) from None
    report = result.to_dict()
    if args.figure:      # the figure first: a failure leaves no file
        shown = {}
        for name, kind, table in ((report["best_model"], "model", result.models),
                                  (report["best_baseline"], "baseline", result.baselines)):
            if name:
                aligned = table[name].tip_mean_aligned_mm
                shown[f"{name} ({kind}; offset-aligned mean {aligned:.1f} mm)"] = result.predictions[name]
        fig = benchmark_figure(result.validation.tip, shown,
                               title=f"{Path(args.validate).name}: free run on the commands alone")
        save_figure(fig, args.figure)
    if args.markdown:
        name = Path(args.validate).resolve().parent.name or "robot"
        table = SuiteResult(suite="", title="lab benchmark", rows=(SuiteRow.from_report(name, args.json, report),))
        atomic_write_text(args.markdown, table.markdown())
    atomic_write_text(args.json, json.dumps(report, indent=2) + "\n")
    print(format_benchmark(report))
    for path in (args.json, args.figure, args.markdown):
        if path:
            print(f"lab benchmark: wrote {path}")
    return 0


def _robots_folder(json_path) -> Path:
    """The folder of a suite's robot reports: the ``--json`` file's stem + ``-robots``, beside it."""
    p = Path(json_path)
    return p.with_name(p.stem + "-robots")


def _job(suite: Suite, r: SuiteRobot, workers: int) -> SuiteJob:
    """The ``SuiteJob`` of a suite file's robot (its options checked; errors name the entry)."""
    from ..lab.benchmark import BenchmarkOptions
    from ..lab.recording import Layout
    from ..lab.suite import SuiteJob
    from ..lab.synthetic import SyntheticOptions

    entry = f"{suite.path}: {r.key}"
    given = {k: getattr(r, k) for k in ("segments", "tendons_per_segment", "routing_radius", "lag", "families",
                                        "scenario")
             if getattr(r, k) is not None}
    if r.synthetic is not None:
        given["synthetic"] = SyntheticOptions(amount=r.synthetic)
    try:
        options = BenchmarkOptions(length=r.length, workers=workers, **given)
        layout = Layout(inputs=r.inputs, tip=r.tip, position_unit=r.position_unit)
    except SoftrnnInputError as err:
        raise SoftrnnInputError(f"{entry}: {err}") from None
    return SuiteJob(name=r.name, entry=entry, train=r.train, validation=r.validate, layout=layout, options=options)


def _suite(args) -> int:
    from ..lab.suite import run_suite
    from ..scenarios.suite import read_suite

    given = [f"--{d.replace('_', '-')}" for d, default in args.lab_single.items() if getattr(args, d) != default]
    if given:
        raise SoftrnnInputError(f"--suite gives each robot's sessions and options in its file: leave out "
                                f"{', '.join(given)}")
    again = args.overwrite or args.resume
    prepare_output(args.json, "--json", overwrite=again)
    if args.markdown:
        prepare_output(args.markdown, "--markdown", overwrite=again)
    folder = _robots_folder(args.json)
    prepare_output(folder, "--json", kind="folder", overwrite=again,
                   fix="give --resume to keep the robots it finished, or --overwrite to run them again")
    suite = read_suite(args.suite)
    workers = _workers(args.workers)
    jobs = [_job(suite, r, workers) for r in suite.robots]
    with Bar("lab benchmark", unit="stage", enabled=not args.quiet) as bar:
        try:
            result = run_suite(jobs, folder, suite=suite.path, title=suite.title, resume=args.resume, progress=bar)
        except KeyboardInterrupt as err:
            bar.close()
            print(f"lab benchmark: interrupted; the robots finished are kept in {folder}: run the same command "
                  "with --resume to go on", file=sys.stderr)
            return stop_code(err)
    if args.markdown:
        atomic_write_text(args.markdown, result.markdown())
    atomic_write_text(args.json, json.dumps(result.to_dict(), indent=2) + "\n")
    print(result.markdown(), end="")
    kept = [r.name for r in result.rows if r.resumed]
    if kept:
        print(f"lab benchmark: kept from an earlier run: {', '.join(kept)}")
    for path in (folder, args.json, args.markdown):
        if path:
            print(f"lab benchmark: wrote {path}")
    return 0


_COLUMNS = (("tip RMSE [mm]", "tip_rmse_mm", 14), ("mean [mm]", "tip_mean_mm", 11),
            ("RMSE [% L]", "tip_rmse_pct_of_length", 12), ("mean [% L]", "tip_mean_pct_of_length", 12),
            ("aligned RMSE [mm]", "tip_rmse_aligned_mm", 19), ("aligned mean [mm]", "tip_mean_aligned_mm", 19),
            ("[% L]", "tip_mean_aligned_pct_of_length", 8), ("cover 90", "coverage_90", 10))
"""The terminal table's columns: (title, JSON key, width)."""


def _cell(entry: dict, key: str, width: int) -> str:
    value = entry.get(key)
    if value is None:
        return f"{'-':>{width}}"
    return f"{value * 100:>{width - 1}.0f}%" if key == "coverage_90" else f"{value:>{width}.2f}"


def format_benchmark(r: dict) -> str:
    """The text ``softrnn lab benchmark`` prints for its JSON report."""
    robot = r["robot"]
    lag = f"{robot['lag_rows']} rows" + (" (estimated)" if robot.get("estimated") else "")
    lines = [f"lab benchmark: {len(robot['training_sessions'])} training session(s), validation "
             f"{robot['validation_session']['rows']} rows; robot length {robot['length_m']:g} m; lag {lag}",
             f"  {'':<22}" + "".join(f"{title:>{width}}" for title, _, width in _COLUMNS)]
    for title, table in (("models", r["models"]), ("baselines", r["baselines"])):
        lines.append(f"  {title}:")
        for name, e in table.items():
            lines.append(f"    {name:<20}" + "".join(_cell(e, key, width) for _, key, width in _COLUMNS))
    lines.append("  aligned: after removing the constant offset over the validation session; cover 90: the share "
                 "of rows inside the model's stated 90 % ball")
    for name, why in r["skipped"].items():
        lines.append(f"  {name} not run: {why}")
    if r["ratio_best_model_to_best_baseline"] is not None:
        lines.append(f"  best model {r['best_model']}, best baseline {r['best_baseline']}: ratio "
                     f"{r['ratio_best_model_to_best_baseline']:.2f}")
    if r["chosen_on_training"]:
        c = r["chosen_on_training"]
        lines.append(f"  chosen on the training sessions' hold-out part: {c['family']} "
                     f"(validation tip RMSE {c['validation_tip_rmse_mm']:.2f} mm)")
    if r.get("session_agreement"):
        a = r["session_agreement"]
        lines.append("  session agreement, the physics' tip RMSE over the validation session calibrated on: "
                     f"the training sessions {a['training_only']['validation_tip_rmse_mm']:.2f} mm, every session "
                     f"{a['training_and_validation']['validation_tip_rmse_mm']:.2f} mm, the validation session alone "
                     f"{a['validation_only']['validation_tip_rmse_mm']:.2f} mm (a diagnostic; no choice reads it)")
    lines.append(f"  {r['seconds']:.0f} s")
    return "\n".join(lines)


def _calibrate(args) -> int:
    from ..lab.benchmark import TipScore, check_pulls, check_reach, robot_for, settle_lag
    from ..lab.families import displacements
    from ..lab.recording import shift_inputs
    from ..lab.tendon_robot import calibrate, session_resets
    from ..learned.threads import one_blas_thread

    if args.twist and not args.creep:
        raise bad("--twist", True, "give --creep with it: the robot turns as its tendons creep")
    prepare_output(args.output, "-o", overwrite=args.overwrite)
    options = _options(args, ("physics",))
    recordings = _read(args.recordings + ([args.validate] if args.validate else []), _layout(args))
    lag, _ = settle_lag(recordings[:len(args.recordings)], options)
    try:
        recordings = [shift_inputs(r, lag) for r in recordings]
    except SoftrnnInputError as err:
        raise _as_option(err) from None
    train = recordings[:len(args.recordings)]
    robot = robot_for(options, train[0].n_inputs)
    if robot is None:
        raise bad("--tendons-per-segment", args.tendons_per_segment,
                  f"a divisor of the {train[0].n_inputs} inputs, or give --segments")
    if robot.n_tendons != train[0].n_inputs:
        raise bad("--segments", args.segments, f"segments whose tendons ({robot.n_tendons}) match the "
                                               f"{train[0].n_inputs} input columns")
    check_pulls(robot, recordings, options.routing_radius is not None)
    try:
        check_reach(recordings, args.length)
    except SoftrnnInputError as err:
        raise _as_option(err) from None
    physics = dataclasses.replace(options.calibration, gravity=args.gravity, friction=args.friction, play=args.play,
                                  creep=args.creep, twist=args.twist)
    # BLAS on one thread, as in the benchmark's workers: the same calibration on every machine
    with Bar("lab calibrate", unit="start", enabled=not args.quiet) as bar, one_blas_thread():
        cal = calibrate(robot, np.vstack([displacements(r) for r in train]), np.vstack([r.tip for r in train]),
                        physics, progress=bar, resets=session_resets([r.n_rows for r in train]),
                        times=np.concatenate([r.time for r in train]))
    report = {**cal.to_dict(), "variant": physics.variant, "lag_rows": lag, "sessions": [r.path for r in train]}
    if args.validate:
        v = recordings[-1]
        score = TipScore.of(cal.predict(displacements(v), times=v.time), v.tip, args.length, labels=v.labels)
        report["validation"] = {"path": v.path, **score.to_dict()}
    atomic_write_text(args.output, json.dumps(report, indent=2) + "\n")
    print(f"lab calibrate: tip RMSE on the fitted rows {cal.rmse_m * 1e3:.2f} mm ({cal.seconds:.0f} s)")
    if args.validate:
        print(f"lab calibrate: tip RMSE on {Path(args.validate).name} {report['validation']['tip_rmse_mm']:.2f} mm")
    print(f"lab calibrate: wrote {args.output}")
    return 0


def run(args) -> int:
    return args.lab_run(args)
