"""The real-robot benchmark: every model family and every baseline, fitted on the training
sessions only, free running over a validation session from its start on the commands alone.

``run_benchmark`` returns a ``BenchmarkResult``; its ``to_dict()`` is the JSON of
``softrnn lab benchmark`` (docs/guide/real-robots.md): the robot, per model and per baseline the
Euclidean tip RMSE and mean error [mm] and the RMSE as % of the robot's length, the best of each
and their ratio, the family chosen on the training sessions' hold-out part, and the time taken.
"""

from __future__ import annotations

import time
from dataclasses import asdict, dataclass, field

import numpy as np

from ..errors import SoftrnnInputError, bad, positive
from ..learned.metrics import tip_errors
from .families import (
    ConstantVelocityFamily,
    Hybrid,
    LearnedMap,
    LinearARXFamily,
    NetOptions,
    NodeFamily,
    NodeOptions,
    PersistenceFamily,
    Sequence,
    SequenceOptions,
    StaticPolynomial,
    choose,
    displacements,
    holdout_split,
)
from .physics_variants import choose_physics
from .recording import Recording, check_sessions, estimate_lag, shift_inputs
from .tendon_robot import LENGTH_UNITS, CalibrationOptions, TendonRobot

FAMILIES = ("physics", "learned_map", "hybrid", "sequence", "node_lstm")
"""softrnn's model families, in the order they are fitted."""
BASELINES = ("persistence", "constant_velocity", "linear_arx", "static_map")
"""The baselines, in report order: the first three the shared ones of ``softrnn.learned.baselines``."""
ARX_ORDERS = ((1, 1), (2, 1), (1, 2), (2, 2))
POLY_CANDIDATES = tuple((d, r) for d in (1, 2, 3) for r in (1e-6, 1e-3, 1e-1))
MIN_ROWS = 10
"""Fewest rows of every session (after the lag) the benchmark runs on: the baselines, the families and
their hold-out split (the last quarter of a sole training session) need that many; a 3-row session
would end in a least-squares error, a few more in fits on empty windows."""


@dataclass(frozen=True)
class BenchmarkOptions:
    """What the benchmark runs.

    Parameters
    ----------
    length : float
        the robot's length [m] (for errors as % of length; and the segments' default)
    lag : int or "auto"
        rows the response lags the command (``auto``: estimated on the training sessions,
        ``recording.estimate_lag``)
    segments : tuple or None
        segment lengths [m] for the physics (default: the inputs split into segments of
        ``tendons_per_segment``, of equal length)
    tendons_per_segment : int
        tendons of each segment
    routing_radius : float
        the tendons' start distance from the backbone [m]
    families : tuple
        which of ``FAMILIES`` to run
    nets : NetOptions
        the options of the learned maps' networks (``learned_map``, ``hybrid``)
    sequence : SequenceOptions
        the options of the ``sequence`` model
    node : NodeOptions
        the options of the ``node_lstm`` model
    calibration : CalibrationOptions
        the options of the physics' calibration
    """

    length: float
    lag: object = "auto"
    segments: tuple | None = None
    tendons_per_segment: int = 3
    routing_radius: float = 4.5e-3
    families: tuple = FAMILIES
    nets: NetOptions = NetOptions()
    sequence: SequenceOptions = SequenceOptions()
    node: NodeOptions = NodeOptions()
    calibration: CalibrationOptions = CalibrationOptions()

    def __post_init__(self):
        positive("length", self.length, "m")
        if self.lag != "auto" and (not isinstance(self.lag, int) or isinstance(self.lag, bool) or self.lag < 0):
            raise bad("lag", self.lag, "a whole number of rows >= 0, or 'auto'")
        unknown = [f for f in self.families if f not in FAMILIES]
        if unknown or not self.families:
            raise bad("families", ",".join(self.families), f"one or more of {', '.join(FAMILIES)}")


@dataclass(frozen=True)
class TipScore:
    """One model's Euclidean tip errors over the validation session (rounded to 4 digits).

    Attributes
    ----------
    tip_rmse_mm, tip_mean_mm, tip_max_mm : float
        RMS, mean and largest error of the tip position [mm]
    tip_rmse_pct_of_length : float
        the RMS error in % of the robot's length
    """

    tip_rmse_mm: float
    tip_mean_mm: float
    tip_max_mm: float
    tip_rmse_pct_of_length: float


