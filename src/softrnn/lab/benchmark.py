"""The real-robot benchmark: every model family and every baseline, fitted on the training
sessions only, free running over a validation session from its start on the commands alone.

``run_benchmark`` returns a ``BenchmarkResult``; its ``to_dict()`` is the JSON of
``softrnn lab benchmark`` (docs/guide/real-robots.md): the robot, per model and per baseline the
Euclidean tip RMSE and mean error [mm] and as % of the robot's length, raw and after removing the
constant offset over the session, the coverage of a stated 90 % uncertainty, the best of each and
their ratio, the family chosen on the training sessions' hold-out part, how far the sessions agree
for the physics' form (``session_agreement``, a diagnostic that reads the validation session and
feeds no choice), and the time taken.
``prepare`` does every check on the input before any fit (``run_prepared`` then runs), so that a
suite of robots (``softrnn.lab.suite``) refuses a bad robot before it starts.
"""

from __future__ import annotations

import math
import time
from dataclasses import asdict, dataclass, field

import numpy as np

from ..errors import SoftrnnInputError, bad, integer, positive
from ..learned.metrics import aligned_tip_errors, coverage, tip_errors
from ._pool import WorkerPool
from ._stages import EARLY, LONGEST_FIRST, HeldScore, Ran, collect_families, dynamic_models, run_model, submit_family
from .dynamic_physics import DynamicOptions, DynamicRobot
from .families import (
    HOLDOUT_RULES,
    ConstantVelocityFamily,
    LinearARXFamily,
    NodeOptions,
    PersistenceFamily,
    Physics,
    StaticPolynomial,
    choose,
    displacements,
    finite_or_inf,
    held_rows,
    holdout_split,
    parsimonious,
    shared_refits,
)
from .nets import NetOptions, SequenceOptions, early_candidates
from .physics_variants import choose_physics
from .recording import Recording, check_sessions, estimate_lag, shift_inputs
from .synthetic import SyntheticOptions, pull_limits
from .tendon_robot import LENGTH_UNITS, ROUTING_RANGE, CalibrationOptions, TendonRobot
from .uncertainty import REFIT_FOLDS, with_interval

