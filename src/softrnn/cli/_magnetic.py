"""softrnn magnetic experiment|compare|example-csv: the paper's magnetic experiment (section 5, Table 1);
softrnn magnetic navigate: the manipulator steered at a vessel bifurcation (docs/guide/navigation.md)."""

import json
import math

from ._progress import Bar
from ._vocabulary import output

NAME = "magnetic"
PREDICTS = ("increment", "pose")
"""What the experiment's LSTMs can predict (--predict)."""
HELP = "the paper's magnetic experiment (Table 1): simulated, or on lab data (a CSV of currents and orientations)"


def _training_args(p, epochs_help: str):
    p.add_argument("--epochs", type=int, default=None, help=epochs_help)
    p.add_argument("--seed", type=int, default=0, help="random seed of the currents, camera noise and training "
                                                       "(default: 0)")
    p.add_argument("--predict", dest="output", choices=PREDICTS, default="increment",
                   help="what the LSTMs predict: the next orientation minus the last (default, most accurate one "
                        "step ahead) or the next orientation (as the paper; stable when free running)")
    p.add_argument("--json", default=None, metavar="PATH", help="also write the table as JSON to PATH")
    p.add_argument("--overwrite", action="store_true",
                   help="replace the results in DIR (table1.json, fig12.png, models) and the --json file if they "
                        "exist (default: refuse; the simulated robot.h5 is reused when the settings match)")
    p.add_argument("--quiet", action="store_true", help="no progress bars")


def _calibration_args(p, default: bool):
    if default:
        p.add_argument("--no-calibrate", dest="calibrate", action="store_false",
                       help="skip the calibrated dynamic Cosserat model (fitted to the training span's camera record)")
    else:
        p.add_argument("--calibrate", action="store_true",
                       help="also fit the dynamic Cosserat model's stiffness, remanence and damping factors to the "
                            "training span (needs currents at a constant interval) and predict the test span with "
                            "it from the currents alone (the 'calibrated dynamic Cosserat' row)")
    p.add_argument("--workers", type=int, default=2, help="local Dask worker processes for the calibration's "
                                                          "simulations (default 2; 1: in this process)")
    p.add_argument("--scheduler", default=None, metavar="tcp://HOST:PORT",
                   help="run the calibration's simulations on an existing Dask cluster")


def add_args(p):
    sub = p.add_subparsers(title="subcommands", dest="magnetic", required=True)
    e = sub.add_parser("experiment", help="simulate the experiment and reproduce Table 1 and Fig. 12",
                       description="The dynamic model plays the real robot (parameters a few percent off the "
                                   "nominal ones), a camera model measures the magnets' orientations, the static "
                                   "Cosserat model and one LSTM per magnet predict them; prints Table 1 beside the "
                                   "paper's and writes DIR/table1.json, DIR/fig12.png, DIR/robot.h5 (reused when "
                                   "run again with the same settings) and DIR/models.")
    output(e, dest="out", required=True, metavar="DIR", help="output folder (created)", legacy=PREDICTS,
           legacy_dest="output", legacy_flag="--predict")
    e.add_argument("--quick", action="store_true", help="240 samples and 8 epochs (under a minute) instead of the "
                                                        "paper's 669 samples and 25 epochs")
    e.add_argument("--samples", type=int, default=None, help="measured samples (default: 669, quick: 240)")
    _training_args(e, "training epochs (default: 25, quick: 8)")
    _calibration_args(e, True)
    c = sub.add_parser("compare", help="the same comparison on a lab CSV (docs/magnetic-format.md)",
                       description="Read a CSV of coil currents (and/or magnet wrenches) and measured magnet "
                                   "orientations, predict the orientations with the static Cosserat model from the "
                                   "currents and with one LSTM per magnet trained on the first 60 per cent, and "
                                   "print the table; writes DIR/table1.json, DIR/fig12.png and DIR/models.")
    c.add_argument("csv", help="the lab CSV (layout in docs/magnetic-format.md, e.g. examples/magnetic_lab.csv)")
    output(c, dest="out", required=True, metavar="DIR", help="output folder (created)", legacy=PREDICTS,
           legacy_dest="output", legacy_flag="--predict")
    _training_args(c, "training epochs (default: 25)")
    _calibration_args(c, False)
    x = sub.add_parser("example-csv", help="write a simulated example lab CSV",
                       description="Simulate a short run of the experiment and write it in the lab format "
                                   "(currents, orientations, magnet positions): examples/magnetic_lab.csv is made so.")
    output(x, dest="csv", old=(), default=None, metavar="PATH.csv", help="the CSV to write")
    x.add_argument("path", nargs="?", default=None, metavar="PATH",
                   help="the CSV to write, as -o PATH (the older spelling, still accepted)")
    x.add_argument("--samples", type=int, default=300, help="rows (default: 300)")
    x.add_argument("--seed", type=int, default=1, help="random seed (default: 1)")
    x.add_argument("--overwrite", action="store_true", help="replace PATH if it exists (default: refuse)")
    x.add_argument("--quiet", action="store_true", help="no progress bar")
    _navigate_args(sub)


