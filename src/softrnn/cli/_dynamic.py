"""softrnn dynamic train|evaluate|rollout|export: the learned whole-manipulator model (beyond the
paper; ``softrnn.learned.whole``): one set of weights along the rod, free running at its own step."""

from __future__ import annotations

import json
import sys
import time as _time
from contextlib import contextmanager
from pathlib import Path

from ..errors import FileFault, SimulationError, SoftrnnInputError, bad, require_extra
from ..files import atomic_write_text, json_default, prepare_output
from ._lazy import numpy as np
from ._progress import StepBar as _StepBar
from ._progress import stop_code
from ._vocabulary import deprecate, deprecate_converted, output, settings

NAME = "dynamic"
HELP = ("the learned whole-manipulator model (beyond the paper): train it on data sets and sweeps, evaluate it "
        "free running at every node beside baselines, roll it out as a data set, export a step to ONNX")

_OPTIONS = {"model_dt": "--model-dt", "node_stride": "--node-stride", "history": "--history", "memory": "--memory",
            "width": "--width", "layers": "--layers", "steps": "--steps", "unroll": "--unroll", "noise": "--noise",
            "seed": "--seed", "heldout": "--heldout", "validation": "--validation",
            "train_fraction": "--train-fraction", "data": "DATA", "drive": "--drive", "envelope": "--envelope",
            "prior_tau": "--prior-tau", "ema": "--ema", "ridge": "--ridge", "load_ridge": "--load-ridge",
            "linear_lr": "--linear-lr", "conv_reads": "--conv-reads", "start_fraction": "--start-fraction",
            "validate_on": "--validate-on", "resume": "--resume", "start_time": "--start", "stop_time": "--stop"}
"""Library argument names -> the options that set them (for the one-line errors)."""


def add_args(p):
    sub = p.add_subparsers(title="subcommands", dest="dynamic_command", required=True,
                           metavar="{" + ",".join(c[0] for c in _COMMANDS) + "}")
    for name, help_, adder, runner in _COMMANDS:
        q = sub.add_parser(name, help=help_, description=help_)
        adder(q)
        q.set_defaults(dynamic_run=runner)


def run(args) -> int:
    return args.dynamic_run(args)


@contextmanager
def _as_options():
    """Re-raise the library's ``name=value is invalid`` errors under the option's name (--model-dt)."""
    try:
        yield
    except SoftrnnInputError as err:
        text = str(err)
        for name, option in _OPTIONS.items():
            if text.startswith(f"{name}="):
                raise SoftrnnInputError(option + text[len(name):]) from None
        raise


# ------------------------------------------------------------------------------------------ train
def _float_or_off(text: str):
    """A number, or 'off' (the option switched off: None in the config)."""
    return _OFF if text.strip().lower() == "off" else float(text)


_float_or_off.__name__ = "number or 'off'"     # argparse names the type in its error
_OFF = "off"


_WINDOW = (
    ("--train-fraction", float, "F", "train on the first F of every single-trajectory file (default: 0.6, the rest "
                                     "is the test span; 1 with --validate-on)"),
    ("--model-dt", float, "S", "the model's step [s], a whole multiple of the data's interval (default: 0.02)"),
    ("--node-stride", int, "K", "predict every K-th node and both ends (default: about 20 segments)"),
    ("--history", int, "H", "states read per step (default: 3)"),
)
"""``dynamic train``'s options of the data's spans and the model's window (``settings`` rows)."""