FAMILIES = ("physics", "learned_map", "hybrid", "sequence", "node_lstm")
"""softrnn's model families, in the order they are fitted."""
TAUGHT = ("learned_map", "hybrid", "sequence", "node_lstm")
"""The families that can learn from the physics' synthetic sessions."""
DYNAMIC_FAMILIES = ("dynamic_physics", "dynamic_hybrid")
"""The families of dynamic recordings driven by tendon tensions, run where ``scenario`` describes the
robot (``softrnn.lab.dynamic_families``)."""
BASELINES = ("persistence", "constant_velocity", "linear_arx", "static_map")
"""The baselines, in report order: the first three the shared ones of ``softrnn.learned.baselines``."""
ARX_ORDERS = ((1, 1), (2, 1), (1, 2), (2, 2))
POLY_CANDIDATES = tuple((d, r) for d in (1, 2, 3) for r in (1e-1, 1e-3, 1e-6))
"""The baselines' candidates, simplest first (the hold-out's choice prefers the simplest, ``parsimonious``)."""
LEAST_LEARNED = ("physics", "dynamic_physics", "hybrid", "dynamic_hybrid", "learned_map", "sequence", "node_lstm")
"""The families from the one that leans least on learned parts to the one that leans most: the order
in which the hold-out's family choice prefers them (``parsimonious``): the physics extrapolates by
construction, a learned part only as far as its data reach."""
MIN_ROWS = 10
"""Fewest rows of every session (after the lag) the benchmark runs on: the baselines, the families and
their hold-out split (a quarter of a sole training session, in stretches of rows) need that many; a 3-row session
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
    routing_radius : float or None
        the tendons' distance from the backbone [m], below ``length``: the calibration's start value (it
        fits 0.2-5 times it, ``tendon_robot.ROUTING_RANGE``), and a pull beyond pi times it per segment
        the tendon runs through is refused (``check_pulls``). None: not known; the calibration starts
        from ``TendonRobot``'s default (4.5 mm, the shared robot's) and a pull is refused only beyond what
        the widest routing it fits allows
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
    synthetic : SyntheticOptions or None
        the physics' synthetic sessions the learned families may pretrain on (``softrnn.lab.synthetic``);
        None: the default options where the physics can be calibrated, none otherwise; given with
        ``amount`` > 0 for sessions the physics cannot take, the benchmark refuses to run
    scenario : str or None
        the robot's dynamic description, a scenario name or TOML file (``dynamic_physics``); None:
        the ``DYNAMIC_FAMILIES`` are skipped
    dynamic : DynamicOptions
        the options of the dynamic physics and its calibration
    workers : int
        worker processes the independent stages run in at once (the physics variants, the learned families;
        1: one after the other in this process; 2, the cores of a 2-core machine); the figures do not depend on
        it. The workers are started afresh (``spawn``): a script needs its ``if __name__ == "__main__":`` guard
    """

    length: float
    lag: object = "auto"
    segments: tuple | None = None
    tendons_per_segment: int = 3
    routing_radius: float | None = None
    families: tuple = FAMILIES
    nets: NetOptions = NetOptions()
    sequence: SequenceOptions = SequenceOptions()
    node: NodeOptions = NodeOptions()
    calibration: CalibrationOptions = CalibrationOptions()
    synthetic: SyntheticOptions | None = None
    scenario: str | None = None
    dynamic: DynamicOptions = DynamicOptions()
    workers: int = field(default=2, repr=False, compare=False)   # not what is computed: the same figures

    def __post_init__(self):
        positive("length", self.length, "m")
        if self.routing_radius is not None:
            self._check_routing()
        integer("workers", self.workers, 1)
        if self.lag != "auto" and (not isinstance(self.lag, int) or isinstance(self.lag, bool) or self.lag < 0):
            raise bad("lag", self.lag, "a whole number of rows >= 0, or 'auto'")
        unknown = [f for f in self.families if f not in FAMILIES + DYNAMIC_FAMILIES]
        if unknown or not self.families:
            raise bad("families", ",".join(self.families), f"one or more of {', '.join(FAMILIES + DYNAMIC_FAMILIES)}")
        if self.synthetic is not None and not isinstance(self.synthetic, SyntheticOptions):
            raise bad("synthetic", self.synthetic, "a SyntheticOptions, or None")

    def _check_routing(self) -> None:
        positive("routing_radius", self.routing_radius, "m")
        if self.routing_radius >= self.length:       # mm read as m: the calibration starts from nonsense
            raise bad("routing_radius", self.routing_radius,
                      f"the tendons' distance from the backbone in m, below the robot's length ({self.length:g} m), "
                      f"e.g. {self.routing_radius * 1e-3:g} for {self.routing_radius:g} mm")


