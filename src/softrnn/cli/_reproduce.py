"""softrnn reproduce: run the paper's pipeline end to end into -o DIR (resumable)."""

import sys

from ..errors import bad, require_extra
from ..files import prepare_output
from ._progress import Bar
from ._vocabulary import output

NAME = "reproduce"
HELP = ("reproduce the paper: simulated cases, node models, the whole manipulator, the magnetic experiment "
        "(Table 1), Fig. 13/14, benchmark; report.md/report.json and figures in -o DIR")


def add_args(p):
    output(p, dest="out", default="out/reproduce", metavar="DIR", help="output folder (default: out/reproduce)")
    p.add_argument("--quick", action="store_true", help="shorter runs (10%% of each case), for a smoke test")
    from ._vocabulary import RESTART_HELP

    p.add_argument("--overwrite", action="store_true", help=RESTART_HELP)
    p.add_argument("--quiet", action="store_true", help="no progress bars")
    p.add_argument("--compare", metavar="REF", default=None,
                   help="after the run, compare its accuracy figures (timings aside) with the reference "
                        "folder or report.json REF (e.g. docs/results/reference-quick); exit 1 if one moved")


def before_libraries() -> None:
    """Pin the numeric libraries' code paths (``learned.threads.pin_numerics``) before the command
    imports NumPy, which reads two of them when it loads; the report says which held."""
    from ..learned.threads import pin_numerics

    pin_numerics()


def run(args) -> int:
    # resumable by design: its own folder is continued, anything else is refused
    for extra in ("learn", "dask"):     # every step is needed: refuse before the first one runs
        require_extra(extra)
    from ..reproduce.compare import check, load_report
    from ..reproduce.pipeline import reproduce

    if args.compare is not None:       # a bad reference is refused before the run, not after it
        ref = load_report(args.compare, "--compare")
        if ref["quick"] != args.quick:
            this, theirs = ("quick", "full") if args.quick else ("full", "quick")
            raise bad("--compare", args.compare, f"the reference of a {this} run (it is a {theirs} run's: "
                      f"{'add' if ref['quick'] else 'drop'} --quick, or compare with a {this} reference)")
    prepare_output(args.out, "-o", kind="folder", overwrite=True, mine=("cases", "report.json"))
    from ._vocabulary import start_again

    start_again(args.out, args.overwrite)
    bars = []

    def factory(desc):
        bar = Bar(desc, unit="step", enabled=not args.quiet)
        bars.append(bar)
        return bar

    try:
        reproduce(args.out, quick=args.quick, progress_factory=factory)
    finally:
        for bar in bars:
            bar.__exit__(None, None, None)
    print(f"report: {args.out}/report.md and {args.out}/report.json; figures in {args.out}/figures")
    if args.compare is None:
        return 0
    same, text = check(args.out, args.compare)
    print(f"compared with {args.compare}: {text}")
    if not same:
        print(f"softrnn reproduce: the figures moved from {args.compare}; if on purpose, regenerate the "
              "references (make references) in the same commit and say why", file=sys.stderr)
    return 0 if same else 1