def _navigate_args(sub):
    v = sub.add_parser("navigate", help="steer the manipulator into a branch of a bifurcating vessel",
                       description="The manipulator's rod lies in a bifurcating vessel (contact with friction); the "
                                   "coils apply a field across the trunk toward the chosen branch and the magnets "
                                   "bend the tip into it (docs/guide/navigation.md). Writes an HDF5 dataset with the "
                                   "obstacles and the coil currents, for softrnn show and softrnn animate, and "
                                   "prints where the tip ended.")
    output(v, dest="out", old=(), required=True, metavar="PATH", help="the HDF5 dataset to write")
    v.add_argument("--branch", choices=("left", "right", "none"), default="left",
                   help="the branch to steer into; none: no field (default: left)")
    v.add_argument("--field", type=float, default=15.0, help="field across the trunk in mT (default: 15)")
    v.add_argument("--duration", type=float, default=1.0,
                   help="run time in s: the currents ramp up over the first half, then hold (default: 1)")
    v.add_argument("--advance", type=float, default=None, metavar="MM",
                   help="insert the base MM mm along the trunk (0 to 20), from a quarter of the run over half of "
                        "it, a smoothstep (default: a fixed base)")
    v.add_argument("--rotate", type=float, default=None, metavar="DEG",
                   help="turn the base DEG degrees about its axis (the trunk's; -3600 to 3600), as a hub twists a "
                        "device, with the same timing as --advance (default: its rotation held)")
    v.add_argument("--overwrite", action="store_true", help="replace PATH if it exists (default: refuse)")
    v.add_argument("--quiet", action="store_true", help="no progress bar")


UNITS = {"simulate": "sample", "predict": "sample", "static": "sample", "calibrate": "simulation",
         "evaluate": "magnet"}
"""The unit each stage counts in (others: ``step``)."""


class _Stages(Bar):
    """A ``Progress`` with one tqdm bar per stage (``info["stage"]``, as the experiment reports it):
    a ``Bar`` whose bar is the current stage's ``Bar``."""

    def __init__(self, enabled: bool):
        super().__init__("magnetic", enabled=enabled)
        self.stage = None

    def __call__(self, done: int, total: int, info: dict | None = None) -> None:
        if not self.enabled:
            return
        stage = (info or {}).get("stage", "magnetic")
        if stage != self.stage:
            self.close()
            self.stage = stage
            self.bar = Bar(stage, unit=UNITS.get(stage, "step"))
        self.bar(done, total)


def _print_result(result: dict) -> None:
    from ..experiments.magnetic import format_table

    print("Table 1: max and mean absolute error (deg) of the magnets' orientations about x, y, z on the test span")
    for line in format_table(result):
        print(line)
    axis = result["bending_axis"]
    ranges = ", ".join(f"{name} {r[['x', 'y', 'z'].index(axis)]:.1f} deg"
                       for name, r in result["motion_range_deg"].items())
    print(f"bending axis: {axis} (measured range {ranges}); orientation about z is identically 0 by the paper's "
          f"definition (k perpendicular to z)")
    beats, beats_max = result.get("lstm_beats_static_on_bending_axis"), result.get(
        "lstm_beats_static_on_bending_axis_max") or {}
    if beats is not None:
        i = ["x", "y", "z"].index(axis)
        for name, won in beats.items():
            r, c = result[name]["rnn"][i], result[name]["cosserat"][i]
            print(f"{name}: about {axis} the LSTM {'beats' if won else 'does not beat'} the static model on the mean "
                  f"error ({r[1]:.2f} vs {c[1]:.2f} deg) and {'beats' if beats_max.get(name) else 'does not beat'} it "
                  f"on the max ({r[0]:.2f} vs {c[0]:.2f} deg)")
    cal = result.get("calibration")
    if cal:
        fitted = ", ".join(f"{name} x{p['fitted']:.4f} +- {p['std_error']:.4f}"
                           + (f" (real {p['truth']:g}, {p['error_pct']:+.2f} %)" if "truth" in p else "")
                           for name, p in cal["parameters"].items())
        print(f"calibration ({cal['samples']} samples, {cal['trials']} simulations, {cal['failed_trials']} failed, "
              f"{cal['seconds']:.1f} s): {fitted}")
        for warning in cal.get("not_identifiable") or []:
            print(f"calibration: not identifiable: {warning}")
    st = result.get("static")
    if st:
        print(f"static model: {st['solves']} solves, {st['failures']} failed samples (left out)")
    t = result.get("timings", {})
    parts = []
    if "simulation_s" in t:
        parts.append(f"simulation {t['simulation_s']:.1f} s{' (reused)' if t.get('simulation_resumed') else ''}")
    if "static_s" in t:
        parts.append(f"static model {t['static_s']:.1f} s ({t['static_solves_per_second']:.0f} solves/s, "
                     f"{t['static_predictions_per_second']:.0f} predictions/s)")
    parts.append(f"training {t['training_s']:.1f} s")
    rates = t.get("rnn_steps_per_second") or {}
    if rates:
        parts.append("LSTM " + ", ".join(f"{name} {hz:.3g} steps/s" for name, hz in rates.items()))
    if "total_s" in t:
        parts.append(f"total {t['total_s']:.1f} s")
    print("timings: " + "; ".join(parts))
    print(f"figure: {result['figure']}")