@dataclass(frozen=True)
class TipScore:
    """One model's Euclidean tip errors over the validation session (rounded to 4 digits), raw and
    after removing the constant offset over the session (``softrnn.learned.metrics.aligned_tip_errors``).

    Attributes
    ----------
    tip_rmse_mm, tip_mean_mm, tip_max_mm : float
        RMS, mean and largest error of the tip position [mm]
    tip_rmse_pct_of_length, tip_mean_pct_of_length : float
        the RMS and mean error in % of the robot's length
    tip_rmse_aligned_mm, tip_mean_aligned_mm : float
        the RMS and mean error after removing the constant offset mean_t (p - p_ref) [mm]
    tip_rmse_aligned_pct_of_length, tip_mean_aligned_pct_of_length : float
        the same in % of the robot's length
    coverage_90 : float or None
        the share of rows whose tip lies inside the model's stated 90 % ball (None: the model states
        no uncertainty; left out of the JSON)
    tip_mean_aligned_per_pattern_mm, tip_mean_aligned_per_pattern_pct_of_length : float or None
        the mean error after removing the constant offset over each pattern (each run of rows with
        one label; opencr-mujoco's per-trajectory metric) [mm] and in % of the length (None: the
        session has no labels; left out of the JSON)
    """

    tip_rmse_mm: float
    tip_mean_mm: float
    tip_max_mm: float
    tip_rmse_pct_of_length: float
    tip_mean_pct_of_length: float = float("nan")
    tip_rmse_aligned_mm: float = float("nan")
    tip_mean_aligned_mm: float = float("nan")
    tip_rmse_aligned_pct_of_length: float = float("nan")
    tip_mean_aligned_pct_of_length: float = float("nan")
    coverage_90: float | None = None
    tip_mean_aligned_per_pattern_mm: float | None = None
    tip_mean_aligned_per_pattern_pct_of_length: float | None = None

    @classmethod
    def of(cls, predicted: np.ndarray, reference: np.ndarray, length: float, radius=None, labels=()) -> TipScore:
        """The score of ``predicted`` (T, 3) [m] against ``reference`` (T, 3) [m] for a robot of
        ``length`` [m]; ``radius`` (T,) [m], the stated 90 % ball, gives the coverage; ``labels`` (T,
        str, or empty), the rows' pattern labels, give the per-pattern aligned error."""
        raw, aligned = tip_errors(predicted, reference, length), aligned_tip_errors(predicted, reference, length)
        values = dict(tip_rmse_mm=raw.rmse_mm, tip_mean_mm=raw.mean_mm, tip_max_mm=raw.max_mm,
                      tip_rmse_pct_of_length=raw.pct_of_length(raw.rmse_mm),
                      tip_mean_pct_of_length=raw.pct_of_length(raw.mean_mm),
                      tip_rmse_aligned_mm=aligned.rmse_mm, tip_mean_aligned_mm=aligned.mean_mm,
                      tip_rmse_aligned_pct_of_length=aligned.pct_of_length(aligned.rmse_mm),
                      tip_mean_aligned_pct_of_length=aligned.pct_of_length(aligned.mean_mm))
        if len(labels):
            each = aligned_tip_errors(predicted, reference, length, groups=np.asarray(labels))
            values.update(tip_mean_aligned_per_pattern_mm=each.mean_mm,
                          tip_mean_aligned_per_pattern_pct_of_length=each.pct_of_length(each.mean_mm))
        cover = None if radius is None else round(coverage(predicted, reference, radius), 4)
        return cls(**{k: round(v, 4) for k, v in values.items()}, coverage_90=cover)

    def to_dict(self) -> dict:
        """The JSON of one model or baseline (``coverage_90`` only where the model states an uncertainty); a
        figure that is not finite (a free run that diverged) is null."""
        return {k: v if math.isfinite(v) else None for k, v in asdict(self).items() if v is not None}


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
    validation_tip_rmse_mm : float or None
        the chosen family's tip RMSE over the validation session [mm] (its ``models`` entry)
    """

    family: str
    holdout_rmse_mm: dict
    holdout: str
    validation_tip_rmse_mm: float | None = None


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
    workers : int
        the worker processes it ran in (``BenchmarkOptions.workers``)
    stage_seconds : dict of str to dict
        {stage: {"cpu": CPU time [s], "wall": wall time [s]}} of the stages that ran apart (``WorkerPool``)
    agreement : dict
        ``session_agreement``'s report (empty where the physics did not run)
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
    workers: int = 1
    stage_seconds: dict[str, dict] = field(default_factory=dict)
    agreement: dict = field(default_factory=dict)
    predictions: dict[str, np.ndarray] = field(default_factory=dict, repr=False)
    validation: Recording | None = field(default=None, repr=False)

    @staticmethod
    def _best(table: dict) -> str | None:
        return min(table, key=lambda k: finite_or_inf(table[k].tip_rmse_mm)) if table else None

    def to_dict(self) -> dict:
        """The benchmark's JSON (docs/guide/real-robots.md)."""
        best_model, best_baseline = self._best(self.models), self._best(self.baselines)
        ratio = (self.models[best_model].tip_rmse_mm / self.baselines[best_baseline].tip_rmse_mm
                 if best_model and best_baseline else None)
        out = {"robot": self.robot.to_dict(), "models": {k: v.to_dict() for k, v in self.models.items()},
               "baselines": {k: v.to_dict() for k, v in self.baselines.items()},
               "best_model": best_model, "best_baseline": best_baseline,
               "ratio_best_model_to_best_baseline": ratio,
               "chosen_on_training": {} if self.chosen_on_training is None else asdict(self.chosen_on_training)}
        if self.agreement:
            out["session_agreement"] = self.agreement
        return out | {"skipped": self.skipped, "details": self.details, "seconds": round(self.seconds, 1),
                      "workers": self.workers, "stage_seconds": self.stage_seconds}


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
    ``options.segments``; the routing radius ``TendonRobot``'s default where ``options`` give none); None where
    the inputs do not split into segments."""
    radius = {} if options.routing_radius is None else {"routing_radius": options.routing_radius}
    if options.segments is not None:
        return TendonRobot(options.segments, options.tendons_per_segment, **radius)
    if n_inputs % options.tendons_per_segment:
        return None
    S = n_inputs // options.tendons_per_segment
    return TendonRobot(tuple([options.length / S] * S), options.tendons_per_segment, **radius)


def check_pulls(robot: TendonRobot, sessions, given: bool = True) -> None:
    """Refuse a pull the routing cannot take: more than pi r per segment the tendon runs through
    (a pull beyond bending every segment it spans by half a turn). ``given``: whether r, ``robot``'s
    routing radius, is the robot's own; else (a start value) the widest routing the calibration fits
    (``tendon_robot.ROUTING_RANGE``) sets the limit, so that only a pull no fit could take is refused."""
    widest = 1.0 if given else ROUTING_RANGE[1]
    limit = pull_limits(robot) * widest
    radius = (f"routing radius {robot.routing_radius * 1e3:g} mm" if given else
              f"the widest routing radius the calibration fits, {widest:g} x {robot.routing_radius * 1e3:g} mm")
    for s in sessions:
        q = displacements(s)
        over = q > limit
        if np.any(over):
            k, i = np.argwhere(over)[0]
            raise SoftrnnInputError(
                f"{s.path}: row {k + 1}, input {s.columns[i] if s.columns else s.names[i]!r}: a pull of "
                f"{q[k, i] * 1e3:.4g} mm is beyond what the routing allows (pi x {radius} per segment it "
                f"runs through = {limit[i] * 1e3:.4g} mm); check the units and the column order"
                + ("" if given else ", or give the robot's --routing-radius"))


def check_rows(sessions) -> None:
    """Refuse a session with fewer than ``MIN_ROWS`` rows (after the lag): one line naming its file."""
    for s in sessions:
        if s.n_rows < MIN_ROWS:
            after = f" after the lag of {s.lag} row{'s' if s.lag != 1 else ''}" if s.lag else ""
            raise SoftrnnInputError(f"{s.path}: has {s.n_rows} rows{after}; the benchmark needs at least {MIN_ROWS} "
                                    "rows in every session: give a longer recording")


TIP_REACH = (0.01, 2.5)
"""``check_reach``: the tip's largest distance from its mean position over the sessions, as a share of the
robot's length, below which or above which the positions' unit (or the length) is refused as wrong."""


def check_reach(sessions, length: float) -> None:
    """Refuse sessions whose tip moves farther than a robot of ``length`` [m] reaches, or hardly at all: the
    tip's largest distance from its mean position over every row is at most twice the length (the tip stays
    within the length of its base), ``TIP_REACH``'s upper share with a margin for noise; under its lower
    share (1 %: 2 mm for a 0.2 m robot, over every session) the recording shows no motion to model. Both
    are what positions in m read as mm (or the reverse) look like: one line naming the length and the fix."""
    tips = np.vstack([s.tip for s in sessions])
    tips = tips[np.all(np.isfinite(tips), axis=1)]
    if tips.shape[0] < 2:
        return
    reach = float(np.linalg.norm(tips - tips.mean(axis=0), axis=1).max())
    low, high = TIP_REACH
    if reach > high * length:
        raise bad("length", length, f"the robot's length in m: the tip moves up to {reach:.4g} m from its mean "
                                    "position over the sessions, beyond what a robot of that length reaches "
                                    f"({high:g} x its length); if the positions are in mm, drop --position-unit m")
    if reach < low * length:
        raise bad("length", length, f"the robot's length in m: the tip moves at most {reach * 1e3:.3g} mm from its "
                                    f"mean position over the sessions, under {low:.0%} of that length; if the "
                                    "positions are in m, pass --position-unit m")


def settle_lag(train: list[Recording], options: BenchmarkOptions) -> tuple[int, dict]:
    """The lag in rows (``options.lag``, or estimated on ``train``) and what to report of it."""
    if options.lag != "auto":
        return options.lag, {"lag_rows": options.lag, "estimated": False}
    lag, scores = estimate_lag(train)
    return lag, {"lag_rows": lag, "estimated": True,
                 "linear_fit_rmse_mm_by_lag": {str(k): round(v * 1e3, 3) for k, v in scores.items()}}


def _physics_unavailable(robot, sessions) -> str | None:
    """Why the tendon physics cannot be calibrated on ``sessions`` (None: it can)."""
    return "the inputs do not split into segments of --tendons-per-segment" if robot is None else \
        _physics_reason(sessions, robot.n_tendons)


def settle_synthetic(options: BenchmarkOptions, robot, sessions, families) -> tuple[SyntheticOptions, str | None]:
    """The synthetic data the learned families of ``families`` get and, where none, why: the default
    options where the physics can be calibrated, ``options.synthetic`` where given; refused (one line)
    when given with an amount > 0 for a learned family while the physics cannot be calibrated."""
    reason = _physics_unavailable(robot, sessions)
    if not set(TAUGHT) & set(families):
        return SyntheticOptions(amount=0.0), "no learned family"
    if reason is None:
        syn = SyntheticOptions() if options.synthetic is None else options.synthetic
        return syn, None if syn.on else "synthetic data not asked for (amount 0)"
    if options.synthetic is not None and options.synthetic.on and (set(TAUGHT) - {"hybrid"}) & set(families):
        raise bad("synthetic", options.synthetic.amount, f"synthetic data need the calibrated tendon physics, "
                  f"which these sessions do not allow ({reason}); set the amount to 0")
    return SyntheticOptions(amount=0.0), f"no calibrated physics: {reason}"


def _families(options: BenchmarkOptions, robot, sessions) -> tuple[list, dict]:
    """The families to run and those skipped {name: why}: the physics and the hybrid need tendon
    displacements that match the robot (and so do synthetic data asked for: ``settle_synthetic``)."""
    families, skipped = list(options.families), {}
    reason = _physics_unavailable(robot, sessions)
    syn, _ = settle_synthetic(options, robot, sessions, families)
    if reason:
        for f in ("physics", "hybrid"):
            if f in families:
                families.remove(f)
                skipped[f] = reason
    elif "physics" in families or "hybrid" in families or syn.on:
        check_pulls(robot, sessions, options.routing_radius is not None)
    return families, skipped


class _Table:
    """The validation session's scores, predictions and model descriptions, filled as models are run."""

    def __init__(self, validation: Recording, length: float):
        self.validation, self.length = validation, length
        self.predictions: dict[str, np.ndarray] = {}
        self.details: dict[str, dict] = {}
        self.models: dict[str, TipScore] = {}
        self.baselines: dict[str, TipScore] = {}

    def record(self, table: dict, name: str, model, holdout_scores=None) -> None:
        """Run ``model`` over the validation session and score it into ``table`` (``models`` or
        ``baselines``). A model with ``predict_interval(session) -> (tip (T, 3) [m], radius (T,) [m])``
        (the ball that holds the true tip with 90 % probability) is run by it: its tip is the prediction,
        its radius gives the coverage (``_stages.run_model``)."""
        self.add(table, run_model(name, model, self.validation, holdout_scores))

    def add(self, table: dict, ran: Ran) -> None:
        """Score a model's run over the validation session into ``table`` (``models`` or ``baselines``)."""
        self.predictions[ran.name] = ran.tip
        table[ran.name] = TipScore.of(ran.tip, self.validation.tip, self.length, ran.radius, self.validation.labels)
        self.details[ran.name] = ran.details

    def merge(self, other: _Table) -> None:
        """Add the models and baselines of ``other`` (a table of the same session), after this one's."""
        for name in ("models", "baselines", "predictions", "details"):
            getattr(self, name).update(getattr(other, name))


