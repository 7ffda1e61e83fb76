"""softrnn animate DATA.h5 -o rod.gif: the rod over time, applied and contact forces as arrows, the
file's obstacles drawn (.gif, or .mp4 with ffmpeg). ``softrnn animate SCENARIO``: simulate the
scenario first (into a temporary dataset, or the --save-data file) and animate that."""

import tempfile
from dataclasses import replace
from pathlib import Path

from ..errors import bad
from ..files import prepare_output
from ._names import SCENARIO_NAMES, STYLES
from ._plot import RECORDED, named_node, over_note, over_reference
from ._progress import Bar

NAME = "animate"
HELP = ("animate a dataset's rod over time with its applied (and contact) forces as arrows and its obstacles, "
        "or simulate a scenario and animate it (.gif, or .mp4 with ffmpeg)")
_DATA = (".h5", ".hdf5")


def add_args(p):
    from ._vocabulary import deprecate

    p.add_argument("data", metavar="DATA|SCENARIO",
                   help="an HDF5 dataset written by softrnn (e.g. by 'softrnn simulate -o'), or a scenario to "
                        "simulate first: a shipped name (" + ", ".join(SCENARIO_NAMES) + ") or a .toml file")
    p.add_argument("-o", "--output", default=None, metavar="PATH",
                   help="output .gif or .mp4 (default: DATA with the suffix .gif; for a scenario: its name "
                        "with .gif, in the current folder)")
    p.add_argument("--style", default="auto", choices=STYLES,
                   help="'fluoroscopy': an X-ray screen's picture of the rod as a guidewire in its contrast-filled "
                        "vessels (flat views only; no forces or legend); 'plain': the rod, forces and obstacles on "
                        "axes in metres; 'auto' (default): fluoroscopy when the data's obstacles include a vessel "
                        "and the view is flat, else plain")
    p.add_argument("--save-data", default=None, metavar="PATH.h5",
                   help="with a scenario: keep the simulated dataset in this file (default: a temporary file, "
                        "removed afterwards)")
    p.add_argument("--samples", type=int, default=None,
                   help="with a scenario: saved samples (default: the scenario's)")
    p.add_argument("--dt", type=float, default=None,
                   help="with a scenario: saved interval in s (default: the scenario's)")
    p.add_argument("--group", default=None, help="the trajectory's group inside the file (default: the only one)")
    p.add_argument("--fps", type=float, default=20.0, help="frames per second of playback (default 20)")
    count = p.add_mutually_exclusive_group()
    count.add_argument("--frames", type=int, default=None,
                       help="number of frames, evenly spaced in time (default: up to 200)")
    playback = count.add_argument("--playback", dest="duration", type=float, default=None, metavar="SECONDS",
                                  help="length of the movie in s (frames = playback x fps)")
    deprecate(p, playback, "--duration", why=" (--duration is simulated time in the other commands)")
    p.add_argument("--start", type=float, default=None, help="first time shown [s] (default: the first sample)")
    p.add_argument("--stop", type=float, default=None, help="last time shown [s] (default: the last sample)")
    p.add_argument("--node", type=int, default=None,
                   help="node of interest to mark (default: the one the file names, if any)")
    p.add_argument("--no-trail", action="store_true", help="do not draw the path of the node of interest")
    p.add_argument("--view", default="auto", choices=("auto", "xy", "xz", "yz", "3d"),
                   help="'auto' (default): the plane of a flat vessel the file records (the rod seen inside it), "
                        "else a flat view when the motion is planar, else 3-D")
    p.add_argument("--elev", type=float, default=22.0, help="3-D camera elevation in degrees (default 22)")
    p.add_argument("--azim", type=float, default=-50.0, help="3-D camera azimuth in degrees (default -50)")
    p.add_argument("--no-obstacles", action="store_true",
                   help="do not draw the obstacles the file records (contact with planes, spheres, cylinders, vessels)")
    p.add_argument("--over", nargs="?", const=RECORDED, default=None, metavar="REFERENCE.h5",
                   help="DATA is a prediction ('softrnn rollout', 'softrnn dynamic rollout'): draw its reference data "
                        "set under it (grey, dashed) with the tip's error; without a path, the reference the "
                        "prediction file records")
    p.add_argument("--no-contact-forces", action="store_true",
                   help="do not draw the file's contact forces as arrows")
    p.add_argument("--size", default="640x560", metavar="WxH", help="frame size in pixels (default 640x560)")
    p.add_argument("--overwrite", action="store_true",
                   help="replace the output (and --save-data) file if it exists (default: refuse)")
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
    from ..figures.data import check_suffix

    scenario = _scenario(args)
    stem = Path(args.data).stem
    out = Path(args.output) if args.output else (Path(args.data).with_suffix(".gif") if scenario is None
                                                 else Path(stem + ".gif"))
    check_suffix(out, argument="--output")
    prepare_output(out, "--output", overwrite=args.overwrite)
    size = parse_size(args.size)
    if args.frames is not None and args.frames < 1:
        raise bad("--frames", args.frames, "an integer >= 1")
    if args.duration is not None and not args.duration > 0:
        raise bad("--playback", args.duration, "a movie length > 0 s")
    if not args.fps > 0:
        raise bad("--fps", args.fps, "a number of frames per second > 0")
    if args.style == "fluoroscopy" and args.view == "3d":      # before any simulation
        raise bad("--view", args.view, "a flat view (auto, xy, xz or yz) with --style fluoroscopy")
    if args.over is not None and args.style == "fluoroscopy":
        raise bad("--style", args.style, "plain or auto with --over (the reference is drawn under the prediction)")
    if args.over is not None and scenario is not None:
        raise bad("--over", args.over, f"a prediction data set to draw over its reference; {args.data} is a scenario")
    if scenario is None:
        return _animate(args, args.data, out, size, Path(args.data).name)
    with tempfile.TemporaryDirectory(prefix="softrnn-animate-") as folder:
        path = args.save_data or str(Path(folder) / "run.h5")
        _simulate(args, scenario, path)
        return _animate(args, path, out, size, scenario.name)