_FLAGS = {"samples": "--samples", "epochs": "--epochs", "seed": "--seed"}
"""``ExperimentConfig`` fields set from a flag, named by the flag in an error."""


def _config(make=None, **fields):
    """``make(**fields)`` (None: ``ExperimentConfig``), its one-line error naming the flag that set the field."""
    from ..errors import SoftrnnInputError
    from ..experiments.magnetic import ExperimentConfig

    try:
        return (ExperimentConfig if make is None else make)(**fields)
    except SoftrnnInputError as err:
        text = str(err)
        for name, flag in _FLAGS.items():
            if text.startswith(f"{name}=") and name in fields:
                raise SoftrnnInputError(flag + text[len(name):]) from None
        raise


def _check_size(config) -> None:
    """Refuse ``--samples`` too many for this machine before anything is made or written
    (``check_experiment_size``: the simulated robot's arrays and solver steps)."""
    from ..errors import SoftrnnInputError, bad
    from ..experiments.magnetic import check_experiment_size

    try:
        check_experiment_size(config)
    except SoftrnnInputError as err:
        raise bad("--samples", config.samples, f"fewer samples: {err}") from None


def _example_csv(args) -> int:
    """softrnn magnetic example-csv -o PATH: a short simulated run in the lab format."""
    from ..errors import bad
    from ..experiments.magnetic.lab import example_config, write_example_csv
    from ..files import prepare_output

    if (args.csv is None) == (args.path is None):
        raise bad("-o", args.csv, "the CSV to write, given once: -o PATH.csv (or the older positional PATH)")
    path, argument = (args.csv, "-o") if args.csv is not None else (args.path, "PATH")
    if args.samples < 20:
        raise bad("--samples", args.samples, "at least 20 rows")
    _check_size(_config(example_config, samples=args.samples, seed=args.seed))
    prepare_output(path, argument, overwrite=args.overwrite)
    with Bar("example-csv", unit="sample", enabled=not args.quiet) as bar:
        data = write_example_csv(path, args.samples, seed=args.seed, progress=bar)
    print(f"wrote {path}: {data.n_samples} rows, t = 0 .. {data.time[-1]:g} s")
    return 0


