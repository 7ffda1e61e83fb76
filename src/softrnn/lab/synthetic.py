"""Synthetic sessions from a calibrated physics: the simulator teaches the learned models where the
recordings do not reach.

``synthetic_sessions`` drives a fitted ``Physics`` (``softrnn.lab.families``) over the whole command
space the robot can reach (per input the recorded range, by default pooled over the inputs: the servos
of one robot share their limits, and a session rarely takes every tendon as far as another), with
targets never recorded: a random subset of the inputs moved at once to random values, or each
segment's tendons taken from a different recorded row (segments bent together that were recorded one
at a time). The commands ramp to each target with per-row steps, holds and row intervals drawn from
the recorded sessions (``CommandStatistics``); every pull stays within what the routing allows
(``pull_limits``, the limit ``check_pulls`` of the benchmark enforces). The tips are the physics'
predictions, optionally with Gaussian noise at a fraction of the physics' residual on the recordings.

The result is a list of ``Recording`` with the recorded sessions' channels (``path`` ``synthetic:<i>``),
deterministic for a seed. How the learned families use them: ``softrnn.lab.nets``, and
docs/guide/real-robots.md.
"""

from __future__ import annotations

import hashlib
from dataclasses import dataclass

import numpy as np

from ..errors import bad, is_int, nonnegative
from .recording import Recording
from .tendon_robot import LENGTH_UNITS, TendonRobot

HOLD_TOLERANCE = 1e-3
"""A row holds the command when no input changes by more than this fraction of its recorded range."""


@dataclass(frozen=True)
class SyntheticOptions:
    """How much synthetic data the physics writes and how the learned families weigh it.

    Parameters
    ----------
    amount : float
        synthetic rows as a multiple of the real training rows (0: no synthetic data)
    weight : float
        the synthetic rows' total weight against the real rows' in a mixed fit (1: as much as all
        real rows together)
    seed : int
        the random generator's seed (the same seed, the same sessions)
    noise : float
        Gaussian tip noise, per axis, as a multiple of the physics' RMS residual on the recorded rows
        (0: the physics' tips exactly)
    limits : tuple or None
        (low, high) of every input in the inputs' units, or one (low, high) per input; None: the
        recorded range (``shared_range``)
    shared_range : bool
        without ``limits``: every input ranges over the recorded range of all inputs pooled (True),
        or over its own recorded range (False)
    """

    amount: float = 5.0
    weight: float = 0.5
    seed: int = 0
    noise: float = 0.0
    limits: tuple | None = None
    shared_range: bool = True

    def __post_init__(self):
        nonnegative("amount", self.amount, "x the real rows")
        nonnegative("weight", self.weight)
        nonnegative("noise", self.noise, "x the physics' residual")
        if not is_int(self.seed) or self.seed < 0:
            raise bad("seed", self.seed, "a whole number >= 0")
        if self.limits is not None:
            try:
                pairs = np.atleast_2d(np.asarray(self.limits, dtype=float))
            except (TypeError, ValueError):
                pairs = np.zeros((0, 0))
            if (pairs.ndim != 2 or pairs.shape[1] != 2 or not pairs.size or not np.all(np.isfinite(pairs))
                    or np.any(pairs[:, 0] >= pairs[:, 1])):
                raise bad("limits", self.limits, "(low, high) with low < high, or one such pair per input")
            object.__setattr__(self, "limits", tuple(map(tuple, pairs.tolist())))

    @property
    def on(self) -> bool:
        """Whether any synthetic row is asked for."""
        return self.amount > 0

    def describe(self) -> dict:
        """The options, JSON-ready."""
        return {"amount_x_real_rows": self.amount, "weight": self.weight, "seed": self.seed, "noise": self.noise,
                "limits": None if self.limits is None else [list(p) for p in self.limits],
                "shared_range": self.shared_range}


def pull_limits(robot: TendonRobot) -> np.ndarray:
    """(n_tendons,) the largest pull the routing allows [m]: pi r per segment the tendon runs through
    (bending each of them by half a turn)."""
    return np.pi * robot.routing_radius * (robot.segment_of + 1)