@dataclass(frozen=True, kw_only=True)
class RobotInfo:
    """The robot and sessions a benchmark ran on.

    Attributes
    ----------
    length_m : float
        the robot's length [m]
    segments_m, tendons_per_segment : tuple of float or None, int or None
        the physics' segment lengths [m] and tendons per segment (None: no robot)
    lag : dict
        ``lag_rows``, ``estimated`` and, estimated, ``linear_fit_rmse_mm_by_lag`` (``settle_lag``)
    training_sessions, validation_session : tuple of dict, dict
        the sessions' ``Recording.describe()``
    """

    length_m: float
    segments_m: tuple | None = None
    tendons_per_segment: int | None = None
    lag: dict
    training_sessions: tuple
    validation_session: dict

    def to_dict(self) -> dict:
        """The JSON's ``robot``."""
        out = {"length_m": self.length_m, **self.lag, "training_sessions": list(self.training_sessions),
               "validation_session": self.validation_session}
        if self.segments_m is not None:
            out.update(segments_m=list(self.segments_m), tendons_per_segment=self.tendons_per_segment)
        return out


@dataclass(frozen=True)
class Choice:
    """The family the training sessions' hold-out part prefers.

    Attributes
    ----------
    family : str
        the family with the lowest hold-out error
    holdout_rmse_mm : dict
        {family: tip RMSE [mm] on the hold-out part}
    holdout : str
        what the hold-out part was
    """

    family: str
    holdout_rmse_mm: dict
    holdout: str


@dataclass(frozen=True)
class BenchmarkResult:
    """What ``run_benchmark`` found (``to_dict()`` for the JSON).

    Attributes
    ----------
    robot : RobotInfo
        the robot and sessions
    models, baselines : dict of str to TipScore
        each model family's and baseline's errors over the validation session
    chosen_on_training : Choice or None
        the family the hold-out part prefers (None: no family was run)
    details, skipped : dict of str to dict, dict of str to str
        each model's ``describe()`` (with its hold-out scores); the families skipped and why
    seconds : float
        the wall time [s]
    predictions : dict of str to ndarray
        each model's and baseline's predicted tip path (T, 3) [m]
    validation : Recording or None
        the validation session, shifted by the lag
    """

    robot: RobotInfo
    models: dict[str, TipScore]
    baselines: dict[str, TipScore]
    chosen_on_training: Choice | None
    details: dict[str, dict]
    skipped: dict[str, str]
    seconds: float
    predictions: dict[str, np.ndarray] = field(default_factory=dict, repr=False)
    validation: Recording | None = field(default=None, repr=False)

    @staticmethod
    def _best(table: dict) -> str | None:
        return min(table, key=lambda k: table[k].tip_rmse_mm) if table else None

    def to_dict(self) -> dict:
        """The benchmark's JSON (docs/guide/real-robots.md)."""
        best_model, best_baseline = self._best(self.models), self._best(self.baselines)
        ratio = (self.models[best_model].tip_rmse_mm / self.baselines[best_baseline].tip_rmse_mm
                 if best_model and best_baseline else None)
        return {"robot": self.robot.to_dict(), "models": {k: asdict(v) for k, v in self.models.items()},
                "baselines": {k: asdict(v) for k, v in self.baselines.items()},
                "best_model": best_model, "best_baseline": best_baseline,
                "ratio_best_model_to_best_baseline": ratio,
                "chosen_on_training": {} if self.chosen_on_training is None else asdict(self.chosen_on_training),
                "skipped": self.skipped, "details": self.details, "seconds": round(self.seconds, 1)}


def _physics_reason(sessions, robot_inputs: int) -> str | None:
    s = sessions[0]
    if any(u not in LENGTH_UNITS for u in s.units):
        return (f"the inputs' units ({', '.join(sorted(set(s.units)) or ['none'])}) are not tendon displacements "
                "in m or mm")
    if s.n_inputs != robot_inputs:
        return (f"{s.n_inputs} inputs do not match the robot's {robot_inputs} tendons "
                "(--segments, --tendons-per-segment)")
    return None


def robot_for(options: BenchmarkOptions, n_inputs: int) -> TendonRobot | None:
    """The tendon robot of ``options`` for ``n_inputs`` tendon inputs (equal segments unless
    ``options.segments``); None where the inputs do not split into segments."""
    if options.segments is not None:
        return TendonRobot(options.segments, options.tendons_per_segment, options.routing_radius)
    if n_inputs % options.tendons_per_segment:
        return None
    S = n_inputs // options.tendons_per_segment
    return TendonRobot(tuple([options.length / S] * S), options.tendons_per_segment, options.routing_radius)