_NETWORK = (
    ("--width", int, "W", "channels of the convolution (default: 48)"),
    ("--layers", int, "L", "hidden layers of the convolution (default: 3)"),
    ("--steps", int, "N", "optimiser steps (default: 4000)"),
    ("--unroll", int, "K", "free steps in the loss (default: 20)"),
    ("--noise", float, "X", "input noise in units of the velocities' spread (default: 0.01)"),
    ("--seed", int, "S", "random seed (default: 0)"),
    ("--ema", float, "D", "decay of the running average of the weights validated beside them (default: 0.995; 0: off)"),
    ("--envelope", _float_or_off, "M", "the network's correction acts within the training data's range of its inputs "
                                       "and fades to zero M times that range beyond it; 'off': everywhere (0.25)"),
    ("--prior-tau", _float_or_off, "S", "the ridge fit of the linear term is shrunk toward a critically damped "
                                        "relaxation with this time constant [s]; 'off': toward zero (default: 0.5)"),
    ("--ridge", float, "R", "where the ladder of ridge penalties for the linear term's fit starts (relative to the "
                            "mean feature variance; default: 1e-6); the linear baseline's ladder starts at 1e-6 "
                            "regardless"),
    ("--load-ridge", float, "R", "a separate ridge penalty on the load coefficients of the network's linear term "
                                 "(default: the same as the rest)"),
    ("--linear-lr", float, "F", "the linear term's learning rate as a fraction of the network's (0.01; 0: frozen)"),
)
"""``dynamic train``'s options of the network and its optimiser, as ``_WINDOW``."""


def _add_train(p):
    p.add_argument("data", nargs="+", metavar="DATA",
                   help="data set files (every node stored) or sweep folders (traj-NNNNN.h5 files)")
    output(p, dest="out", required=True, metavar="MODEL_DIR", help="the model folder to write")
    p.add_argument("--heldout", type=int, default=0, metavar="N",
                   help="hold out the last N variants of every sweep (never trained on; recorded) (default: 0)")
    p.add_argument("--validation", type=int, default=0, metavar="N",
                   help="of every sweep, N variants before the held-out ones choose among the training's "
                        "checkpoints by free runs (never trained on; recorded) (default: 0)")
    p.add_argument("--validate-on", nargs="+", action="extend", default=[], metavar="FILE",
                   help="separate validation recordings (other sessions of the same robot: files or sweep folders, "
                        "used whole) that choose among the training's checkpoints by free runs; every "
                        "single-trajectory DATA file is then trained on whole (no test span)")
    settings(p, _WINDOW)
    p.add_argument("--memory", choices=("window", "lstm"), default=None,
                   help="the history window alone, or also an LSTM cell per node (default: window)")
    settings(p, _NETWORK)
    p.add_argument("--conv-reads", choices=("all", "displacements", "loads"), default=None,
                   help="what the convolution reads: the states and velocities (all, the default), their "
                        "displacements only, or everything including the loads")
    p.add_argument("--start-fraction", type=float, default=None, metavar="F",
                   help="the fraction of each batch's windows drawn from the trajectories' first steps (runs from "
                        "rest; default: 0)")
    p.add_argument("--recorded-feedback", dest="feedback", action="store_false", default=None,
                   help="take the recorded forces of PD tracking loads as inputs instead of applying the law to "
                        "the model's own state (default: the law, where a data set's scenario has PD loads)")
    p.add_argument("--drive", choices=("wrench", "actuation", "both"), default=None,
                   help="the model's load input: the nodal wrenches (default), the data's actuation inputs (tendon "
                        "tensions, pressures, currents: docs/dataset-format.md), or both")
    p.add_argument("--predict-clamps", dest="prescribed", action="store_false", default=None,
                   help="predict a clamp that the data's scenario moves along a path like any other node, from "
                        "its own history (default: its recorded path is an input, and the model follows it)")
    p.add_argument("--ignore-obstacles", dest="obstacles", action="store_false", default=None,
                   help="report the model's free runs as they are, even where they pass through the obstacles the "
                        "data were simulated with (default: a reported node inside one is moved back to its surface)")
    p.add_argument("--contact-inputs", dest="contact", action="store_true", default=None,
                   help="where the data record obstacles, give the network's correction each kept node's gap to the "
                        "nearest obstacle and its normal, measured on the model's own state at each step (default off)")
    p.add_argument("--frame", choices=("world", "vessel"), default=None,
                   help="the coordinates of the model's state: the world frame (default), or along the centreline "
                        "of the vessel the data were simulated in (arc parameter and two offsets across it)")
    p.add_argument("--threads", type=int, default=None, metavar="T",
                   help="PyTorch threads while training (default: PyTorch's own choice)")
    again = p.add_mutually_exclusive_group()
    again.add_argument("--resume", action="store_true",
                       help="continue an interrupted training from MODEL_DIR/checkpoint.pt (same settings)")
    again.add_argument("--overwrite", action="store_true",
                       help="replace the model or unfinished training in MODEL_DIR (default: refuse)")
    p.add_argument("--quiet", action="store_true", help="no progress bar")


