"""softrnn rollout MODEL [MODEL ...] DATA.h5 -o pred.h5: step node models together (paper Fig. 2C),
free running, and write the predicted trajectory in the data set format."""

from __future__ import annotations

import time as _time
from pathlib import Path

from ..errors import SoftrnnInputError, bad
from ..files import prepare_output
from ._lazy import numpy as np
from ._progress import Bar

NAME = "rollout"
HELP = ("run node models together, free running from a data set's initial history (paper Fig. 2C), and "
        "write the predicted trajectory as a data set (for 'softrnn animate/plot PRED.h5 --over DATA.h5')")


def add_args(p):
    p.add_argument("paths", nargs="+", metavar="MODEL ... DATA.h5",
                   help="model folders (each predicts its own node), then the reference data set")
    p.add_argument("-o", "--output", required=True, metavar="PATH.h5", help="the predicted trajectory (.h5)")
    p.add_argument("--shared", default=None, metavar="MODEL",
                   help="one model applied to many nodes (beyond the paper), neighbours at the same offsets")
    p.add_argument("--shared-nodes", default=None, metavar="NODES",
                   help="nodes for --shared, e.g. 1..49 or 1,2,10..20 (default: the nodes a pooled model was "
                        "trained for (train --pool), else every stored node whose neighbours are stored and that "
                        "has no model of its own)")
    p.add_argument("--group", default=None, help="the trajectory's group inside a sweep file")
    p.add_argument("--start", type=float, default=None,
                   help="time of the first predicted sample [s] (default: right after the seed history)")
    p.add_argument("--stop", type=float, default=None, help="time of the last predicted sample [s] (default: the end)")
    p.add_argument("--unmodelled", default="reference", choices=("reference", "hold"),
                   help="nodes without a model: follow the reference data (default; for clamps, the boundary "
                        "condition) or hold their last seed pose")
    p.add_argument("--figure", default=None, metavar="PATH",
                   help="also draw predicted (dashed) and reference rod shapes at a few times (.png/.pdf/.svg)")
    p.add_argument("--overwrite", action="store_true",
                   help="replace the -o and --figure files if they exist (default: refuse)")
    p.add_argument("--quiet", action="store_true", help="no progress bar")


def parse_nodes(text: str, argument: str = "--shared-nodes") -> list[int]:
    """'1..49' or '1,2,10..20' (also the older '1-49') -> the node indices, sorted."""
    from ._vocabulary import node_list

    return sorted(set(node_list(text, argument)))