def baseline_families(train: list[Recording], split: tuple) -> dict:
    """{name: family} of the baselines: persistence, constant velocity, the linear ARX model and the static
    polynomial map, their options chosen on the training sessions' hold-out part (``split``: fitting
    part, held part); with the hold-out scores of those chosen ({name: {candidate: mm}})."""
    out = {"persistence": (PersistenceFamily(), None), "constant_velocity": (ConstantVelocityFamily(), None)}
    c = choose({f"na={a},nb={b}": (lambda a=a, b=b: LinearARXFamily(a, b)) for a, b in ARX_ORDERS}, train, split)
    a, b = (int(x.split("=")[1]) for x in c.chosen.split(","))
    out["linear_arx"] = (LinearARXFamily(a, b), c.scores)
    c = choose({f"degree={d},ridge={r:g}": (lambda d=d, r=r: StaticPolynomial(d, r)) for d, r in POLY_CANDIDATES},
               train, split)
    d, r = (x.split("=")[1] for x in c.chosen.split(","))
    out["static_map"] = (StaticPolynomial(int(d), float(r)), c.scores)
    return out


def baseline_with_interval(family, train: list[Recording], split: tuple, physics: tuple | None = None):
    """The baseline ``family`` fitted on ``train`` with its 90 % interval calibrated on ``split`` (fitting
    part, held part; ``uncertainty.calibrate``), scaled by its refits' spread where it has no error scale
    of its own (``uncertainty.RefitSpread``), and then, with ``physics`` (the calibrated physics fitted on
    the fitting part and on ``train``), by its distance from the physics' tip too (``uncertainty.PhysicsGap``)."""
    return with_interval(family.fit(train), family.fit(split[0]), *split, train, fitted=True, refits=REFIT_FOLDS,
                         physics=physics)