def _config(args):
    from ..learned.whole.config import DynamicConfig

    names = ("model_dt", "node_stride", "history", "memory", "width", "layers", "steps", "unroll", "noise", "seed",
             "ema", "feedback", "drive", "envelope", "prior_tau", "ridge", "load_ridge", "linear_lr", "conv_reads",
             "start_fraction", "prescribed", "obstacles", "contact", "frame")
    given = {k: getattr(args, k) for k in names if getattr(args, k) is not None}
    return DynamicConfig(**{k: (None if v is _OFF else v) for k, v in given.items()})


def _interrupted(run) -> None:
    """Say what an interrupted training kept (its last checkpoint, or nothing)."""
    from ..learned.whole import training

    if run.kept():
        print(f"softrnn: interrupted; the training's last checkpoint (one every {training.CHECKPOINT_EVERY} steps) "
              f"is kept in {run.checkpoint}; run the same command with --resume to continue", file=sys.stderr)
    else:
        print(f"softrnn: interrupted before the first checkpoint (after {training.CHECKPOINT_EVERY} steps); "
              "nothing was kept", file=sys.stderr)


def _train_summary(folder, config, encoding, info: dict, data: dict, head: str = "dynamic train:") -> str:
    n = {key: len(data.get(key) or []) for key in ("train", "validation", "heldout")}
    loss = info.get("final_loss")
    selected = ""
    if n["validation"] and "selected_step" in info:
        step = info["selected_step"]
        selected = f", weights of step {step}" + (" (the linear start: no trained checkpoint beat it)" if step == 0
                                                  else "")
    return (f"{head} {config.steps} steps in {info.get('train_seconds', float('nan')):.1f} s, final loss "
            f"{'-' if loss is None else f'{loss:.4g}'}{selected}; model_dt {encoding.model_dt:g} s, "
            f"{encoding.n_predicted} of {encoding.n_nodes} nodes predicted"
            f"{_on_path(encoding)}{_driven(encoding)}; "
            f"{n['train']} training trajectories{' (every sample trained on)' if data.get('validate_on') else ''}, "
            f"{n['validation']} for validation{_separate(data)}, {n['heldout']} held out (listed in "
            f"{folder}/model.json)")


def _separate(data: dict) -> str:
    """' (N separate recordings: a.h5, ...)' for ``--validate-on``."""
    given = data.get("validate_on") or []
    if not given:
        return ""
    names = ", ".join(Path(p["path"]).name + ("" if p.get("group", "/") == "/" else f":{p['group']}")
                      for p in given[:3])
    more = ", ..." if len(given) > 3 else ""
    return f" ({len(given)} separate recording{'s' if len(given) != 1 else ''}: {names}{more})"


def _on_path(encoding) -> str:
    """', node 0 on its recorded path' for a model with prescribed nodes, else ''."""
    nodes = encoding.kept[encoding.prescribed].tolist()
    if not nodes:
        return ""
    many = len(nodes) > 1
    return f", node{'s' if many else ''} {', '.join(map(str, nodes))} on {'their' if many else 'its'} recorded path"


def _driven(encoding) -> str:
    """', driven by actuation a, b' (and the wrenches) for a model with actuation inputs, else ''."""
    both = " and the wrenches" if encoding.drive == "both" else ""
    return f", driven by actuation {', '.join(encoding.channels)}{both}" if encoding.channels else ""