def _navigate(args) -> int:
    """softrnn magnetic navigate -o PATH: the steering demonstration, written as a dataset."""
    from ..errors import bad, positive
    from ..files import prepare_output
    from ..magnetics.manipulator import BaseAdvance, currents_for_field
    from ..magnetics.navigation import navigate, navigation_spec, steering_field, tip_branch
    from ..scenarios.magnetic import write_manipulator_dataset

    field = positive("--field", args.field, "mT") * 1e-3
    if not (isinstance(args.duration, float) and 0.1 <= args.duration <= 10.0):
        raise bad("--duration", args.duration, "a run time in s from 0.1 to 10")
    advance = None
    if args.advance is not None:
        if not (isinstance(args.advance, float) and 0.0 < args.advance <= 20.0):
            raise bad("--advance", args.advance, "an insertion in mm, > 0 and at most 20 (the branches are 25 mm long)")
    if args.rotate is not None and not (isinstance(args.rotate, float) and math.isfinite(args.rotate)
                                        and 0.0 < abs(args.rotate) <= 3600.0):
        raise bad("--rotate", args.rotate, "a turn of the base in degrees, nonzero and within +-3600 (ten turns)")
    if args.advance is not None or args.rotate is not None:
        advance = BaseAdvance(distance=(args.advance or 0.0) * 1e-3, start=0.25 * args.duration,
                              ramp=0.5 * args.duration, rotation=math.radians(args.rotate or 0.0))
    spec = navigation_spec(advance=advance)
    per_mt = abs(currents_for_field(spec.coils, (0.0, 0.0, 0.0), steering_field(
        spec.contact.obstacles[0], "left", 1e-3))).max()          # the currents are linear in the field
    if args.branch != "none" and args.field * per_mt > spec.coils.current_limit:
        raise bad("--field", args.field, f"at most {spec.coils.current_limit / per_mt:.4g} mT (the coils' "
                                         f"{spec.coils.current_limit:g} A limit)")
    prepare_output(args.out, "-o", overwrite=args.overwrite)
    half = 0.5 * args.duration
    with Bar("navigate", unit="sample", enabled=not args.quiet) as bar:
        traj = navigate(args.branch, spec=spec, field=field, ramp=half, hold=half, progress=bar)
    tip = traj.positions[-1, -1]
    ended = tip_branch(spec.contact.obstacles[0], tip)
    attrs = {"scenario_name": "magnetic-navigation", "branch": args.branch, "field_T": field,
             **({} if args.advance is None else {"advance_m": advance.distance}),
             **({} if args.rotate is None else {"rotate_rad": advance.rotation}),
             "tip_branch": ended,
             "description": "the magnetic manipulator steered at a bifurcation (softrnn magnetic navigate)"}
    write_manipulator_dataset(args.out, traj, spec, dt=float(traj.time[1] - traj.time[0]), attrs=attrs)
    print(f"wrote {args.out}: {traj.time.size} samples, t = 0 .. {traj.time[-1]:g} s, {traj.wall_time:.1f} s of "
          f"simulation")
    where = {"left": "in the left branch", "right": "in the right branch", "wall": "on a wall (outside both tubes)",
             "trunk": "in the trunk or at the junction, inside both tubes"}[ended]
    currents = ", ".join(f"{i if abs(i) >= 5e-3 else 0.0:.2f}" for i in traj.currents[-1])
    inserted = "" if args.advance is None else f", base advanced {args.advance:g} mm"
    inserted += "" if args.rotate is None else f", base turned {args.rotate:g} deg"
    print(f"tip at [{tip[0] * 1e3:.2f}, {tip[1] * 1e3:.2f}, {tip[2] * 1e3:.2f}] mm, {where} (steered: {args.branch}"
          f"{inserted}, currents {currents} A)")
    return 0


def run(args) -> int:
    from ..errors import require_extra
    from ..experiments.magnetic import FIGURE_FILE, TABLE_FILE, run_experiment
    from ..files import atomic_write_text, prepare_output

    if args.magnetic == "example-csv":
        return _example_csv(args)
    if args.magnetic == "navigate":
        return _navigate(args)
    fields = {"seed": args.seed, "output": args.output, "calibrate": bool(args.calibrate)}
    if args.epochs is not None:
        fields["epochs"] = args.epochs
    if args.magnetic == "experiment":
        if args.samples is not None:
            fields["samples"] = args.samples
        config = _config(quick=args.quick, **fields)
        _check_size(config)   # an absurd --samples is refused before anything else
    else:
        config = _config(**fields)
    require_extra("learn")    # the LSTMs: refused before the robot is simulated
    prepare_output(args.out, "-o", kind="folder", overwrite=args.overwrite, holds=(TABLE_FILE, FIGURE_FILE),
                   fix="pass --overwrite to replace them, or choose another folder")
    if args.json:
        prepare_output(args.json, "--json", overwrite=args.overwrite)
    from ..calibration.parallel import Evaluator

    Evaluator(workers=args.workers, scheduler=args.scheduler)          # checks --workers, --scheduler now
    with _Stages(not args.quiet) as progress:
        if args.magnetic == "experiment":
            result = run_experiment(config, args.out, progress=progress, workers=args.workers,
                                    scheduler=args.scheduler)
        else:
            from ..experiments.magnetic.lab import compare_lab

            result = compare_lab(args.csv, config, args.out, progress=progress, workers=args.workers,
                                 scheduler=args.scheduler)
    _print_result(result)
    if args.json:
        atomic_write_text(args.json, json.dumps(result, indent=2, allow_nan=False) + "\n")
        print(f"table written to {args.json}")
    return 0