def _baselines(train: list[Recording], split: tuple, out: _Table, physics: tuple | None) -> None:
    """The baselines (``baseline_families``), each with a 90 % interval (``baseline_with_interval``; with the
    calibrated ``physics`` pair, or None)."""
    for name, (family, scores) in baseline_families(train, split).items():
        out.record(out.baselines, name, baseline_with_interval(family, train, split, physics), scores)


AGREEMENT = ("how far the sessions agree for the physics' form: the physics calibrated on the training sessions, "
             "refined on the validation session alone and on every session together, each run over the validation "
             "session (a diagnostic: it reads the validation session and feeds no choice)")
"""What ``session_agreement`` reports, in words (its ``what``)."""


def session_agreement(physics: Physics, train: list[Recording], validation: Recording, length: float) -> dict:
    """How far the training sessions and the validation session agree, for the physics' form:
    ``physics`` (calibrated on ``train``) refined on ``validation`` alone and on ``train`` and
    ``validation`` together (``Physics.refit``), each run over ``validation`` (and the latter over
    ``train``). Three figures then split the calibrated physics' validation error: what its form misses
    on the validation rows alone (``validation_only``), what the parameters that fit every row best
    leave there (``training_and_validation``), and the calibration on the training sessions alone
    (``training_only``, the benchmark's physics). It reads the validation session, so nothing is chosen
    on it.
    Returns the JSON's ``session_agreement``: the tip RMSE and offset-aligned mean [mm, % of the length]
    over the validation session per refit, the training rows' tip RMSE [mm] of both refits."""
    def scores(fitted: Physics) -> dict:
        s = TipScore.of(fitted.predict(validation), validation.tip, length)
        fit = tip_errors(np.vstack([fitted.predict(t) for t in train]), np.vstack([t.tip for t in train]))
        return {"validation_tip_rmse_mm": s.tip_rmse_mm, "validation_tip_mean_aligned_mm": s.tip_mean_aligned_mm,
                "validation_tip_mean_aligned_pct_of_length": s.tip_mean_aligned_pct_of_length,
                "training_tip_rmse_mm": round(fit.rmse_mm, 4)}
    return {"what": AGREEMENT, "variant": physics.options.variant,
            "training_only": scores(physics),
            "validation_only": scores(physics.refit([validation])),
            "training_and_validation": scores(physics.refit(list(train) + [validation]))}


