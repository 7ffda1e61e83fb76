"""softrnn control magnetic: close the loop on the simulated magnetic rod (camera at 30 Hz, a
controller setting the coil currents each frame)."""

from __future__ import annotations

import zipfile
from pathlib import Path
from typing import TYPE_CHECKING

from ..errors import bad
from ..files import prepare_output
from ._names import CONTROLLERS, REFERENCES
from ._progress import Bar
from ._vocabulary import output

if TYPE_CHECKING:
    from ..control.loop import LoopConfig

NAME = "control"
HELP = "closed-loop control of the simulated magnetic rod: a controller tracks a reference of the distal magnet"


def add_args(p):
    sub = p.add_subparsers(title="plants", dest="plant", required=True)
    m = sub.add_parser("magnetic", help="the magnetic experiment's perturbed robot, measured by the camera model",
                       description="Run a controller in closed loop on the simulated magnetic robot (the "
                                   "experiment's perturbed dynamic model, the camera with its noise at 30 Hz) and "
                                   "write DIR/run.h5 (the plant's record), DIR/control.png and DIR/control.json "
                                   "(tracking errors, limit violations, the controller's time per frame).")
    m.add_argument("--reference", required=True, metavar="REF",
                   help=f"one of {', '.join(REFERENCES)}, or a CSV of time,about_y_deg,about_x_deg")
    m.add_argument("--controller", required=True, metavar="CTRL", help=f"one of {', '.join(CONTROLLERS)}")
    output(m, dest="out", required=True, metavar="DIR", help="output folder (created)")
    m.add_argument("--duration", type=float, default=60.0, help="seconds of closed loop (default 60)")
    m.add_argument("--seed", type=int, default=0, help="seeds the camera noise and the random reference")
    m.add_argument("--stiffness", type=float, default=1.04, help="the robot's Young's modulus over the nominal "
                                                                 "(default 1.04, the experiment's robot; mpc-learned "
                                                                 "is identified on that robot, so another value tests "
                                                                 "its robustness)")
    m.add_argument("--remanence", type=float, default=0.97, help="the robot's remanence over the nominal "
                                                                 "(default 0.97)")
    m.add_argument("--model", default=None, metavar="FILE.npz",
                   help="mpc-learned: the control model of an earlier run (DIR/control-model.npz); default: identify "
                        "the robot open loop and train it now (about a minute), kept in DIR")
    m.add_argument("--identify-seconds", type=float, default=90.0,
                   help="mpc-learned: seconds of open-loop identification (default 90)")
    m.add_argument("--plan-factors", default=None, metavar="S,R,D",
                   help="the controller's model with stiffness, remanence and damping times these factors (e.g. "
                        "a calibration's: 1.04,0.97,2): what mpc-physics plans on and static-inverse inverts "
                        "(mpc-learned learns the robot instead); default: the nominal model (1,1,1)")
    m.add_argument("--overwrite", action="store_true", help="replace the results in DIR")
    m.add_argument("--quiet", action="store_true", help="no progress bar")


