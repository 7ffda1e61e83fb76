"""softrnn bench: measure the simulator's speed on this machine (table, optional JSON)."""

import json

from ..io_util import atomic_write_text
from ._progress import Bar

NAME = "bench"
HELP = "benchmark the simulator on this machine (us per node-step, real-time factor, compile times)"


def add_args(p):
    p.add_argument("--json", default=None, metavar="PATH", help="write the results as JSON")
    p.add_argument("--quick", action="store_true", help="shorter runs (less precise)")


def run(args) -> int:
    from ..bench.simulator import format_table, run_benchmark

    with Bar("bench", unit="item") as bar:
        result = run_benchmark(quick=args.quick, progress=bar)
    print(format_table(result))
    if args.json:
        atomic_write_text(args.json, json.dumps(result, indent=2))
    return 0
