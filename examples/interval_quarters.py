"""The 90 % intervals of the physics and the baselines checked on a training session alone.

The session's patterns are cut into four quarters (``softrnn.lab.uncertainty.pattern_folds``: whole
patterns recorded beside each other). Each quarter in turn is a validation session: the other three
are the training sessions, split into a fitting part and a held part as ``softrnn lab benchmark`` splits
them; the calibrated physics (plain, or with ``--creep`` the tendons' creep, run through the held rows as
the benchmark runs it) and the four baselines are fitted there with their intervals
calibrated, and the share of the quarter's rows inside each model's 90 % ball is counted, once with
the benchmark's scale from refits (``uncertainty.RefitSpread``; for the baselines with their distance
from the physics' tip, ``uncertainty.PhysicsGap``) and once with none (scale 1). With
``--sequence``, the sequence model too (pretrained on the physics' synthetic sessions), once with its
scale from the physics (``nets.Sequence.error_scale``) and once with none; with ``--node``, the node LSTM
(mode ``mixed``, taught by the physics' synthetic sessions) the same way (``families.NodeFamily``), with
``--node-over-physics`` the node LSTM that learns what the physics leaves (``on_physics``, the narrowest
gate of ``nets.GATES``); with ``--learned-map``, the learned map (mode ``real``) with its scale, with and
without its distance from the physics' tip (``nets.LearnedMap.error_scale``), and with none. No row of
another session is read, so the rule can be judged without a validation session.

    python examples/interval_quarters.py data/opencr-tdcr-v6/train.csv --length 0.222 \\
        --segments 0.1,0.1,0.022 --json out/interval-quarters.json

Prints one line per quarter and model, and writes the coverages (shares of rows) to ``--json``.
About 4 minutes on 2 cores for the shared robot (the physics' multi-start search, once per quarter);
with ``--sequence`` about 25 (four trainings of the GRU per quarter), with ``--node`` or
``--node-over-physics`` about 5 more each, with ``--learned-map`` about 4 more.
"""

import argparse
import json
from dataclasses import dataclass, replace
from pathlib import Path

import numpy as np

from softrnn.errors import SoftrnnInputError
from softrnn.lab.benchmark import BenchmarkOptions, baseline_families, prepare
from softrnn.lab.families import NodeFamily, Physics, holdout_split, masked
from softrnn.lab.nets import GATES, LearnedMap, Sequence, seeded
from softrnn.lab.recording import read_recording
from softrnn.lab.synthetic import SyntheticOptions
from softrnn.lab.uncertainty import (
    REFIT_FOLDS,
    InputDistance,
    Intervals,
    WithInterval,
    calibrate,
    pattern_folds,
    refitter,
    with_interval,
)
from softrnn.learned.threads import one_blas_thread


def coverage(model, sessions) -> float:
    """The share of the rows of ``sessions`` whose tip lies inside the model's 90 % ball."""
    inside = [np.linalg.norm(tip - s.tip, axis=1) <= radius
              for s in sessions for tip, radius in [model.predict_interval(s)]]
    return float(np.mean(np.concatenate(inside)))


@dataclass(frozen=True, eq=False)
class Scaled(Intervals):
    """A fitted ``model`` (``predict``, ``reach``, ``refit``, ``error_scale``) with its own error scale
    (``own``) or the scale 1, not calibrated until ``interval_q``, ``interval_slope`` and ``interval_knee``
    are given; its refits are kept in ``refits`` (by rows), so the two scales share the cross-fit's
    trainings."""

    model: object
    own: bool
    refits: dict
    interval_q: float | None = None
    interval_slope: float | None = None
    interval_knee: float = 0.0

    @property
    def name(self):
        return self.model.name

    @property
    def reach(self):
        return self.model.reach

    def predict(self, session):
        return self.model.predict(session)

    def error_scale(self, session):
        if self.own == "no physics":          # the learned map's own scale without its distance from the physics
            return replace(self.model, physics=None).error_scale(session)
        return self.model.error_scale(session) if self.own else np.ones(session.n_rows)

    def refit(self, sessions):
        key = tuple((s.n_rows, float(s.time[0]), float(s.time[-1])) for s in sessions)
        if key not in self.refits:
            self.refits[key] = refitter(self.model)(sessions)
        return Scaled(self.refits[key], self.own, self.refits)


def learned(name, options, split, train, physics) -> tuple:
    """The sequence model (mode ``finetune``) or the node LSTM (mode ``mixed``, or over the physics with the
    narrowest gate; with its distance from its rows: ``uncertainty.WithInterval``), fitted on ``train``
    and on the fitting part ``split[0]``, each with the physics fitted on the same rows (``physics``:
    (held, final)): (final, held)."""
    if name == "sequence":
        make = [Sequence(options.sequence, "finetune", SyntheticOptions(), p) for p in physics]
        return make[1].fit(train), make[0].fit(split[0])
    if name == "learned_map":
        make = [LearnedMap(options=options.nets, physics=p) for p in physics]
        with seeded("learned_map"):
            return make[1].fit(train), make[0].fit(split[0])
    if name == "node_lstm_over_physics":
        make = [NodeFamily(options.length, options.node, physics=p, on_physics=True, gate=GATES[0]) for p in physics]
    else:
        make = [NodeFamily(options.length, options.node, mode="mixed", synthetic=SyntheticOptions(), physics=p)
                for p in physics]
    return (WithInterval(make[1].fit(train), InputDistance.of(train)),
            WithInterval(make[0].fit(split[0]), InputDistance.of(split[0])))


