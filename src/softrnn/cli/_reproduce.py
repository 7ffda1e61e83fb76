"""softrnn reproduce: run the paper's pipeline end to end into -o DIR (resumable)."""

from ..errors import require_extra
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


def run(args) -> int:
    # resumable by design: its own folder is continued, anything else is refused
    for extra in ("learn", "dask"):     # every step is needed: refuse before the first one runs
        require_extra(extra)
    from ..reproduce.pipeline import reproduce

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
    return 0