def _models(train: list[Recording], split: tuple, families: list, robot, options: BenchmarkOptions, out: _Table,
            step, pool: WorkerPool) -> tuple[dict, list, object, object, tuple | None]:
    """Fit the physics (its options chosen on the hold-out part, ``split``: fitting part, held part), its
    variants at once in ``pool``'s workers, run it, and hand the learned families to the workers. Returns
    the physics' hold-out score [mm], the families' jobs (``_stages.collect_families`` gathers them), the
    job of ``session_agreement`` (None where the physics does not run), the physics with its interval
    (``uncertainty.with_interval``; None without a physics) and the calibrated physics pair (on the fitting
    part, on every training row; None without one)."""
    fit_part, held = split
    holdout = {}
    physics = held_physics = None
    syn, no_syn = settle_synthetic(options, robot, train, families)
    early = {}

    def meanwhile():    # the candidates that need no physics, queued behind its calibration
        for name in (f for f in EARLY if f in families):
            early[name] = pool.submit(f"{name} early", early_candidates, name, train, syn, options)
    if "physics" in families or "hybrid" in families or syn.on:
        # the variant (gravity, friction) chosen on the hold-out, refitted on every training row from there
        pick = choose_physics(robot, options.calibration, fit_part, held, train, pool=pool, meanwhile=meanwhile)
        held_physics, physics = pick.held, pick.physics
    def submit(name, refits=None):
        return submit_family(pool, name, train, (held_physics, physics), syn, no_syn, options, out.validation,
                             early[name].get() if name in early else None, refits)
    # the hybrid after the physics' interval: its interval refits the physics as that one did (shared_refits)
    jobs = [submit(name) for name in LONGEST_FIRST if name in families and name != "hybrid"]
    agreement = physics_interval = None
    if "physics" in families:
        agreement = pool.submit("physics session agreement", session_agreement, physics, train, out.validation,
                                options.length)
    if physics is not None and {"physics", "hybrid", "sequence"} & set(families):
        # also the interval of the hybrid and of the sequence model over the physics where their gate is off
        physics_interval = with_interval(physics, held_physics, *split, train, fitted=True, refits=REFIT_FOLDS)
    if "physics" in families:
        holdout["physics"] = HeldScore(held)(held_physics)
        out.record(out.models, "physics", physics_interval, pick.holdout_rmse_mm)
        step("physics")
    jobs += [submit("hybrid", shared_refits())] if "hybrid" in families else []
    return holdout, jobs, agreement, physics_interval, None if physics is None else (held_physics, physics)


