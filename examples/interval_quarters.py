"""The 90 % intervals of the physics and the baselines checked on a training session alone.

The session's patterns are cut into four quarters (``softrnn.lab.uncertainty.pattern_folds``: whole
patterns recorded beside each other). Each quarter in turn is a validation session: the other three
are the training sessions, split into a fitting part and a held part as ``softrnn lab benchmark`` splits
them; the calibrated physics (plain) and the four baselines are fitted there with their intervals
calibrated, and the share of the quarter's rows inside each model's 90 % ball is counted, once with
the benchmark's scale from refits (``uncertainty.RefitSpread``) and once with none (scale 1). No row of
another session is read, so the rule can be judged without a validation session.

    python examples/interval_quarters.py data/opencr-tdcr-v6/train.csv --length 0.222 \\
        --segments 0.1,0.1,0.022 --json out/interval-quarters.json

Prints one line per quarter and model, and writes the coverages (shares of rows) to ``--json``.
About 4 minutes on 2 cores for the shared robot (the physics' multi-start search, once per quarter).
"""

import argparse
import json
from pathlib import Path

import numpy as np

from softrnn.errors import SoftrnnInputError
from softrnn.lab.benchmark import BenchmarkOptions, baseline_families, prepare
from softrnn.lab.families import Physics, holdout_split
from softrnn.lab.recording import read_recording
from softrnn.lab.uncertainty import REFIT_FOLDS, pattern_folds, with_interval
from softrnn.learned.threads import one_blas_thread


def coverage(model, sessions) -> float:
    """The share of the rows of ``sessions`` whose tip lies inside the model's 90 % ball."""
    inside = [np.linalg.norm(tip - s.tip, axis=1) <= radius
              for s in sessions for tip, radius in [model.predict_interval(s)]]
    return float(np.mean(np.concatenate(inside)))


def quarter(robot, options, train, block) -> dict:
    """{model: {"refits": share, "none": share}} of the rows of ``block`` inside each model's ball."""
    split = holdout_split(train)
    held_physics = Physics(robot, options.calibration).fit(split[0])
    fitted = {"physics": (held_physics.refit(train), held_physics)}
    for name, (family, _) in baseline_families(train, split).items():
        fitted[name] = (family.fit(train), family.fit(split[0]))
    return {name: {label: round(coverage(with_interval(model, held, *split, train, fitted=True, refits=k), block), 4)
                   for label, k in (("refits", REFIT_FOLDS), ("none", 0))}
            for name, (model, held) in fitted.items()}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("session", help="a training session's CSV with pattern labels")
    parser.add_argument("--length", type=float, required=True, help="the robot's length [m]")
    parser.add_argument("--segments", required=True, help="the segments' lengths [m], comma-separated")
    parser.add_argument("--json", type=Path, help="where to write the coverages")
    args = parser.parse_args()
    options = BenchmarkOptions(length=args.length, segments=tuple(float(x) for x in args.segments.split(",")))
    try:
        session = read_recording(args.session)
        prepared = prepare([session], session, options)
    except SoftrnnInputError as err:
        parser.exit(2, f"interval_quarters.py: {err}\n")
    if not session.labels:
        parser.exit(2, f"interval_quarters.py: session {args.session} has no pattern labels; give a session "
                       "with a pattern_label column\n")
    out = {}
    with one_blas_thread():
        for j, (train, block) in enumerate(pattern_folds(list(prepared.train), 4)):
            out[f"quarter {j}"] = quarter(prepared.robot, options, train, block)
            for name, share in out[f"quarter {j}"].items():
                print(f"quarter {j}  {name:18s} refits {share['refits']:6.1%}  none {share['none']:6.1%}", flush=True)
    for label in ("refits", "none"):
        shares = [s[label] for q in out.values() for s in q.values()]
        inside = sum(0.8 <= s <= 0.95 for s in shares)
        print(f"{label}: {inside} of {len(shares)} inside 80-95 %, mean distance from 90 %: "
              f"{100 * np.mean(np.abs(np.array(shares) - 0.9)):.1f} points")
    if args.json:
        args.json.parent.mkdir(parents=True, exist_ok=True)
        tmp = args.json.with_suffix(".tmp")
        tmp.write_text(json.dumps(out, indent=2))
        tmp.replace(args.json)


if __name__ == "__main__":
    main()
