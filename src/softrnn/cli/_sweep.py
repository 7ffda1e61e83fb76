"""softrnn sweep SCENARIO --count N -o DIR: randomised variants in parallel on Dask (resumable)."""

from ..files import prepare_output
from ._progress import Bar
from ._vocabulary import output

NAME = "sweep"
HELP = "simulate N randomised variants of a scenario in parallel on Dask into a folder (resumable)"


def add_args(p):
    p.add_argument("scenario", help="a shipped scenario name or a path to a .toml file")
    p.add_argument("--count", type=int, required=True, metavar="N",
                   help="number of variants (indices 0..N-1, at most 100000)")
    output(p, dest="out", required=True, metavar="DIR", help="output folder: one traj-NNNNN.h5 per variant")
    p.add_argument("--scheduler", default=None, metavar="tcp://HOST:PORT",
                   help="use an existing Dask cluster (default: a local cluster)")
    p.add_argument("--workers", type=int, default=2, help="local worker processes (default 2)")
    p.add_argument("--samples", type=int, default=None, help="samples per trajectory (default: the scenario's)")
    p.add_argument("--dt", type=float, default=None, metavar="SECONDS",
                   help="saved interval [s] (default: the scenario's); the solver step stays the stable one")
    p.add_argument("--merge", default=None, metavar="FILE.h5",
                   help="also combine the trajectories into one file, one group each")
    from ._vocabulary import RESTART_HELP

    p.add_argument("--overwrite", action="store_true", help=RESTART_HELP)
    p.add_argument("--quiet", action="store_true", help="no progress bar")


def run(args) -> int:
    from ..scenarios.scenario import load_scenario
    from ..sweeps.sweep import MANIFEST, check_sweep, run_sweep

    scenario = load_scenario(args.scenario)
    # bad values and a sweep too large for this machine: refused before any folder, worker or step
    check_sweep(scenario, args.count, n_workers=args.workers, n_samples=args.samples, dt=args.dt)
    # resumable by design: its own folder is continued, anything else is refused
    prepare_output(args.out, "-o", kind="folder", overwrite=True, mine=(MANIFEST,))
    if args.merge:
        prepare_output(args.merge, "--merge", overwrite=True)   # remade from the folder on every run
    from ._vocabulary import start_again

    start_again(args.out, args.overwrite)
    with Bar(f"sweep {scenario.name}", unit="traj", enabled=not args.quiet) as bar:
        result = run_sweep(scenario, args.count, args.out, scheduler=args.scheduler, n_workers=args.workers,
                           n_samples=args.samples, dt=args.dt, progress=bar)
    print(f"sweep {scenario.name}: {args.count} trajectories in {args.out} "
          f"({len(result.computed)} computed in {result.wall_time:.1f} s, {len(result.skipped)} already there)")
    if args.merge:
        from ..io.sweepfiles import merge_files

        merge_files(result.files, args.merge)
        print(f"merged into {args.merge} (groups traj-00000 .. traj-{args.count - 1:05d})")
    return 0
