"""softrnn bench: the learned models, the simulator and the static solver on this machine (table, JSON)."""

import importlib.util
import json

from ..files import atomic_write_text, prepare_output
from ._progress import Bar

NAME = "bench"
HELP = ("benchmark this machine: learned-model steps (compiled vs eager PyTorch), the simulator, the "
        "static solver, the whole-manipulator model against the simulator and the navigation environments")
PARTS = ("model", "simulator", "statics", "dynamic", "envs")


def default_parts() -> tuple:
    """Every part; the navigation environments' only where their extra (gymnasium) is installed."""
    return PARTS if importlib.util.find_spec("gymnasium") is not None else PARTS[:-1]


def add_args(p):
    p.add_argument("--json", default=None, metavar="PATH", help="write the results as JSON")
    p.add_argument("--overwrite", action="store_true", help="replace the --json file if it exists (default: refuse)")
    p.add_argument("--quick", action="store_true", help="shorter runs (less precise)")
    p.add_argument("--quiet", action="store_true", help="no progress bar")
    p.add_argument("--only", default=None, metavar="PART[,PART]",
                   help=f"run only some parts: {', '.join(PARTS)} (default: all; envs where gymnasium is "
                        "installed)")
    p.add_argument("--model", default=None, metavar="DIR",
                   help="time this trained model folder for the node step (default: the default architecture "
                        "with random weights)")
    p.add_argument("--dynamic-model", default=None, metavar="DIR",
                   help="time this whole-manipulator model folder (or a folder of CASE/model folders, e.g. "
                        "softrnn reproduce's dynamic/) against the simulator (default: the default architecture "
                        "of each case, untrained: the arithmetic per step is timed)")


def run(args) -> int:
    from ..bench import format_all, run_all
    from ..errors import bad, require_extra

    parts = default_parts() if args.only is None else tuple(x.strip() for x in args.only.split(",") if x.strip())
    unknown = [x for x in parts if x not in PARTS]
    if unknown or not parts:
        raise bad("--only", args.only, f"a comma-separated subset of {', '.join(PARTS)}")
    if "model" in parts or "dynamic" in parts:
        require_extra("learn")   # or run the other parts: --only simulator,statics
    if "envs" in parts:
        require_extra("envs")
    if args.json:
        prepare_output(args.json, "--json", overwrite=args.overwrite)
    model = None
    if args.model is not None:
        from ..learned.node.artifact import load_model
        model = load_model(args.model)
    dynamic = {}
    if "dynamic" in parts:
        from ..bench.dynamic import find_models
        from ..reproduce.dynamic import CONFIGS  # the architecture softrnn reproduce trains

        dynamic = {"dynamic_configs": CONFIGS,
                   "dynamic_models": find_models(args.dynamic_model) if args.dynamic_model else None}
    with Bar("bench", unit="item", enabled=not args.quiet) as bar:
        result = run_all(parts, quick=args.quick, model=model, progress=bar, **dynamic)
    print(format_all(result))
    if args.json:
        atomic_write_text(args.json, json.dumps(result, indent=2))
    return 0