def _train(args) -> int:
    require_extra("learn")
    from ..learned.whole.artifact import save_dynamic
    from ..learned.whole.data import check_step, split_inputs
    from ..learned.whole.fit import fit, model_folder, prepare_training

    folder = model_folder(args.out, overwrite=args.overwrite or args.resume)
    if args.threads is not None and args.threads < 1:
        raise bad("--threads", args.threads, "an integer >= 1")
    with _as_options():
        config = _config(args)
        fraction = args.train_fraction if args.train_fraction is not None else 1.0 if args.validate_on else 0.6
        split = split_inputs([Path(p).absolute() for p in args.data], heldout=args.heldout,
                             validation=args.validation, train_fraction=fraction,
                             validate_on=[Path(p).absolute() for p in args.validate_on])
        check_step(split, config)
        run = prepare_training(folder, config, split, resume=args.resume)
    with _StepBar("dynamic train", unit="step", enabled=not args.quiet) as bar, _as_options():
        try:
            trained, meta = fit(split, config, progress=bar, checkpoint=run.checkpoint, threads=args.threads)
        except KeyboardInterrupt as err:
            bar.close()
            _interrupted(run)
            return stop_code(err)
        except BaseException:
            run.discard()
            raise
    try:
        save_dynamic(folder, trained, meta)
    except FileFault as err:        # the last step's checkpoint stays: --resume saves without training again
        raise FileFault(f"{err}; the training's last checkpoint is kept in {run.checkpoint}: run the same command "
                        "with --resume to save the model without training again") from None
    print(_train_summary(folder, config, trained.encoding, trained.info, meta["data"]))
    print(f"dynamic train: wrote {folder} (evaluate it with 'softrnn dynamic evaluate {folder} --heldout ...')")
    return 0


# ------------------------------------------------------------------------------------------ evaluate
def _add_evaluate(p):
    p.add_argument("model", metavar="MODEL_DIR", help="a model folder written by 'softrnn dynamic train'")
    p.add_argument("--test", default=None, metavar="FILE",
                   help="a trajectory the model trained the first part of: run free over the rest; or a separate "
                        "test recording the model never saw: run free over the whole of it, from its start")
    start = p.add_argument("--start", dest="start_time", type=float, default=None, metavar="S",
                           help="where the test span of --test starts [s, on its time axis]: at the last model step "
                                "at or before S (default: the step at 0.6 of a trajectory the model trained the "
                                "first part of; the start of a separate recording)")
    deprecate_converted(p, start, "--test-start", dest="test_start", type=float, default=None, metavar="F",
                        why=" S in seconds (--test-start F, a fraction of --test, is taken as the time of the "
                            "model step at F of it)")
    p.add_argument("--heldout", nargs="+", action="extend", default=[], metavar="PATH",
                   help="held-out trajectories: files (every group of a sweep file) or sweep folders (every "
                        "traj-*.h5); refused if the model trained on them")
    p.add_argument("--generalisation", default=None, metavar="FILE",
                   help="a trajectory of another scenario, run free from its start")
    deprecate(p, p.add_argument("--json", dest="output", default=None, metavar="PATH",
                                help="also write the report as JSON"), "-o", "--output")
    p.add_argument("--overwrite", action="store_true", help="replace the --json file if it exists (default: refuse)")


def _trajectories(path: str) -> list[tuple[Path, str]]:
    """(file, group) of every trajectory of a file or a sweep folder."""
    from ..io.reader import list_groups

    p = Path(path)
    if p.is_dir():
        files = sorted(p.glob("traj-*.h5"))
        if not files:
            raise bad("--heldout", path, "a data set file or a sweep folder holding traj-NNNNN.h5 files")
        return [(f, "/") for f in files]
    if not p.is_file():
        raise bad("--heldout", path, "an existing data set file or sweep folder")
    return [(p, g) for g in list_groups(p)]


def _read(model, argument: str, path, group: str = "/"):
    """The data set at ``path`` (``group``), checked against the model's encoding."""
    from ..io.reader import read_dataset
    from ..learned.whole.encoding import check_compatible

    data = read_dataset(path, group=None if group == "/" else group)
    check_compatible(model.encoding, data, argument)
    return data


def _seen(model, path, group: str = "/") -> tuple[str, dict] | None:
    """('train' or 'validation', the entry) of ``model``'s record that names this trajectory, or None."""
    where = Path(path).resolve()
    for role in ("train", "validation"):
        for entry in (model.meta.get("data") or {}).get(role) or []:
            if Path(entry["path"]).resolve() == where and entry.get("group", "/") == group:
                return role, entry
    return None


