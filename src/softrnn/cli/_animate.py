"""softrnn animate DATA.h5 -o rod.gif: the rod over time, applied and contact forces as arrows, the
file's obstacles drawn (.gif, or .mp4 with ffmpeg)."""

from pathlib import Path

from ..errors import bad
from ..figures.animation import animate
from ..figures.data import _title, check_suffix, load
from ..files import prepare_output
from ..io.reader import read_dataset
from ._plot import named_node
from ._progress import Bar

NAME = "animate"
HELP = ("animate a dataset's rod over time with its applied (and contact) forces as arrows and its obstacles "
        "(.gif, or .mp4 with ffmpeg)")


def add_args(p):
    p.add_argument("data", help="an HDF5 dataset written by softrnn (e.g. by 'softrnn sweep')")
    p.add_argument("-o", "--output", default=None, metavar="PATH",
                   help="output .gif or .mp4 (default: DATA with the suffix .gif)")
    p.add_argument("--group", default=None, help="the trajectory's group inside the file (default: the only one)")
    p.add_argument("--fps", type=float, default=20.0, help="frames per second of playback (default 20)")
    count = p.add_mutually_exclusive_group()
    count.add_argument("--frames", type=int, default=None,
                       help="number of frames, evenly spaced in time (default: up to 200)")
    count.add_argument("--duration", type=float, default=None,
                       help="playback length in s (frames = duration x fps)")
    p.add_argument("--start", type=float, default=None, help="first time shown [s] (default: the first sample)")
    p.add_argument("--stop", type=float, default=None, help="last time shown [s] (default: the last sample)")
    p.add_argument("--node", type=int, default=None,
                   help="node of interest to mark (default: the one the file names, if any)")
    p.add_argument("--no-trail", action="store_true", help="do not draw the path of the node of interest")
    p.add_argument("--view", default="auto", choices=("auto", "xy", "xz", "yz", "3d"),
                   help="'auto' (default): a flat view when the motion is planar, else 3-D")
    p.add_argument("--elev", type=float, default=22.0, help="3-D camera elevation in degrees (default 22)")
    p.add_argument("--azim", type=float, default=-50.0, help="3-D camera azimuth in degrees (default -50)")
    p.add_argument("--no-obstacles", action="store_true",
                   help="do not draw the obstacles the file records (contact with planes, spheres, cylinders, vessels)")
    p.add_argument("--no-contact-forces", action="store_true",
                   help="do not draw the file's contact forces as arrows")
    p.add_argument("--size", default="640x560", metavar="WxH", help="frame size in pixels (default 640x560)")
    p.add_argument("--overwrite", action="store_true", help="replace the output file if it exists (default: refuse)")
    p.add_argument("--quiet", action="store_true", help="no progress bar")


def parse_size(text: str) -> tuple[int, int]:
    try:
        w, h = (int(v) for v in text.lower().split("x"))
    except ValueError:
        raise bad("--size", text, "WIDTHxHEIGHT in pixels, e.g. 640x560") from None
    if not (64 <= w <= 4096 and 64 <= h <= 4096):
        raise bad("--size", text, "WIDTHxHEIGHT in pixels, each between 64 and 4096")
    return w, h


def run(args) -> int:
    out = Path(args.output) if args.output else Path(args.data).with_suffix(".gif")
    check_suffix(out, argument="--output")
    prepare_output(out, "--output", overwrite=args.overwrite)
    size = parse_size(args.size)
    if args.frames is not None and args.frames < 1:
        raise bad("--frames", args.frames, "an integer >= 1")
    if args.duration is not None and not args.duration > 0:
        raise bad("--duration", args.duration, "a playback length > 0 s")
    if not args.fps > 0:
        raise bad("--fps", args.fps, "a number of frames per second > 0")
    node = args.node
    if node is not None:  # check it first (cheap): the reader's error names the stored nodes
        node = int(read_dataset(args.data, nodes=[node], group=args.group, stop=1).nodes[0])
    data = load(args.data, group=args.group, start=args.start, stop=args.stop)
    if node is None:  # the node the file names, marked when it is stored
        named = named_node(data)
        node = named if named is not None and named in set(data.nodes.tolist()) else None
    with Bar(f"animate {Path(args.data).name}", unit="frame", enabled=not args.quiet) as bar:
        animate(data, out, fps=args.fps, frames=args.frames, duration=args.duration, node=node,
                trail=not args.no_trail, view=args.view, elev=args.elev, azim=args.azim, size=size,
                title=None if _named(data) else Path(args.data).stem, obstacles=not args.no_obstacles,
                contact_forces=not args.no_contact_forces, progress=bar)
    print(f"animate: wrote {out}")
    return 0


def _named(data) -> bool:
    return _title(dict(getattr(data, "attrs", None) or {}), fallback="") != ""