@dataclass(frozen=True)
class Prepared:
    """Sessions checked and lined up for a benchmark (``prepare``): every check on the input done
    before any fit.

    Attributes
    ----------
    train, validation : tuple of Recording, Recording or None
        the sessions, shifted by the lag (validation None: the training sessions checked alone)
    lag_info : dict
        what to report of the lag (``settle_lag``)
    robot : TendonRobot or None
        the tendon robot of the options (None: the inputs do not split into segments)
    families, skipped : tuple of str, dict of str to str
        the families to run, and those skipped and why
    dynamic : tuple of str
        the dynamic families to run (``DYNAMIC_FAMILIES``)
    dynamic_robot : DynamicRobot or None
        the robot of ``options.scenario`` they run (None: no scenario)
    seconds : float
        the wall time the checks took [s]
    """

    train: tuple
    validation: Recording
    lag_info: dict
    robot: TendonRobot | None
    families: tuple
    skipped: dict
    seconds: float
    dynamic: tuple = ()
    dynamic_robot: DynamicRobot | None = None

    @property
    def stages(self) -> int:
        """The stages ``run_prepared`` reports: the baselines, then each family."""
        return 1 + len(self.families) + len(self.dynamic)


def _dynamic_families(options: BenchmarkOptions, sessions) -> tuple[list, dict, DynamicRobot | None]:
    """The dynamic families to run (those named in ``options.families``, else both where a scenario
    is given), those skipped {name: why} and the robot, its sessions checked (tensions in N, one per
    tendon: a one-line error naming ``scenario`` otherwise)."""
    named = [f for f in options.families if f in DYNAMIC_FAMILIES]
    if options.scenario is None:
        return [], {f: "no --scenario: the dynamic physics needs the robot's description (a scenario with its "
                       "tendons)" for f in (named or DYNAMIC_FAMILIES)}, None
    robot = DynamicRobot.from_scenario(options.scenario, options.dynamic)
    for s in sessions:
        robot.check(s)
    return named or list(DYNAMIC_FAMILIES), {}, robot


