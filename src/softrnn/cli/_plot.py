"""softrnn plot DATA.h5 --node 30 -o node30.png: one node's x, y, z against time (and its forces)."""

from pathlib import Path

from ..errors import bad
from ..files import prepare_output

NAME = "plot"
HELP = "plot one node's position per axis [mm] against time, with the forces on it, to .png/.pdf/.svg"


def add_args(p):
    p.add_argument("data", help="an HDF5 dataset written by softrnn (e.g. by 'softrnn sweep')")
    p.add_argument("--node", type=int, default=None,
                   help="the node to plot (default: the node of interest the file names, if any)")
    p.add_argument("-o", "--output", default=None, metavar="PATH",
                   help="output .png, .pdf or .svg (default: DATA_nodeK.png next to DATA)")
    p.add_argument("--group", default=None, help="the trajectory's group inside the file (default: the only one)")
    p.add_argument("--start", type=float, default=None, help="first time shown [s] (default: the first sample)")
    p.add_argument("--stop", type=float, default=None, help="last time shown [s] (default: the last sample)")
    p.add_argument("--no-forces", action="store_true", help="leave out the force panel")
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
            raise bad("--node", None, f"a node to plot: the file names no node of interest; choose one of "
                      f"{describe_nodes(stored)}")
    data = load(args.data, group=args.group, node=node, start=args.start, stop=args.stop)
    node = int(data.nodes[0])  # a negative --node counts from the rod's end
    out = Path(args.output) if args.output else Path(args.data).with_name(f"{Path(args.data).stem}_node{node}.png")
    check_suffix(out, FIGURE_SUFFIXES, argument="--output")
    prepare_output(out, "--output", overwrite=args.overwrite)
    title = None if _title(dict(data.attrs), fallback="") else f"{Path(args.data).stem}: node {node}"
    plot_node(data, node, out, forces=not args.no_forces, title=title)
    print(f"plot: wrote {out}")
    return 0