@dataclass(frozen=True)
class CommandStatistics:
    """What the recorded sessions' commands do row to row (in the inputs' units and s).

    Attributes
    ----------
    steps : (K,) float
        the largest per-input change of every row that moves
    holds : (H,) int
        the rows each move is held for before the next (0 where a move follows a move)
    intervals : (N,) float
        the time between consecutive rows [s]
    low, high : (m,) float
        each input's recorded range
    rows : (R, m) float
        the recorded commands
    """

    steps: np.ndarray
    holds: np.ndarray
    intervals: np.ndarray
    low: np.ndarray
    high: np.ndarray
    rows: np.ndarray

    @classmethod
    def of(cls, sessions) -> CommandStatistics:
        """The statistics of recorded sessions (a list of ``Recording``)."""
        rows = np.vstack([s.inputs for s in sessions])
        low, high = rows.min(axis=0), rows.max(axis=0)
        tol = HOLD_TOLERANCE * max(float(np.max(high - low)), 1e-12)
        steps, holds, intervals = [], [], []
        for s in sessions:
            change = np.max(np.abs(np.diff(s.inputs, axis=0)), axis=1)
            moving = change > tol
            steps.append(change[moving])
            run = 0
            for m in moving:
                if m:
                    holds.append(run)
                    run = 0
                else:
                    run += 1
            intervals.append(s.intervals)
        steps = np.concatenate(steps)
        return cls(steps=steps if steps.size else np.array([max(tol, 1e-12)]), holds=np.asarray(holds or [0]),
                   intervals=np.concatenate(intervals), low=low, high=high, rows=rows)


def _limits(stats: CommandStatistics, options: SyntheticOptions, robot: TendonRobot, units) -> tuple:
    """(low, high) (m,) of each input in its units: the options' or the recorded range, the pulls
    clipped to the routing's limit (``pull_limits``) or the input's largest recorded pull, the larger."""
    m = stats.low.size
    if options.limits is not None:
        pairs = np.asarray(options.limits, dtype=float)
        if len(pairs) not in (1, m):
            raise bad("limits", options.limits, f"one (low, high) or one per input ({m})")
        low, high = np.broadcast_to(pairs[:, 0], (m,)).copy(), np.broadcast_to(pairs[:, 1], (m,)).copy()
    elif options.shared_range:
        low, high = np.full(m, stats.low.min()), np.full(m, stats.high.max())
    else:
        low, high = stats.low.copy(), stats.high.copy()
    factor = np.array([LENGTH_UNITS[u] for u in units])
    high = np.minimum(high, np.maximum(pull_limits(robot) / factor, stats.high))
    return low, np.maximum(high, low)


