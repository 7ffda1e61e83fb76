"""softrnn study hparams DATA.h5 --node N -o DIR: the paper's Fig. 14 study (LSTM units x history, resumable)."""

import json
import sys

from ..errors import bad
from ._progress import Bar, stop_code
from ._vocabulary import output

NAME = "study"
HELP = "hyper-parameter studies of the node models (hparams: the paper's Fig. 14, resumable, on Dask)"


def add_args(p):
    sub = p.add_subparsers(title="studies", dest="study", required=True)
    h = sub.add_parser("hparams", help="Fig. 14: bandwidth and RMS error over LSTM units x history size",
                       description="Train one node model per grid point (LSTM units x history size) in parallel on "
                                   "Dask, evaluate its one-step RMS error on the test span, measure its bandwidth, "
                                   "and draw the two heatmaps of the paper's Fig. 14 (DIR/fig14.png). An interrupted "
                                   "study resumes when run again with the same settings.")
    h.add_argument("data", help="an HDF5 dataset written by softrnn (simulate, sweep, import-csv)")
    h.add_argument("--node", type=int, required=True, help="the node to model (e.g. 50 for the semicircle)")
    output(h, dest="out", required=True, metavar="DIR", help="the study folder (created; resumed if present)")
    h.add_argument("--units", default="5,10,15,20,25", metavar="U,...",
                   help="LSTM units per layer of the grid (default: 5,10,15,20,25)")
    h.add_argument("--history", default="2,5,10,20", metavar="H,...",
                   help="history sizes of the grid, past steps per window (default: 2,5,10,20)")
    h.add_argument("--epochs", type=int, default=10, help="training epochs of every point (default: 10)")
    h.add_argument("--seed", type=int, default=0, help="random seed of every point's training (default: 0)")
    h.add_argument("--wrench", choices=("none", "force", "wrench"), default=None,
                   help="input II (default: force if any force acts on the node in the training span, else none)")
    h.add_argument("--bandwidth-steps", type=int, default=2000,
                   help="timed stepper calls per point (default: 2000)")
    h.add_argument("--scheduler", default=None, metavar="tcp://HOST:PORT",
                   help="an existing Dask cluster, or 'synchronous' to train in this process (default: a local "
                        "cluster)")
    h.add_argument("--workers", type=int, default=2, help="local worker processes (default 2)")
    h.add_argument("--json", default=None, metavar="PATH", help="also write the summary as JSON")
    from ._vocabulary import RESTART_HELP

    h.add_argument("--overwrite", action="store_true", help=RESTART_HELP)
    h.add_argument("--quiet", action="store_true", help="no progress bar")


def _ints(text: str, argument: str) -> tuple:
    try:
        return tuple(int(a) for a in text.split(","))
    except ValueError:
        raise bad(argument, text, "comma-separated positive integers, e.g. 5,10,15") from None


def _fmt(v, spec=".3g") -> str:
    return "-" if v is None else format(v, spec)


def _print_table(result) -> None:
    print(f"{'units':>5} {'H':>3} {'params':>7} {'RMSE mm':>9} {'x':>9} {'y':>9} {'z':>9} "
          f"{'stepper Hz':>11} {'torch Hz':>9} {'epochs':>6}")
    for r in result.points:
        e, b = r["error"], r.get("bandwidth") or {}
        torch = (b.get("torch") or {}).get("hz")
        print(f"{r['units']:>5} {r['history']:>3} {r['parameters']:>7} {e['rmse_mm']:>9.3g} "
              + " ".join(f"{v:>9.3g}" for v in e["rmse_axis_mm"])
              + f" {_fmt((b.get('stepper') or {}).get('hz'), '.4g'):>11} {_fmt(torch, '.4g'):>9} "
                f"{r['training']['epochs_run']:>6}")


def _print_regions(result) -> None:
    t = result.trends
    for key, label, unit in (("bandwidth", "bandwidth (compiled stepper)", "Hz"),
                             ("torch_bandwidth", "bandwidth (eager PyTorch)", "Hz"),
                             ("rms_error", "RMS error", "mm")):
        reg = result.regions.get(key)
        if reg is None:
            continue
        best, paper = reg.best, reg.paper
        print(f"{label}: best {best['value']:.4g} {unit} at {best['units']} units, H = {best['history']}; region "
              f"({reg.criterion}): units {reg.units[0]}-{reg.units[1]}, H {reg.history[0]}-"
              f"{reg.history[1]} ({len(reg.points)} points, {reg.fraction_in_paper_region:.0%} inside the "
              f"paper's); paper: units {paper['lstm_units'][0]}-{paper['lstm_units'][1]}, H {paper['history'][0]}-"
              f"{paper['history'][1]}")
    for key, label in (("bandwidth", "stepper bandwidth"), ("torch_bandwidth", "torch bandwidth"),
                       ("rms_error", "RMS error")):
        u, h = t.get(f"{key}_vs_units"), t.get(f"{key}_vs_history")
        if u is not None or h is not None:
            print(f"{label}: {_fmt(None if u is None else 100 * u, '+.0f')} % from the fewest to the most units, "
                  f"{_fmt(None if h is None else 100 * h, '+.0f')} % from the shortest to the longest history")
    print(f"paper ({result.paper['source']}):")
    print(f"  \"{result.paper['bandwidth']}\"")
    print(f"  \"{result.paper['rms_error']}\"")


def run(args) -> int:
    from ..experiments.fig14 import MANIFEST, StudyConfig, run_study
    from ..files import atomic_write_text, prepare_output
    from ._train import _default_wrench

    if args.workers < 1:
        raise bad("--workers", args.workers, "an integer >= 1")
    # resumable by design: its own folder is continued, anything else is refused
    prepare_output(args.out, "-o", kind="folder", overwrite=True, mine=(MANIFEST,))
    if args.json:
        prepare_output(args.json, "--json", overwrite=True)   # the summary, rewritten on every run
    wrench = args.wrench or _default_wrench(args.data, args.node)
    config = StudyConfig(node=args.node, units=_ints(args.units, "--units"), history=_ints(args.history, "--history"),
                         epochs=args.epochs, seed=args.seed, wrench=wrench, bandwidth_steps=args.bandwidth_steps)
    from ._vocabulary import start_again

    start_again(args.out, args.overwrite)
    with Bar("study hparams", unit="step", enabled=not args.quiet) as bar:
        try:
            result = run_study(args.data, config, args.out, scheduler=args.scheduler, workers=args.workers,
                               progress=bar)
        except KeyboardInterrupt as err:
            bar.close()
            print(f"softrnn: interrupted; the finished grid points are kept in {args.out}; run the same command "
                  f"again to compute only the missing ones", file=sys.stderr)
            return stop_code(err)
    n = len(result.points)
    print(f"study hparams: {n} grid points in {args.out} ({len(result.computed)} trained, "
          f"{len(result.measured)} timed now, {len(result.found)} already there) in "
          f"{result.wall_seconds:.1f} s; one-step RMS error on the test span, bandwidth = calls per second on one "
          f"thread (the median of 5 runs)")
    _print_table(result)
    _print_regions(result)
    print(f"figure: {result.figure}")
    if args.json:
        atomic_write_text(args.json, json.dumps(result.to_dict(), indent=2, allow_nan=False) + "\n")
        print(f"summary written to {args.json}")
    return 0