def run(args) -> int:
    from ..figures.data import FIGURE_SUFFIXES, check_suffix
    from ..io.reader import read_dataset
    from ..learned.node.artifact import load_model
    from ..learned.node.evaluate import check_compatible
    from ..learned.node.manipulator import Manipulator, model_inputs
    from ..learned.node.rollout import max_error_mm, rollout, write_rollout

    if len(args.paths) < 2 and args.shared is None:
        raise bad("MODEL", None, "at least one model folder before DATA.h5 (or --shared MODEL)")
    *folders, data_path = args.paths
    if not str(args.output).endswith((".h5", ".hdf5")):
        raise bad("-o", args.output, "a file name ending in .h5 or .hdf5")
    if Path(args.output).resolve() == Path(data_path).resolve():
        raise bad("-o", args.output, "another file than the reference data set")
    if args.figure:
        check_suffix(args.figure, FIGURE_SUFFIXES, argument="--figure")
    if args.shared_nodes is not None and args.shared is None:
        raise bad("--shared-nodes", args.shared_nodes, "--shared MODEL as well")
    prepare_output(args.output, "-o", overwrite=args.overwrite)
    if args.figure:
        prepare_output(args.figure, "--figure", overwrite=args.overwrite)
    models = [load_model(f) for f in folders]
    shared = load_model(args.shared) if args.shared else None
    head = read_dataset(data_path, group=args.group, stop=1)  # stored nodes and attrs, one sample
    for m in models + ([shared] if shared is not None else []):
        check_compatible(m, head, where=str(data_path))
    names = [str(f) for f in folders]
    shared_nodes: list[int] = []
    if shared is not None:
        own = {int(m.spec.node) for m in models}
        if args.shared_nodes is not None:
            shared_nodes = [a for a in parse_nodes(args.shared_nodes) if a not in own]
        elif shared.meta.get("pool"):   # a pooled model: the nodes it was trained for
            shared_nodes = [int(a) for a in shared.meta["pool"] if int(a) not in own]
        else:
            stored = set(int(a) for a in head.nodes)
            shared_nodes = [a for a in sorted(stored) if a not in own
                            and set(model_inputs(shared, a)[1]) <= stored]
        if not shared_nodes:
            raise bad("--shared-nodes", args.shared_nodes, "at least one node without a model of its own")
        names.append(f"{args.shared} (shared: nodes {_ranges(shared_nodes)})")
    manip = Manipulator.of(models, shared=shared, shared_nodes=shared_nodes)
    data = read_dataset(data_path, group=args.group)
    start, stop = _span(data.time, manip.history, args.start, args.stop)
    t0 = _time.perf_counter()
    with Bar(f"rollout {Path(data_path).name}", unit="step", enabled=not args.quiet) as bar:
        result = rollout(manip, data, start, stop, unmodelled=args.unmodelled, progress=bar)
    seconds = _time.perf_counter() - t0
    out = write_rollout(args.output, result, data, models=names, source=str(data_path))
    steps = result.stop - result.start
    n = len(result.modelled)
    print(f"rollout: {n} modelled node{'s' if n != 1 else ''} ({_ranges(result.modelled)}; "
          f"{len(manip.distinct_models())} model{'s' if len(manip.distinct_models()) != 1 else ''}), "
          f"unmodelled nodes: {args.unmodelled}")
    print(f"  predicted samples {result.start}..{result.stop - 1} (t = {result.time[result.seed]:g} .. "
          f"{result.time[-1]:g} s, {steps} steps) from {result.seed} seed samples, in {seconds:.2f} s "
          f"({seconds / steps * 1e6:.0f} us per step, {seconds / (steps * n) * 1e6:.1f} us per node-step)")
    errors = max_error_mm(result, data)
    worst = max(errors, key=lambda a: float(np.max(errors[a])))
    e = errors[worst]
    print(f"  largest error vs the reference: node {worst}, max |error| [mm] x {e[0]:.3f}, y {e[1]:.3f}, z {e[2]:.3f}")
    print(f"rollout: wrote {out} (show it over the data with 'softrnn animate {out} --over {data_path}' or "
          f"'softrnn plot {out} --over {data_path}')")
    if args.figure:
        _figure(result, data, args.figure)
        print(f"rollout: wrote {args.figure}")
    return 0


def _span(time: np.ndarray, history: int, start, stop) -> tuple[int, int]:
    """Sample indices [start, stop) of the predicted samples for times --start/--stop [s]."""
    from ..figures.data import time_span

    T = time.shape[0]
    if T <= history:
        raise SoftrnnInputError(f"the data set has {T} samples but the models' history is {history}: they need at "
                                f"least {history + 1} (the history and one sample to predict); use a longer record")
    i0, i1 = time_span(time, start, stop, names=("--start", "--stop"))
    if start is None:
        i0 = history
    elif i0 < history:
        raise bad("--start", start, f"a time >= {time[history]:g} s: the {history} samples before the first "
                                    f"predicted one seed the history")
    if i1 < i0:
        raise bad("--stop", stop, f"a time after the first predicted sample ({time[i0]:g} s)")
    return i0, i1 + 1


def _ranges(nodes) -> str:
    nodes = sorted(int(a) for a in nodes)
    parts, i = [], 0
    while i < len(nodes):
        j = i
        while j + 1 < len(nodes) and nodes[j + 1] == nodes[j] + 1:
            j += 1
        parts.append(f"{nodes[i]}..{nodes[j]}" if j > i else str(nodes[i]))
        i = j + 1
    return ",".join(parts)


def _figure(result, data, path) -> None:
    from ..figures import plots as plotting
    from ..figures.saving import save_figure

    rows = np.unique(np.linspace(result.seed, result.positions.shape[0] - 1, 5).round().astype(int))
    ref = data.positions[result.first + rows]
    modelled = np.isin(result.nodes, np.asarray(result.modelled))
    name = data.attrs.get("scenario_name") or "data"
    fig = plotting.predicted_shapes(result.time[rows], ref, result.positions[rows],
                                    f"{name}: rollout of nodes {_ranges(result.modelled)}", modelled=modelled)
    save_figure(fig, path)