def prepare(train: list[Recording], validation: Recording | None, options: BenchmarkOptions) -> Prepared:
    """Check ``train`` and ``validation`` (sessions of one robot) against ``options`` and line them up
    by the lag: one-line ``SoftrnnInputError`` for channels that differ, sessions that share rows, too few
    rows, a lag too long, a pull beyond the routing. ``validation`` None: the training sessions alone (a
    check of them with the benchmark's options, as ``examples/interval_quarters.py`` makes; not to be
    run)."""
    t0 = time.perf_counter()
    check_sessions(list(train) + ([] if validation is None else [validation]))
    lag, lag_info = settle_lag(train, options)
    train = [shift_inputs(s, lag) for s in train]
    validation = None if validation is None else shift_inputs(validation, lag)
    every = train + ([] if validation is None else [validation])
    check_rows(every)
    check_reach(every, options.length)
    robot = robot_for(options, every[0].n_inputs)
    families, skipped = _families(options, robot, every)
    dynamic, dynamic_skipped, dynamic_robot = _dynamic_families(options, every)
    families = [f for f in families if f not in DYNAMIC_FAMILIES]
    skipped.update(dynamic_skipped)
    return Prepared(train=tuple(train), validation=validation, lag_info=lag_info, robot=robot,
                    families=tuple(families), skipped=skipped, seconds=time.perf_counter() - t0,
                    dynamic=tuple(dynamic), dynamic_robot=dynamic_robot)


def run_benchmark(train: list[Recording], validation: Recording, options: BenchmarkOptions,
                  progress=None) -> BenchmarkResult:
    """Fit every baseline and model family on ``train`` (sessions of one robot) and run each free
    over ``validation`` from its start. ``progress(done, total, {"stage": text})`` after each stage."""
    return run_prepared(prepare(train, validation, options), options, progress)


def run_prepared(prepared: Prepared, options: BenchmarkOptions, progress=None) -> BenchmarkResult:
    """``run_benchmark`` on sessions ``prepare`` checked with the same ``options``."""
    t0 = time.perf_counter()
    train, validation, robot, families = list(prepared.train), prepared.validation, prepared.robot, prepared.families
    done = 0

    def step(stage):
        nonlocal done
        done += 1
        if progress is not None:
            progress(done, prepared.stages, {"stage": stage})

    out, dynamic = _Table(validation, options.length), _Table(validation, options.length)
    split = holdout_split(train)
    with WorkerPool(options.workers) as pool:
        holdout, jobs, agreement, physics_interval, pair = _models(train, split, families, robot, options, out,
                                                                   step, pool)
        # the baselines here, while the workers fit the learned families: their scales read the physics
        _baselines(train, split, out, pair)
        step("baselines")
        # the dynamic families here, while the workers fit the learned ones
        dynamic_holdout = dynamic_models(train, list(prepared.dynamic), prepared.dynamic_robot, dynamic, step)
        holdout.update(collect_families(jobs, pool, out, step, physics_interval))
        agreement = {} if agreement is None else agreement.get()
    holdout.update(dynamic_holdout)
    out.merge(dynamic)
    chosen = None
    if holdout:
        ordered = {f: holdout[f] for f in sorted(holdout, key=LEAST_LEARNED.index)}
        family = parsimonious(ordered, held_rows(split[1]))
        chosen = Choice(family=family, holdout_rmse_mm=holdout,
                        holdout=HOLDOUT_RULES[len(train) >= 2],
                        validation_tip_rmse_mm=out.models[family].tip_rmse_mm)
    robot_info = RobotInfo(length_m=options.length, lag=prepared.lag_info,
                           training_sessions=tuple(s.describe() for s in train),
                           validation_session=validation.describe(),
                           segments_m=None if robot is None else tuple(robot.segment_lengths),
                           tendons_per_segment=None if robot is None else robot.tendons_per_segment)
    return BenchmarkResult(robot=robot_info, models=out.models, baselines=out.baselines,
                           chosen_on_training=chosen, details=out.details, skipped=prepared.skipped,
                           seconds=prepared.seconds + time.perf_counter() - t0, workers=pool.workers,
                           stage_seconds=pool.seconds(), agreement=agreement,
                           predictions=out.predictions, validation=validation)