def quarter(robot, options, train, block, with_sequence, with_node=False, with_node_over=False,
            with_map=False) -> dict:
    """{model: {"refits" or "physics": share, "none": share}} of the rows of ``block`` inside each
    model's ball."""
    split = holdout_split(train)
    plain = Physics(robot, replace(options.calibration, creep=False)).fit(split[0])
    held_physics = plain if not options.calibration.creep else replace(
        plain, options=options.calibration, start=plain.calibration.params, calibration=None).fit(
        masked(train, split[1]))
    fitted = {"physics": (held_physics.refit(train), held_physics)}
    for name, (family, _) in baseline_families(train, split).items():
        fitted[name] = (family.fit(train), family.fit(split[0]))
    # the baselines' refits' scale also holds their distance from the physics' tip, as in the benchmark
    pair = (held_physics, fitted["physics"][0])
    out = {name: {label: round(coverage(with_interval(model, held, *split, train, fitted=True, refits=k,
                                                      physics=None if name == "physics" else pair), block), 4)
                  for label, k in (("refits", REFIT_FOLDS), ("none", 0))}
           for name, (model, held) in fitted.items()}
    asked = (("sequence", with_sequence), ("node_lstm", with_node), ("node_lstm_over_physics", with_node_over),
             ("learned_map", with_map))
    for name in [n for n, wanted in asked if wanted]:
        final, held = learned(name, options, split, train, (held_physics, fitted["physics"][0]))
        refits = {}
        scales = (("physics", True), ("none", False))
        if name == "learned_map":           # its spread with and without its distance from the physics
            scales = (("physics", True), ("no physics", "no physics"), ("none", False))
        out[name] = {label: round(coverage(replace(Scaled(final, own, {}), **calibrate(
            Scaled(held, own, refits), *split)), block), 4) for label, own in scales}
    return out


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("session", help="a training session's CSV with pattern labels")
    parser.add_argument("--length", type=float, required=True, help="the robot's length [m]")
    parser.add_argument("--segments", required=True, help="the segments' lengths [m], comma-separated")
    parser.add_argument("--json", type=Path, help="where to write the coverages")
    parser.add_argument("--sequence", action="store_true", help="also the sequence model (about 25 minutes)")
    parser.add_argument("--node", action="store_true", help="also the node LSTM (about 5 minutes)")
    parser.add_argument("--node-over-physics", action="store_true",
                        help="also the node LSTM over the physics (about 5 minutes)")
    parser.add_argument("--learned-map", action="store_true",
                        help="also the learned map (mode real), its scale with and without its distance from the "
                             "physics (about 4 minutes)")
    parser.add_argument("--creep", action="store_true", help="the physics with the tendons' creep")
    args = parser.parse_args()
    options = BenchmarkOptions(length=args.length, segments=tuple(float(x) for x in args.segments.split(",")))
    options = replace(options, calibration=replace(options.calibration, creep=args.creep))
    try:
        session = read_recording(args.session)
        prepared = prepare([session], None, options)
    except SoftrnnInputError as err:
        parser.exit(2, f"interval_quarters.py: {err}\n")
    if not session.labels:
        parser.exit(2, f"interval_quarters.py: session {args.session} has no pattern labels; give a session "
                       "with a pattern_label column\n")
    out = {}
    with one_blas_thread():
        for j, (train, block) in enumerate(pattern_folds(list(prepared.train), 4)):
            out[f"quarter {j}"] = quarter(prepared.robot, options, train, block, args.sequence, args.node,
                                          args.node_over_physics, args.learned_map)
            for name, share in out[f"quarter {j}"].items():
                print(f"quarter {j}  {name:18s} " + "  ".join(f"{k} {v:6.1%}" for k, v in share.items()), flush=True)
    learned_names = ("sequence", "node_lstm", "node_lstm_over_physics", "learned_map")
    groups = {"physics and baselines": [n for n in out["quarter 0"] if n not in learned_names]}
    for name, wanted in zip(learned_names, (args.sequence, args.node, args.node_over_physics, args.learned_map)):
        if wanted:
            groups[name] = [name]
    for group, names in groups.items():
        for label in out["quarter 0"][names[0]]:
            shares = [q[n][label] for q in out.values() for n in names]
            inside = sum(0.8 <= s <= 0.95 for s in shares)
            print(f"{group}, {label}: {inside} of {len(shares)} inside 80-95 %, mean distance from 90 %: "
                  f"{100 * np.mean(np.abs(np.array(shares) - 0.9)):.1f} points")
    if args.json:
        args.json.parent.mkdir(parents=True, exist_ok=True)
        tmp = args.json.with_suffix(".tmp")
        tmp.write_text(json.dumps(out, indent=2))
        tmp.replace(args.json)


if __name__ == "__main__":
    main()