def check_pulls(robot: TendonRobot, sessions) -> None:
    """Refuse a pull the routing cannot take: more than pi r per segment the tendon runs through
    (a pull beyond bending every segment it spans by half a turn)."""
    for s in sessions:
        q = displacements(s)
        limit = np.pi * robot.routing_radius * (robot.segment_of + 1)
        over = q > limit
        if np.any(over):
            k, i = np.argwhere(over)[0]
            raise SoftrnnInputError(
                f"{s.path}: row {k + 1}, input {s.columns[i] if s.columns else s.names[i]!r}: a pull of "
                f"{q[k, i] * 1e3:.4g} mm is beyond what the routing allows (pi x routing radius "
                f"{robot.routing_radius * 1e3:g} mm per segment it runs through = {limit[i] * 1e3:.4g} mm); "
                "check the units and the column order, or give the robot's --routing-radius")


def check_rows(sessions) -> None:
    """Refuse a session with fewer than ``MIN_ROWS`` rows (after the lag): one line naming its file."""
    for s in sessions:
        if s.n_rows < MIN_ROWS:
            after = f" after the lag of {s.lag} row{'s' if s.lag != 1 else ''}" if s.lag else ""
            raise SoftrnnInputError(f"{s.path}: has {s.n_rows} rows{after}; the benchmark needs at least {MIN_ROWS} "
                                    "rows in every session: give a longer recording")


def settle_lag(train: list[Recording], options: BenchmarkOptions) -> tuple[int, dict]:
    """The lag in rows (``options.lag``, or estimated on ``train``) and what to report of it."""
    if options.lag != "auto":
        return options.lag, {"lag_rows": options.lag, "estimated": False}
    lag, scores = estimate_lag(train)
    return lag, {"lag_rows": lag, "estimated": True,
                 "linear_fit_rmse_mm_by_lag": {str(k): round(v * 1e3, 3) for k, v in scores.items()}}


def _families(options: BenchmarkOptions, robot, sessions) -> tuple[list, dict]:
    """The families to run and those skipped {name: why}: the physics and the hybrid need tendon
    displacements that match the robot."""
    families, skipped = list(options.families), {}
    reason = "the inputs do not split into segments of --tendons-per-segment" if robot is None else \
        _physics_reason(sessions, robot.n_tendons)
    if reason:
        for f in ("physics", "hybrid"):
            if f in families:
                families.remove(f)
                skipped[f] = reason
    elif "physics" in families or "hybrid" in families:
        check_pulls(robot, sessions)
    return families, skipped


class _Table:
    """The validation session's errors, predictions and model descriptions, filled as models are run."""

    def __init__(self, validation: Recording, length: float):
        self.validation, self.length = validation, length
        self.predictions, self.details, self.models, self.baselines = {}, {}, {}, {}

    def record(self, table: dict, name: str, model, holdout_scores=None) -> None:
        pred = model.predict(self.validation)
        self.predictions[name] = pred
        err = tip_errors(pred, self.validation.tip).tip_summary()
        err["tip_rmse_pct_of_length"] = err["tip_rmse_mm"] / (self.length * 1e3) * 100.0
        table[name] = {k: round(v, 4) for k, v in err.items()}
        self.details[name] = model.describe()
        if holdout_scores is not None:
            self.details[name]["holdout_rmse_mm"] = holdout_scores


def _baselines(train: list[Recording], out: _Table) -> None:
    """Persistence, constant velocity, the linear ARX model and the static polynomial map, their options
    chosen on the training sessions' hold-out part."""
    out.record(out.baselines, "persistence", PersistenceFamily().fit(train))
    out.record(out.baselines, "constant_velocity", ConstantVelocityFamily().fit(train))
    c = choose({f"na={a},nb={b}": (lambda a=a, b=b: LinearARXFamily(a, b)) for a, b in ARX_ORDERS}, train)
    a, b = (int(x.split("=")[1]) for x in c.chosen.split(","))
    out.record(out.baselines, "linear_arx", LinearARXFamily(a, b).fit(train), c.scores)
    c = choose({f"degree={d},ridge={r:g}": (lambda d=d, r=r: StaticPolynomial(d, r)) for d, r in POLY_CANDIDATES},
               train)
    d, r = (x.split("=")[1] for x in c.chosen.split(","))
    out.record(out.baselines, "static_map", StaticPolynomial(int(d), float(r)).fit(train), c.scores)