def _scenario(args):
    """The scenario to simulate first, or None when ``args.data`` names a dataset (a .h5 or .hdf5
    name, or an existing file that is not .toml); checks the scenario-only options."""
    text = str(args.data)
    path = Path(text)
    if path.suffix.lower() in _DATA or (path.is_file() and path.suffix.lower() != ".toml"):
        for flag, value in (("--save-data", args.save_data), ("--samples", args.samples), ("--dt", args.dt)):
            if value is not None:
                raise bad(flag, value, f"only with a scenario to simulate; {text} is a dataset (leave {flag} out)")
        return None
    from ..scenarios.scenario import load_scenario

    if not path.is_file() and text not in SCENARIO_NAMES:
        raise bad("data or scenario", text, "an existing .h5 dataset, a shipped scenario ("
                  + ", ".join(SCENARIO_NAMES) + ") or an existing scenario .toml file")
    scenario = load_scenario(text)
    if args.samples is not None and args.samples < 1:
        raise bad("--samples", args.samples, "an integer >= 1")
    if args.dt is not None and not args.dt > 0:
        raise bad("--dt", args.dt, "a saved interval > 0 s")
    if args.save_data is not None:
        if not str(args.save_data).endswith(_DATA):
            raise bad("--save-data", args.save_data, "a file name ending in .h5 or .hdf5")
        prepare_output(args.save_data, "--save-data", overwrite=args.overwrite)
    return scenario


def _simulate(args, scenario, path: str) -> None:
    """Run ``scenario`` (with the --samples and --dt given) into the dataset ``path``, with progress."""
    from ..scenarios.summary import simulate_summary

    changes = {k: v for k, v in (("dt", args.dt), ("n_samples", args.samples)) if v is not None}
    config = replace(scenario.config, **changes) if changes else scenario.config
    with Bar(f"simulate {scenario.name}", enabled=not args.quiet) as bar:
        summary = simulate_summary(name=scenario.name, title=scenario.title, setup=scenario.setup, config=config,
                                   node=scenario.nodes_of_interest[0], out_path=path,
                                   scenario_text=scenario.text, seed=scenario.seed,
                                   attrs={"scenario_name": scenario.name}, progress=bar,
                                   magnetic=scenario.magnetic, record=scenario.record)
    kept = f", saved in {args.save_data}" if args.save_data else ""
    print(f"animate: simulated {scenario.name} ({summary['duration_s']:g} s of motion) in "
          f"{summary['total_time_s']:.1f} s{kept}")


def _animate(args, data_path: str, out: Path, size: tuple[int, int], label: str) -> int:
    """Animate the dataset ``data_path`` (named ``label`` on the progress bar and, when its
    attributes name nothing, in the picture) into ``out`` with the options ``args``."""
    from ..figures.animation import animate
    from ..figures.data import load
    from ..io.reader import read_dataset

    node = args.node
    if node is not None:  # check it first (cheap): the reader's error names the stored nodes
        node = int(read_dataset(data_path, nodes=[node], group=args.group, stop=1).nodes[0])
    data = load(data_path, group=args.group, start=args.start, stop=args.stop)
    if node is None:  # the node the file names, marked when it is stored
        named = named_node(data)
        node = named if named is not None and named in set(data.nodes.tolist()) else None
    reference, ref_path = over_reference(args.over, data_path, dict(data.attrs))
    with Bar(f"animate {label}", unit="frame", enabled=not args.quiet) as bar:
        animate(data, out, fps=args.fps, frames=args.frames, duration=args.duration, node=node,
                trail=not args.no_trail, view=args.view, elev=args.elev, azim=args.azim, size=size,
                title=None if _named(data) else Path(label).stem, obstacles=_obstacles(args, data),
                contact_forces=not args.no_contact_forces, style=args.style, progress=bar, reference=reference)
    print(f"animate: wrote {out}" + over_note(dict(data.attrs), ref_path, f"softrnn animate {data_path} --over"))
    return 0


def _obstacles(args, data):
    """What to draw: nothing (--no-obstacles), the data's own obstacles (True), or, for a prediction
    (a rollout records no contact but keeps its data's scenario record), the obstacles of that
    scenario, with a sweep variant's drawn values."""
    from ..io.record import read_record
    from ..scenarios.record import with_record

    if args.no_obstacles:
        return False
    attrs = dict(getattr(data, "attrs", None) or {})
    if attrs.get("contact") is not None or not attrs.get("prediction"):
        return True
    record = read_record(with_record(data))      # an older file's rebuilt from its scenario text
    return True if record is None or record.contact is None else record.contact


def _named(data) -> bool:
    from ..figures.data import _title

    return _title(dict(getattr(data, "attrs", None) or {}), fallback="") != ""
