"""softrnn lab-example -o DIR: lab-like CSV recordings of the simulated three-tendon arm (one tip
marker with noise, the tendon tensions, 20 Hz) for the lab workflow (docs/guide/lab-workflow.md)."""

from ..errors import bad
from ._progress import Bar

_OPTIONS = {"scenarios": "--scenarios", "scenario": "--scenarios", "duration": "--duration", "rate": "--rate",
            "noise": "--noise", "seed": "--seed", "out_dir": "-o"}

NAME = "lab-example"
HELP = ("write lab-like CSV recordings of the simulated three-tendon arm (a noisy tip marker and the tendon "
        "tensions at 20 Hz) to try the lab workflow: import-csv, train --drive actuation, evaluate, export")


def add_args(p):
    from ..experiments.lab_example import DEFAULT_SCENARIOS, LabExampleConfig

    d = LabExampleConfig()
    p.add_argument("-o", "--output", required=True, metavar="DIR",
                   help="folder to write <scenario>.csv into (created if needed)")
    p.add_argument("--scenarios", default=",".join(DEFAULT_SCENARIOS), metavar="NAME,...",
                   help=f"tendon scenarios to record, one CSV each (default: {','.join(DEFAULT_SCENARIOS)})")
    p.add_argument("--duration", type=float, default=d.duration,
                   help=f"seconds per recording (default: {d.duration:g})")
    p.add_argument("--rate", type=float, default=d.rate, help=f"samples per second in Hz (default: {d.rate:g})")
    p.add_argument("--noise", type=float, default=d.noise,
                   help=f"marker noise, standard deviation per axis in m (default: {d.noise:g})")
    p.add_argument("--seed", type=int, default=d.seed, help=f"seed of the marker noise (default: {d.seed})")
    p.add_argument("--overwrite", action="store_true", help="replace existing CSVs in DIR (default: refuse)")
    p.add_argument("--quiet", action="store_true", help="no progress bar")


def run(args) -> int:
    from ..errors import SoftrnnInputError
    from ..experiments.lab_example import LabExampleConfig, write_lab_example

    names = tuple(s.strip() for s in args.scenarios.split(",") if s.strip())
    if not names:
        raise bad("--scenarios", args.scenarios, "comma-separated tendon scenarios, e.g. tendon-spatial")
    command = (f"softrnn lab-example -o {args.output} --scenarios {','.join(names)} --duration {args.duration:g} "
               f"--rate {args.rate:g} --noise {args.noise:g} --seed {args.seed}")
    try:
        config = LabExampleConfig(scenarios=names, duration=args.duration, rate=args.rate, noise=args.noise,
                                  seed=args.seed)
        with Bar("lab-example", unit="sample", enabled=not args.quiet) as bar:
            paths = write_lab_example(args.output, config, command=command, overwrite=args.overwrite, progress=bar)
    except SoftrnnInputError as err:     # name the command's option
        text = str(err)
        if text.startswith("the run "):     # check_run_size: too large for this machine
            text = str(bad("--duration", args.duration, f"a shorter recording or a lower --rate: {text}"))
        for name, option in _OPTIONS.items():
            if text.startswith(f"{name}="):
                text = option + text[len(name):]
                break
        raise SoftrnnInputError(text.replace("overwrite=True", "--overwrite")
                                ) from None
    for p in paths:
        print(f"wrote {p}: tip marker and tendon tensions, {config.duration:g} s at {config.rate:g} Hz, "
              f"marker noise {config.noise * 1e3:g} mm")
    return 0