def run(args) -> int:
    from ..control.loop import LoopConfig
    from ..control.references import reference
    from ..control.run import FIGURE_FILE, RUN_FILE, SUMMARY_FILE, control_run, learned_model

    if args.controller not in CONTROLLERS:
        raise bad("--controller", args.controller, f"one of {', '.join(CONTROLLERS)}")
    _check_size(args.duration, LoopConfig(seed=args.seed))
    reference(args.reference, duration=args.duration, seed=args.seed)          # checks REF and --duration now
    for flag, value in (("--stiffness", args.stiffness), ("--remanence", args.remanence)):
        if not 0.2 <= value <= 5.0:
            raise bad(flag, value, "a factor in [0.2, 5] on the nominal value (1.04 and 0.97: the experiment's robot)")
    config = LoopConfig(stiffness=args.stiffness, remanence=args.remanence, seed=args.seed)
    spec = _plan_spec(args.plan_factors)
    prepare_output(args.out, "-o", kind="folder", overwrite=args.overwrite, holds=(RUN_FILE, FIGURE_FILE, SUMMARY_FILE),
                   fix="pass --overwrite to replace them, or choose another folder")
    model = None
    if args.controller == "mpc-learned":
        if args.identify_seconds < 5:
            raise bad("--identify-seconds", args.identify_seconds, "at least 5 s of identification")
        _check_model_file(args.model)
        # identified on the experiment's robot: --stiffness/--remanence perturb the plant after it
        with Bar("identify and train mpc-learned", unit="step", enabled=not args.quiet) as bar:
            model = learned_model(args.out, args.model, identify_seconds=args.identify_seconds,
                                  config=LoopConfig(seed=args.seed), seed=args.seed, progress=bar)
    with Bar(f"control {args.controller}", unit="frame", enabled=not args.quiet) as bar:
        s = control_run(args.reference, args.controller, args.out, duration=args.duration, config=config,
                        model=model, spec=spec, progress=bar)

    def deg(v):
        return "not finite" if v is None else f"{v:.2f}"

    loop = s.loop
    print(f"{s.controller} on {s.reference} ({s.duration_s:g} s): tracking RMS {deg(loop.rms_deg)} deg "
          f"(about y {deg(loop.rms_deg_about['y'])}, about x {deg(loop.rms_deg_about['x'])}), "
          f"max {deg(loop.max_deg)} deg; limit violations {loop.limit_violations}; controller "
          f"{loop.compute_ms_median:.3f} ms per frame (p99 {loop.compute_ms_p99:.3f})")
    print(f"wrote {args.out}/{RUN_FILE}, {FIGURE_FILE}, {SUMMARY_FILE}")
    return 0


def _check_size(duration, config: LoopConfig) -> None:
    """Refuse a ``--duration`` too long for this machine before anything is allocated.

    Parameters
    ----------
    duration : float
        the closed loop's seconds (``--duration``); one that is not a positive finite number is left
        to ``reference`` to refuse
    config : LoopConfig
        the loop's settings: its frame rate and settling time size the plant's run

    Raises
    ------
    SoftrnnInputError
        ``--duration=...`` with the run's size against ``array_limit()`` and ``MAX_SOLVER_STEPS``
        (``check_manipulator_run``, the size model of every simulation) when it is too large.
    """
    import math

    from ..errors import SoftrnnInputError
    from ..magnetics.manipulator import ManipulatorRun, ManipulatorSpec, check_manipulator_run

    if not (isinstance(duration, (int, float)) and math.isfinite(duration) and duration > 0):
        return
    frames = duration * config.rate + 1
    if frames > 2**62:
        raise bad("--duration", duration, f"a shorter closed loop ({frames:.3g} frames at {config.rate:g} Hz)")
    try:
        check_manipulator_run(config.plant_spec(ManipulatorSpec()),
                              ManipulatorRun(dt=1.0 / config.rate, n_samples=int(round(frames)), settle=config.settle))
    except SoftrnnInputError as err:
        raise bad("--duration", duration, f"a shorter closed loop: {err}") from None


def _check_model_file(path) -> None:
    """Refuse a ``--model`` that cannot be a control model (missing, a folder, not an ``.npz`` archive)
    with one line naming it, before numpy reads it (whose message for a foreign file suggests
    ``allow_pickle``)."""
    from ..control.run import MODEL_FILE

    if path is None:
        return
    what = f"a control model file written by softrnn control (DIR/{MODEL_FILE})"
    p = Path(path)
    if not p.exists():
        raise bad("--model", path, f"{what}, but there is no such file")
    if p.is_dir():
        raise bad("--model", path, f"{what}, but it is a folder")
    try:
        archive = zipfile.is_zipfile(p)
    except OSError as err:
        raise bad("--model", path, f"{what}, but it cannot be read ({err.strerror or type(err).__name__})") from None
    if not archive:
        raise bad("--model", path, f"{what}, but it is not one (not an .npz archive)")


def _plan_spec(text):
    """The model mpc-physics plans on, from ``--plan-factors`` S,R,D (None: the nominal one)."""
    from ..magnetics.manipulator import ManipulatorSpec

    if text is None:
        return None
    try:
        factors = [float(v) for v in text.split(",")]
    except ValueError:
        factors = []
    if len(factors) != 3 or not all(0.2 <= f <= 5.0 for f in factors):
        raise bad("--plan-factors", text, "three factors in [0.2, 5] for stiffness, remanence and damping, "
                                          "e.g. 1.04,0.97,2")
    return ManipulatorSpec().scaled(stiffness=factors[0], remanence=factors[1], damping=factors[2])
