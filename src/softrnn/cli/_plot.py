"""softrnn plot DATA.h5 --node 30 -o node30.png: one node's x, y, z against time (and its forces and the
data's actuation inputs); ``--over REFERENCE.h5``: a prediction drawn over its reference data, with
the node's error."""

from pathlib import Path

from ..errors import SoftrnnInputError, bad
from ..files import prepare_output

NAME = "plot"
RECORDED = "recorded"
"""``--over`` without a path: the reference the prediction file records."""
HELP = ("plot one node's position per axis [mm] against time, with the forces on it and the actuation inputs, "
        "or a prediction over its reference data, to .png/.pdf/.svg")


def add_args(p):
    p.add_argument("data", help="an HDF5 dataset written by softrnn (e.g. by 'softrnn sweep')")
    p.add_argument("--node", type=int, default=None,
                   help="the node to plot (default: the node of interest the file names, else the only node stored)")
    p.add_argument("-o", "--output", default=None, metavar="PATH",
                   help="output .png, .pdf or .svg (default: DATA_nodeK.png next to DATA)")
    p.add_argument("--group", default=None, help="the trajectory's group inside the file (default: the only one)")
    p.add_argument("--start", type=float, default=None, help="first time shown [s] (default: the first sample)")
    p.add_argument("--stop", type=float, default=None, help="last time shown [s] (default: the last sample)")
    p.add_argument("--no-forces", action="store_true", help="leave out the force panel")
    p.add_argument("--no-inputs", action="store_true", help="leave out the actuation inputs' panels")
    p.add_argument("--over", nargs="?", const=RECORDED, default=None, metavar="REFERENCE.h5",
                   help="DATA is a prediction ('softrnn rollout', 'softrnn dynamic rollout'): draw it over its "
                        "reference data set (dashed), with the node's error; without a path, the reference the "
                        "prediction file records")
    p.add_argument("--overwrite", action="store_true", help="replace the output file if it exists (default: refuse)")


def named_node(data) -> int | None:
    """The node of interest that dataset-like ``data`` names (``figures.data.node_of_interest``: its
    attrs or scenario record, an older file's rebuilt from its scenario text), else that of the paper
    case its ``attrs['case']`` names, else None."""
    from ..figures.data import _text, node_of_interest
    from ..scenarios.cases import CASE_NAMES, build_case
    from ..scenarios.record import with_record

    case = _text(dict(getattr(data, "attrs", None) or {}).get("case"))
    node = node_of_interest(with_record(data))
    if node is None and case in CASE_NAMES:
        node = node_of_interest(data, default=build_case(case).node_of_interest)
    return node


def run(args) -> int:
    from ..figures.data import FIGURE_SUFFIXES, _title, check_suffix, describe_nodes, load
    from ..figures.pictures import plot_node
    from ..io.reader import read_dataset

    if args.output:
        check_suffix(args.output, FIGURE_SUFFIXES, argument="--output")
        prepare_output(args.output, "--output", overwrite=args.overwrite)
    node = args.node
    if node is None:
        meta = read_dataset(args.data, nodes=[], group=args.group)  # attrs and time only
        node = named_node(meta)
        if node is None:
            stored = read_dataset(args.data, nodes=None, group=args.group, stop=1).nodes
            if len(stored) != 1:
                raise bad("--node", None, f"a node to plot: the file names no node of interest; choose one of "
                          f"{describe_nodes(stored)}")
            node = int(stored[0])               # the only node stored (a tip-only recording): that one
    data = load(args.data, group=args.group, node=node, start=args.start, stop=args.stop)
    node = int(data.nodes[0])  # a negative --node counts from the rod's end
    reference, ref_path = over_reference(args.over, args.data, dict(data.attrs), node=node)
    out = Path(args.output) if args.output else Path(args.data).with_name(f"{Path(args.data).stem}_node{node}.png")
    check_suffix(out, FIGURE_SUFFIXES, argument="--output")
    prepare_output(out, "--output", overwrite=args.overwrite)
    title = None if _title(dict(data.attrs), fallback="") else f"{Path(args.data).stem}: node {node}"
    plot_node(data, node, out, forces=not args.no_forces, title=title, inputs=not args.no_inputs,
              reference=reference)
    print(f"plot: wrote {out}" + over_note(dict(data.attrs), ref_path, f"softrnn plot {args.data} --over"))
    return 0


def over_reference(over, data_path, attrs: dict, node: int | None = None):
    """(reference data set, its path) of ``--over``, (None, None) without it: the path given, or
    with ``RECORDED`` the one the prediction file records; only ``node`` when given."""
    if over is None:
        return None, None
    from ..figures.data import describe_nodes
    from ..figures.overlay import recorded_reference
    from ..io.reader import read_dataset

    path = recorded_reference(data_path, attrs) if over == RECORDED else Path(over)
    if path is None:
        raise SoftrnnInputError(f"--over without a path: {data_path} records no reference data set (it is not a "
                                f"prediction of 'softrnn rollout'); give it with --over REFERENCE.h5")
    if path.resolve() == Path(data_path).resolve():
        raise bad("--over", str(over), "another file than the prediction (its reference data set)")
    if node is None:
        return read_dataset(path), path
    stored = read_dataset(path, stop=1).nodes
    if node not in set(int(a) for a in stored):
        raise bad("--over", str(path), f"the data set the prediction was made from: it stores no node {node} "
                  f"(it stores {describe_nodes(stored)})")
    return read_dataset(path, nodes=[node]), path


def over_note(attrs: dict, ref_path, command: str) -> str:
    """' (over REF)' after an overlay; for a prediction drawn alone, how to draw it over its data."""
    if ref_path is not None:
        return f" (over {ref_path})"
    return f" (a prediction: '{command}' draws it over its reference data)" if attrs.get("prediction") else ""