def _models(train: list[Recording], families: list, robot, options: BenchmarkOptions, out: _Table, step) -> dict:
    """Fit each family (its options chosen on the hold-out part) and run it; returns each family's
    hold-out score [mm]."""
    fit_part, held = holdout_split(train)
    held_ref = np.vstack([s.tip for s in held])

    def held_score(model):
        return round(tip_errors(np.vstack([model.predict(s) for s in held]), held_ref).rmse_mm, 4)

    holdout = {}
    physics = held_physics = None
    if "physics" in families or "hybrid" in families:
        # the variant (gravity, friction) chosen on the hold-out, refitted on every training row from there
        pick = choose_physics(robot, options.calibration, fit_part, held, train)
        held_physics, physics = pick.held, pick.physics
    if "physics" in families:
        holdout["physics"] = held_score(held_physics)
        out.record(out.models, "physics", physics, pick.holdout_rmse_mm)
        step("physics")
    if "learned_map" in families:
        c = choose({f"hysteresis={h}": (lambda h=h: LearnedMap(h, options.nets)) for h in (False, True)}, train)
        holdout["learned_map"] = c.scores[c.chosen]
        out.record(out.models, "learned_map", LearnedMap(c.chosen.endswith("True"), options.nets).fit(train),
                   c.scores)
        step("learned_map")
    if "hybrid" in families:
        scores = {f"hysteresis={h}": held_score(Hybrid(held_physics, h, options.nets).fit(fit_part))
                  for h in (False, True)}
        best = min(scores, key=scores.get)
        holdout["hybrid"] = scores[best]
        out.record(out.models, "hybrid", Hybrid(physics, best.endswith("True"), options.nets).fit(train), scores)
        step("hybrid")
    if "sequence" in families:
        holdout["sequence"] = held_score(Sequence(options.sequence).fit(fit_part))
        out.record(out.models, "sequence", Sequence(options.sequence).fit(train))
        step("sequence")
    if "node_lstm" in families:
        holdout["node_lstm"] = held_score(NodeFamily(options.length, options.node).fit(fit_part))
        out.record(out.models, "node_lstm", NodeFamily(options.length, options.node).fit(train))
        step("node_lstm")
    return holdout


def _scores(table: dict) -> dict[str, TipScore]:
    """{name: TipScore} of a ``_Table`` entry {name: {tip_rmse_mm, ...}}."""
    return {name: TipScore(**errors) for name, errors in table.items()}


def run_benchmark(train: list[Recording], validation: Recording, options: BenchmarkOptions,
                  progress=None) -> BenchmarkResult:
    """Fit every baseline and model family on ``train`` (sessions of one robot) and run each free
    over ``validation`` from its start. ``progress(done, total, {"stage": text})`` after each stage."""
    t0 = time.perf_counter()
    check_sessions(list(train) + [validation])
    lag, lag_info = settle_lag(train, options)
    train = [shift_inputs(s, lag) for s in train]
    validation = shift_inputs(validation, lag)
    check_rows(train + [validation])
    robot = robot_for(options, validation.n_inputs)
    families, skipped = _families(options, robot, train + [validation])
    stages = ["baselines"] + families
    done = 0

    def step(stage):
        nonlocal done
        done += 1
        if progress is not None:
            progress(done, len(stages), {"stage": stage})

    out = _Table(validation, options.length)
    _baselines(train, out)
    step("baselines")
    holdout = _models(train, families, robot, options, out, step)
    chosen = Choice(family=min(holdout, key=holdout.get), holdout_rmse_mm=holdout,
                    holdout="the last training session" if len(train) >= 2 else
                            "the last quarter of the training session") if holdout else None
    robot_info = RobotInfo(length_m=options.length, lag=lag_info, training_sessions=tuple(s.describe() for s in train),
                           validation_session=validation.describe(),
                           segments_m=None if robot is None else tuple(robot.segment_lengths),
                           tendons_per_segment=None if robot is None else robot.tendons_per_segment)
    return BenchmarkResult(robot=robot_info, models=_scores(out.models), baselines=_scores(out.baselines),
                           chosen_on_training=chosen, details=out.details, skipped=skipped,
                           seconds=time.perf_counter() - t0,
                           predictions=out.predictions, validation=validation)