def _unseen(model, argument: str, path, group: str = "/") -> None:
    """Refuse a trajectory the model trained on (or chose its weights by) as held-out data."""
    seen = _seen(model, path, group)
    if seen is not None:
        what = "trained on it" if seen[0] == "train" else "chose its weights by free runs on it (validation)"
        name = str(path) + ("" if group == "/" else f":{group}")
        raise bad(argument, name, f"a trajectory the model never saw, but it {what} (model.json lists it); "
                                  "give a held-out variant (train with --heldout N to keep some back)")


def _step_times(model, data) -> tuple[np.ndarray, int]:
    """The model's step times [s] on the data set's time axis (``Encoding.trajectory``'s), and the
    model's step in data samples."""
    k = model.encoding.stride(float(data.dt))
    return np.asarray(data.time[np.arange((data.n_samples - 1) // k + 1) * k], dtype=np.float64), k


def _test_start(args, times: np.ndarray, separate: bool) -> float:
    """Where the test span starts [s]: ``--start``; the time of the model step at ``--test-start F``
    (deprecated) or, by default, at 0.6 of a trajectory the model trained the first part of
    (``start_of_test_span``'s rounding, so the span is the same); a separate recording's start."""
    if args.start_time is not None:
        last = times[max(len(times) - 2, 0)]
        eps = 1e-9 * max(1.0, abs(float(times[-1])))
        if not (np.isfinite(args.start_time) and times[0] - eps <= args.start_time <= last + eps):
            raise bad("--start", args.start_time, f"a time in [{times[0]:g}, {last:g}] s of {args.test} (a model "
                                                  "step before its end)")
        return float(args.start_time)
    if args.test_start is None and separate:
        return float(times[0])
    fraction = 0.6 if args.test_start is None else args.test_start
    return float(times[int(round(fraction * (len(times) - 1)))])


def _check_test(model, args, times: np.ndarray, k: int, seconds: float) -> None:
    """The test span from ``seconds`` must start after the part of --test the model trained on."""
    seen = _seen(model, args.test)
    if seen is None:
        return
    role, entry = seen
    if role == "validation" or entry.get("stop") is None:
        raise bad("--test", str(args.test), "a trajectory whose test span the model never saw, but it "
                                            f"{'trained on' if role == 'train' else 'validated on'} all of it; "
                                            "use --heldout or --generalisation data instead")
    from ..learned.spans import check_beyond_trained
    from ..learned.whole.evaluation import step_at

    # on the model's step grid (every k-th sample): the first predicted state, one model step after the
    # start, must lie beyond the trained samples 0 .. stop - 1
    stop, n_steps = int(entry["stop"]), len(times)
    start = max(max(model.engine.history, 2) - 1, step_at(times, seconds))
    if args.test_start is not None:        # the deprecated fraction: refused in its own words
        check_beyond_trained(start, k, stop, n_steps, fraction=args.test_start, path=args.test)
        return
    try:
        check_beyond_trained(start, k, stop, n_steps, fraction=0.6, path=args.test)
    except SoftrnnInputError:
        first = -(-stop // k) - 1                   # the first start whose next state is unseen
        later = f"a time >= {times[first]:g} s" if first <= n_steps - 2 else \
            "nothing: it trained on all but its last model step; use --heldout or --generalisation data instead"
        raise bad("--start", seconds, f"a start after the trained part of {args.test} (its first {stop} samples): "
                                      f"{later}") from None


def _evaluate(args) -> int:
    from ..learned.whole.artifact import load_dynamic
    from ..learned.whole.evaluation import evaluate_dynamic

    if args.test is None and not args.heldout and args.generalisation is None:
        raise SoftrnnInputError("nothing to evaluate: give --test FILE, --heldout PATH ... or --generalisation FILE")
    if args.test_start is not None and not 0.0 < args.test_start < 1.0:
        raise bad("--test-start", args.test_start, "a fraction in (0, 1), e.g. 0.6")
    if args.test_start is not None and args.start_time is not None:
        raise bad("--test-start", args.test_start, "one of --start S and the deprecated --test-start F, not both")
    if args.test is None and args.start_time is not None:
        raise bad("--start", args.start_time, "--test FILE as well (--start is where its test span starts)")
    if args.output:
        prepare_output(args.output, "--json", overwrite=args.overwrite)
    model = load_dynamic(args.model)
    heldout = [t for path in args.heldout for t in _trajectories(path)]
    for path, group in heldout:
        _unseen(model, "--heldout", path, group)
    if args.generalisation is not None:
        _unseen(model, "--generalisation", args.generalisation)
    test = None if args.test is None else _read(model, "--test", args.test)
    seconds, separate = None, False
    if test is not None:
        separate = _seen(model, args.test) is None         # a separate test recording: from its start
        times, k = _step_times(model, test)
        seconds = _test_start(args, times, separate)
        _check_test(model, args, times, k, seconds)
    general = None if args.generalisation is None else _read(model, "--generalisation", args.generalisation)
    report = evaluate_dynamic(model, test=test, heldout=[_read(model, "--heldout", p, g) for p, g in heldout],
                              generalisation=general, test_start_time=seconds)
    report = {"model": str(args.model), "test": args.test, "heldout_files": [f"{p}:{g}" for p, g in heldout],
              "generalisation_file": args.generalisation, **report.to_dict()}
    if test is not None:
        given = args.start_time is not None or args.test_start is not None
        report["test_span"]["span"] = "whole record" if separate and not given else "test span"
    print(format_evaluation(report))
    if args.output:
        atomic_write_text(args.output, json.dumps(report, indent=2, allow_nan=False, default=json_default) + "\n")
        print(f"dynamic evaluate: wrote {args.output}")
    return 0


_NAMES = ("model", "persistence", "constant_velocity", "linear")
_HEADS = ("model", "persistence", "const. vel.", "linear")


def _cell(value) -> str:
    return f"{value:>12.3g}" if isinstance(value, (int, float)) else f"{value or '-':>12}"


def _span_cell(span: dict):
    return "diverged" if span.get("diverged_at") is not None else span.get("max_pct_of_length")


def _tip_rows(block: dict) -> list[tuple[str, list]]:
    """The tip's Euclidean RMSE [mm] rows of a test-span or generalisation block, where reported."""
    if not isinstance(block.get("model"), dict) or "rmse_euclidean_mm" not in block["model"]:
        return []

    def cell(b, one_step):
        b = (b or {}).get("one_step") if one_step else b
        return "diverged" if not b or b.get("rmse_euclidean_mm") is None else b["rmse_euclidean_mm"]

    tip = f"node {block['tip_node']}" if "tip_node" in block else "the tip"
    return [(f"  tip ({tip}) Euclidean RMSE [mm]", [cell(block.get(n), False) for n in _NAMES]),
            ("    one step ahead [mm]", [cell(block.get(n), True) for n in _NAMES])]


def _rows(r: dict) -> list[tuple[str, list]]:
    rows = []
    if "test_span" in r:
        t = r["test_span"]
        label = "test file (whole)" if t.get("span") == "whole record" else "test span"
        rows.append((f"{label} {t['start_s']:g}..{t['end_s']:g} s", [_span_cell(t[n]) for n in _NAMES]))
        rows += _tip_rows(t)
    if "heldout" in r:
        h = r["heldout"]
        for stat in ("median", "worst"):
            key = f"{stat}_max_pct_of_length"
            values = [h[key]] + [h["baselines"][n][key] for n in _NAMES[1:]]
            rows.append((f"held out ({h['variants']}): {stat}", values))
    if "generalisation" in r:
        rows.append(("generalisation", [_span_cell(r["generalisation"][n]) for n in _NAMES]))
        rows += _tip_rows(r["generalisation"])
    for n, row in (r.get("horizons") or {}).items():
        rows.append((f"at {n} steps ({int(n) * r['model_dt_s']:g} s)", [row.get(k) for k in _NAMES]))
    return rows


def format_evaluation(r: dict) -> str:
    """The table ``softrnn dynamic evaluate`` prints for an ``evaluate_dynamic`` report."""
    lines = [f"dynamic evaluate: {r['model']} (model_dt {r['model_dt_s']:g} s, {r['predicted_nodes']} of "
             f"{r['nodes']} nodes predicted, history {r['history']})",
             f"  largest position error over every node, % of the rod length ({r['length_m']:g} m); free running",
             f"  {'':<32}" + "".join(f"{h:>12}" for h in _HEADS)]
    lines += [f"  {label:<32}" + "".join(_cell(v) for v in values) for label, values in _rows(r)]
    if r.get("horizons"):
        lines.append("  ('-' at a horizon: no held-out trajectory is that long, or the run diverged)")
    return "\n".join(lines)


# ------------------------------------------------------------------------------------------ rollout
def _add_rollout(p):
    p.add_argument("model", metavar="MODEL_DIR", help="a model folder written by 'softrnn dynamic train'")
    p.add_argument("data", metavar="DATA", help="a data set storing every node (the history and the loads)")
    p.add_argument("--group", default=None, help="the trajectory's group inside a sweep file")
    start = p.add_argument("--start", dest="start_time", type=float, default=None, metavar="S",
                           help="the last state taken from the data [s]; the model runs free after it (default: at "
                                "0.6 of the data's span)")
    stop = p.add_argument("--stop", dest="stop_time", type=float, default=None, metavar="S",
                          help="the last predicted time [s] (default: the end)")
    deprecate(p, start, "--start-time")
    deprecate(p, stop, "--stop-time")
    output(p, old=(), required=True, metavar="OUT.h5", help="the predicted trajectory (.h5)")
    p.add_argument("--overwrite", action="store_true", help="replace the -o file if it exists (default: refuse)")


def _check_rollout_size(model, axis, k: int, start: int, stop: int, stop_time) -> None:
    """Refuse, before DATA's node arrays are read, a rollout whose arrays (``rollout_bytes``) would not
    fit this machine (``rod.simulation.array_limit``); ``axis``: DATA's time axis (``nodes=[]``)."""
    from ..learned.whole.rollout import rollout_bytes
    from ..rod import simulation

    (held, data), limit = rollout_bytes(model, axis, k, start, stop), simulation.array_limit()
    if held > limit:
        size = (f"too large for this machine, from {axis.time[start * k]:g} to {axis.time[(stop - 1) * k]:g} s "
                f"({stop - start} model steps, {model.encoding.n_nodes} nodes) it would hold {held / 2**30:.3g} GiB "
                f"of arrays in memory (limit {limit / 2**30:.3g} GiB, DATA itself {data / 2**30:.3g} GiB)")
        if stop_time is None:
            raise SoftrnnInputError(f"the rollout to the end of DATA is {size}; give --stop to stop earlier, or a "
                                    "shorter DATA file")
        raise bad("--stop", stop_time, f"a shorter rollout: this one is {size}; stop earlier, or a shorter DATA file")


def _rollout(args) -> int:
    from ..io.reader import read_dataset
    from ..io.writer import write_dataset
    from ..learned.whole.artifact import load_dynamic
    from ..learned.whole.encoding import check_compatible
    from ..learned.whole.rollout import check_window, rollout_dataset, rollout_steps

    if not str(args.output).endswith((".h5", ".hdf5")):
        raise bad("-o", args.output, "a file name ending in .h5 or .hdf5")
    if Path(args.output).resolve() == Path(args.data).resolve():
        raise bad("-o", args.output, "another file than DATA")
    prepare_output(args.output, "-o", overwrite=args.overwrite)
    axis = read_dataset(args.data, group=args.group, nodes=[])       # the time axis, no node arrays
    with _as_options():
        check_window(axis.time, args.start_time, args.stop_time)
    model = load_dynamic(args.model)
    check_compatible(model.encoding, read_dataset(args.data, group=args.group, stop=1), "DATA")
    times, k = _step_times(model, axis)
    with _as_options():
        start, stop = rollout_steps(times, model.engine.history, args.start_time, args.stop_time)
    _check_rollout_size(model, axis, k, start, stop, args.stop_time)
    data = read_dataset(args.data, group=args.group)
    traj = model.encoding.trajectory(data)
    t0 = _time.perf_counter()
    source = {"model": str(args.model), "reference": str(args.data)}
    ds, diverged = rollout_dataset(model, data, start, stop, attrs=source)
    seconds = _time.perf_counter() - t0
    if diverged is not None:
        raise SimulationError(f"the free run diverged at t = {traj.time[start + diverged]:g} s ({diverged} model "
                              f"steps after the start at {traj.time[start]:g} s); nothing was written; start later "
                              "or stop earlier (--start, --stop), or train the model on more data")
    write_dataset(args.output, ds)
    _rollout_summary(model, data, ds, seconds, args.output)
    return 0


def _rollout_summary(model, data, ds, seconds: float, out) -> None:
    k = model.encoding.stride(float(data.dt))
    rows = np.searchsorted(data.time, ds.time - 1e-9 * float(data.dt))       # the data's samples at ds.time
    err = np.linalg.norm(ds.positions[1:].astype(np.float64) - data.positions[rows[1:]].astype(np.float64), axis=-1)
    steps = len(ds.time) - 1
    print(f"dynamic rollout: {steps} model steps of {model.encoding.model_dt:g} s ({k} data samples each) from "
          f"t = {ds.time[0]:g} to {ds.time[-1]:g} s, {model.encoding.n_predicted} of {model.encoding.n_nodes} nodes "
          f"predicted, in {seconds:.3f} s ({seconds / steps * 1e6:.0f} us per step)")
    print(f"  largest error vs the data over every node: {err.max() * 1e3:.3g} mm "
          f"({100 * err.max() / model.encoding.length:.3g} % of the rod length)")
    print(f"dynamic rollout: wrote {out} (show it with 'softrnn animate {out}')")


# ------------------------------------------------------------------------------------------ export
def _add_export(p):
    p.add_argument("model", metavar="MODEL_DIR", help="a model folder written by 'softrnn dynamic train'")
    p.add_argument("--onnx", required=True, metavar="OUT.onnx",
                   help="the ONNX file of one model step; its encoding goes to OUT.onnx.json beside it")
    p.add_argument("--overwrite", action="store_true",
                   help="replace the ONNX file and its .json sidecar if they exist (default: refuse)")


def _export(args) -> int:
    require_extra("learn")
    from ..learned.whole.artifact import load_dynamic
    from ..learned.whole.export import export_onnx, input_names, output_names, sidecar_path

    path = Path(args.onnx)
    if Path(args.model).resolve() in path.resolve().parents:
        raise bad("--onnx", args.onnx, "a path outside the model folder (a foreign file there would stop "
                                       "'softrnn dynamic train' from replacing the model)")
    prepare_output(path, "--onnx", overwrite=args.overwrite)
    prepare_output(sidecar_path(path), "--onnx", overwrite=args.overwrite,
                   fix="this is the sidecar of --onnx; pass --overwrite to replace both, or choose another path")
    model = load_dynamic(args.model)
    result = export_onnx(model, path)
    print(f"dynamic export: wrote {result.path} (ONNX; {', '.join(input_names(model))} -> "
          f"{', '.join(output_names(model))}) and {result.sidecar} (encoding and layouts)")
    print(f"  checked with ONNX Runtime against the NumPy engine on a random input: largest difference "
          f"{result.max_difference:.2g} (m or rad)")
    return 0


_COMMANDS = (
    ("train", "train a whole-manipulator model on data set files and sweep folders (resumable)", _add_train, _train),
    ("evaluate", "free-running errors at every node on test, held-out and generalisation data beside persistence, "
                 "constant velocity and a linear model", _add_evaluate, _evaluate),
    ("rollout", "run the model free from a data set's history and loads; write every node", _add_rollout, _rollout),
    ("export", "export one model step to ONNX (with its encoding as a .json sidecar), checked with ONNX Runtime",
     _add_export, _export))