def _target(rng, current, stats: CommandStatistics, low, high, group: int) -> np.ndarray:
    """The next command: a random subset of inputs moved to random values, or every segment's
    tendons (``group`` consecutive inputs) from a different recorded row."""
    m = current.size
    if rng.random() < 0.5:
        target = current.copy()
        moved = rng.choice(m, size=rng.integers(1, m + 1), replace=False)
        target[moved] = rng.uniform(low[moved], high[moved])
    else:
        picks = rng.integers(0, len(stats.rows), size=-(-m // group))
        target = np.concatenate([stats.rows[p, g * group:(g + 1) * group] for g, p in enumerate(picks)])
    return np.clip(target, low, high)


def _commands(rng, stats: CommandStatistics, low, high, group: int, rows: int) -> np.ndarray:
    """(rows, m) commands: ramps from the recorded start to successive targets, with recorded
    per-row steps and holds."""
    current = np.clip(stats.rows[0], low, high)
    out = [current]
    count = 1
    while count < rows:
        target = _target(rng, current, stats, low, high, group)
        step = float(rng.choice(stats.steps))
        n = max(1, int(np.ceil(np.max(np.abs(target - current)) / step)))
        ramp = current + (target - current) * (np.arange(1, n + 1) / n)[:, None]
        hold = np.repeat(target[None], int(rng.choice(stats.holds)), axis=0)
        out += [ramp, hold]
        count += len(ramp) + len(hold)
        current = target
    return np.vstack(out)[:rows]


def synthetic_sessions(physics, sessions, options: SyntheticOptions = SyntheticOptions()) -> list[Recording]:
    """Synthetic sessions of the robot whose fitted ``physics`` (``families.Physics``) was calibrated
    on ``sessions`` (a list of ``Recording``): ``options.amount`` times their rows in sessions of
    their mean length, tips = the physics' (+ noise). Rows whose predicted tip is not finite are
    dropped. [] when ``options.amount`` is 0. Kept in ``physics.memo`` where it has one (the same
    physics, sessions and options, the same synthetic sessions)."""
    sessions = list(sessions)
    memo = getattr(physics, "memo", None)
    key = ("synthetic", options, *((s.commands_key(), hashlib.sha256(np.ascontiguousarray(s.tip).tobytes()).digest())
                                   for s in sessions))
    if memo is not None and key in memo:
        return list(memo[key])
    out = _synthesize(physics, sessions, options)
    if memo is not None:
        memo[key] = tuple(out)
    return out


def _after_calibration(physics, stats: CommandStatistics) -> float:
    """The time [s] the synthetic sessions start at: a recorded interval after the last row of the physics'
    calibration where it keeps a timeline (creep, ``tendon_robot.CreepTimeline``), so that each runs on the
    robot as the training left it, as a session recorded after the training does; else 0."""
    timeline = getattr(getattr(physics, "calibration", None), "timeline", None)
    if timeline is None or not timeline.times.size:
        return 0.0
    return float(timeline.times.max()) + float(np.median(stats.intervals))


def _synthesize(physics, sessions: list, options: SyntheticOptions) -> list[Recording]:
    """``synthetic_sessions`` computed."""
    real = sum(s.n_rows for s in sessions)
    total = int(round(options.amount * real))
    if total <= 0:
        return []
    first = sessions[0]
    rng = np.random.default_rng(options.seed)
    stats = CommandStatistics.of(sessions)
    low, high = _limits(stats, options, physics.robot, first.units)
    group = physics.robot.tendons_per_segment
    sigma = 0.0
    if options.noise > 0:
        res = np.vstack([physics.predict(s) - s.tip for s in sessions])
        sigma = options.noise * np.sqrt(np.mean(res ** 2, axis=0))             # (3,) [m]
    length = max(10, int(round(real / len(sessions))))
    start = _after_calibration(physics, stats)
    out = []
    for i, a in enumerate(range(0, total, length)):
        n = min(length, total - a)
        u = _commands(rng, stats, low, high, group, n)
        t = start + np.concatenate([[0.0], np.cumsum(rng.choice(stats.intervals, size=n - 1))])
        rec = Recording(path=f"synthetic:{i}", time=t, inputs=u, names=first.names, units=first.units,
                        tip=np.zeros((n, 3)), columns=first.columns)
        tip = physics.predict(rec) + rng.normal(0.0, 1.0, (n, 3)) * sigma
        ok = np.all(np.isfinite(tip), axis=1)
        if np.count_nonzero(ok) >= 3:
            out.append(Recording(path=rec.path, time=t[ok], inputs=u[ok], names=first.names, units=first.units,
                                 tip=tip[ok], columns=first.columns))
    return out


MODES = ("real", "finetune", "mixed")
"""How a learned family uses the synthetic sessions: not at all, pretrained then fitted to the real
rows, or both at once (``softrnn.lab.nets``)."""


def check_mode(family, offered=MODES) -> None:
    """Refuse (one line) a ``family`` whose ``mode`` is not one of ``offered``, or that learns from
    synthetic sessions without a calibrated ``physics`` and ``synthetic.amount`` > 0."""
    if family.mode not in offered:
        raise bad("mode", family.mode, f"one of {', '.join(offered)} for the {family.name} family")
    if family.mode != "real" and (family.physics is None or family.physics.calibration is None
                                  or not family.synthetic.on):
        raise bad("mode", family.mode, f"'real' for the {family.name} family without a calibrated physics and "
                                       "synthetic.amount > 0 (the other modes learn from the physics' sessions)")


def taught_sessions(family, sessions, offered=MODES, options: SyntheticOptions | None = None) -> list:
    """The synthetic sessions ``family`` learns from beside ``sessions`` ([] in mode ``real``), its mode
    one of ``offered`` (``check_mode``); ``options``: instead of ``family.synthetic``."""
    check_mode(family, offered)
    if family.mode == "real":
        return []
    return synthetic_sessions(family.physics, sessions, family.synthetic if options is None else options)
