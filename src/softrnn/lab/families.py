"""The models a robot's recordings are fitted with, and the baselines they are compared with.

Every family is a frozen description of a model; ``fit(sessions)`` returns the fitted model, a new frozen
instance of the same class, which predicts the tip of a whole session free running from its start on the
commands alone (``predict(session)`` -> (T, 3) [m]) and says what it is (``describe()``): the recorded tip is
read only where a model needs an initial condition (the first row for persistence, two for constant velocity,
``na`` for the linear ARX model), never afterwards.

Baselines (the cores shared with the learned models, ``softrnn.learned``):

* ``PersistenceFamily``, ``ConstantVelocityFamily``: ``learned.baselines.Persistence`` and
  ``ConstantVelocity`` run free: the tip stays where the session starts, or keeps its first velocity.
* ``LinearARXFamily``: ``learned.linear.LinearARX`` of the tip driven by the commands (least squares, run free).
* ``StaticPolynomial``: the tip as a polynomial of the current inputs (ridge least squares).

softrnn's models:

* ``Physics``: the calibrated tendon robot (``softrnn.lab.tendon_robot``).
* ``LearnedMap``, ``Hybrid`` (the physics plus a learned residual), ``Sequence`` (a GRU): the learned
  families, taught by the physics' synthetic sessions (``softrnn.lab.nets``, ``softrnn.lab.synthetic``).
* ``NodeFamily``: softrnn's per-node LSTM (``softrnn.learned.node``) driven by the commands alone.

The errors of a prediction are ``softrnn.learned.metrics.tip_errors``. Options with more than one sensible value
(the ARX orders, the polynomial's degree and ridge, the hysteresis state) are chosen on a hold-out part of the
training sessions (``choose``), never on the session a model is reported on.
"""

from __future__ import annotations

import hashlib
import math
import tempfile
from dataclasses import dataclass, field, replace
from typing import Protocol

import numpy as np
from scipy.spatial import cKDTree

from ..errors import SoftrnnInputError, bad, nonnegative
from ..fitting.starts import here
from ..io.reader import Dataset
from ..learned.baselines import ConstantVelocity, Persistence, free_run
from ..learned.horizons import RolloutDiverged
from ..learned.linear import LinearARX
from ..learned.metrics import tip_errors
from ..learned.node.train_config import TrainConfig
from .recording import Recording
from .synthetic import SyntheticOptions, check_mode, taught_sessions
from .tendon_robot import LENGTH_UNITS, Calibration, CalibrationOptions, TendonRobot, calibrate, pack, session_resets

PLAY_WIDTHS = (0.05, 0.15)
"""Widths of the play operators of the hysteresis state, as fractions of each input's range in
the training sessions."""


class Family(Protocol):
    """What the benchmark needs of a model family (every class below): ``fit`` returns the fitted
    model, a new frozen instance, whose ``predict`` runs free over a session."""

    name: str

    def fit(self, sessions) -> Family:
        """The model fitted on training sessions (a list of ``Recording``)."""

    def predict(self, session: Recording) -> np.ndarray:
        """The tip (T, 3) [m] over ``session``, free running from its start on its inputs."""

    def describe(self) -> dict:
        """What the model is and its options, JSON-ready."""


def _previous(u: np.ndarray) -> np.ndarray:
    return np.vstack([u[:1], u[:-1]])


def play(u: np.ndarray, width: np.ndarray) -> np.ndarray:
    """The play (backlash) operator of each input column: p_k = min(max(p_{k-1}, u_k - w), u_k + w),
    p_0 = u_0; u (T, m), width (m,) -> (T, m). Its output lags a reversal by the width: the
    simplest path-dependent state (Preisach / Prandtl-Ishlinskii hysteresis models sum these)."""
    out = np.empty_like(u)
    state = u[0].copy()
    for k in range(len(u)):
        state = np.minimum(np.maximum(state, u[k] - width), u[k] + width)
        out[k] = state
    return out


# -------------------------------------------------------------------------------------------- baselines
@dataclass(frozen=True)
class PersistenceFamily:
    """The tip stays at the session's first recorded position (``learned.baselines.Persistence`` run free)."""

    name: str = "persistence"
    baseline, kind = Persistence(), "the first row's tip held"    # class attributes, not fields

    def fit(self, sessions) -> PersistenceFamily:
        """The fitted model (nothing to fit: ``self``) for training sessions (a list of ``Recording``)."""
        return self

    def predict(self, session: Recording) -> np.ndarray:
        """The tip (T, 3) [m] over ``session``, free running from its first ``history`` rows; NaN from the
        row where the run left the bounds of ``learned.baselines.free_run`` (it diverged: scored as a miss)."""
        H, T = self.baseline.history, session.n_rows
        try:
            run = free_run(self.baseline, session.tip[:, None], None, H, T)[:, 0] if T > H else session.tip[H:]
        except RolloutDiverged as err:
            run = err.states[:, 0]
        return np.concatenate([session.tip[:H], run])                              # (T, 3)

    def describe(self) -> dict:
        """What the model is and its options, JSON-ready."""
        return {"kind": self.kind}


@dataclass(frozen=True)
class ConstantVelocityFamily(PersistenceFamily):
    """The tip keeps the velocity of the session's first two rows (``learned.baselines.ConstantVelocity``)."""

    name: str = "constant_velocity"
    spread: float = 0.0
    """The training tips' RMS distance from their mean [m] (``fit``): how far the tip wanders."""
    baseline, kind = ConstantVelocity(), "the first two rows' velocity kept"

    def fit(self, sessions) -> ConstantVelocityFamily:
        """The fitted model for training sessions (a list of ``Recording``): nothing to fit but the spread
        of their tips (``error_scale``)."""
        tip = np.vstack([s.tip for s in sessions])
        return replace(self, spread=float(np.sqrt(np.mean(np.sum((tip - tip.mean(axis=0)) ** 2, axis=1)))))

    def error_scale(self, session: Recording) -> np.ndarray:
        """(T,) the scale of its error per row [m]: k |v0| + ``spread``, k the rows since the session's
        start and v0 its first velocity [m per row]: the run leaves the robot's workspace along v0, and
        the tip wanders within it (``softrnn.lab.uncertainty``)."""
        v0 = float(np.linalg.norm(session.tip[1] - session.tip[0])) if session.n_rows > 1 else 0.0
        return np.arange(session.n_rows, dtype=float) * v0 + self.spread

    def describe(self) -> dict:
        """What the model is and its error scale, JSON-ready."""
        return {"kind": self.kind, "error_scale": "rows since the start x |first velocity| + spread",
                "spread_mm": round(self.spread * 1e3, 4)}


@dataclass(frozen=True, eq=False)
class LinearARXFamily:
    """The tip as a linear ARX model of the commands (``learned.linear.LinearARX``, ``na`` tip lags,
    ``nb`` input lags), free running: from the session's first ``history`` measured tips, or with
    ``from_rest`` from its first row alone, the robot taken at rest there (the commands and the tip held
    at the first row's before it), so that every row is predicted."""

    na: int = 1
    nb: int = 1
    name: str = "linear_arx"
    arx: LinearARX | None = None
    from_rest: bool = False

    @property
    def W(self) -> np.ndarray:
        """The fitted weights (``LinearARX.weights``)."""
        return self.arx.weights

    def fit(self, sessions) -> LinearARXFamily:
        """The model fitted on training sessions (a list of ``Recording``)."""
        sessions = list(sessions)
        arx = LinearARX.fit([s.tip for s in sessions], [s.inputs for s in sessions], self.na, self.nb)
        return replace(self, arx=arx)

    def predict(self, session: Recording) -> np.ndarray:
        """The tip (T, 3) [m] over ``session``, free running from its start on its inputs."""
        with np.errstate(over="ignore", invalid="ignore"):      # a run that diverges scores inf (``choose``)
            if not self.from_rest:
                return self.arx.run(session.tip, session.inputs)
            m = self.arx.history
            u = np.vstack([np.repeat(session.inputs[:1], m, axis=0), session.inputs])
            return self.arx.run(np.repeat(session.tip[:1], m, axis=0), u)[m:]

    def describe(self) -> dict:
        """What the model is and its options, JSON-ready."""
        return {"kind": "linear ARX, least squares, free running" + (" from rest" if self.from_rest else ""),
                "na": self.na, "nb": self.nb}


def _monomials(u: np.ndarray, degree: int) -> np.ndarray:
    cols = [np.ones(len(u))]
    m = u.shape[1]

    def grow(start, depth, prod):
        for i in range(start, m):
            p = prod * u[:, i]
            cols.append(p)
            if depth < degree:
                grow(i, depth + 1, p)

    grow(0, 1, np.ones(len(u)))
    return np.column_stack(cols)


@dataclass(frozen=True, eq=False)
class StaticPolynomial:
    """The tip as a polynomial of the current inputs (ridge least squares on standardised inputs;
    ``ridge`` relative to the features' mean square)."""

    degree: int = 1
    ridge: float = 1e-6
    name: str = "static_map"
    W: np.ndarray | None = None
    mu: np.ndarray | None = None
    sd: np.ndarray | None = None

    def _features(self, u):
        return _monomials((u - self.mu) / self.sd, self.degree)

    def fit(self, sessions) -> StaticPolynomial:
        """The model fitted on training sessions (a list of ``Recording``)."""
        u = np.vstack([s.inputs for s in sessions])
        y = np.vstack([s.tip for s in sessions])
        scaled = replace(self, mu=u.mean(axis=0), sd=u.std(axis=0) + 1e-12)
        X = scaled._features(u)
        G = X.T @ X
        lam = self.ridge * np.trace(G) / G.shape[0]
        return replace(scaled, W=np.linalg.solve(G + lam * np.eye(G.shape[0]), X.T @ y))

    def predict(self, session: Recording) -> np.ndarray:
        """The tip (T, 3) [m] over ``session``, free running from its start on its inputs."""
        return self._features(session.inputs) @ self.W

    def describe(self) -> dict:
        """What the model is and its options, JSON-ready."""
        return {"kind": "polynomial of the current inputs, ridge least squares", "degree": self.degree,
                "ridge": self.ridge}


# -------------------------------------------------------------------------------------- softrnn models
def displacements(session: Recording) -> np.ndarray:
    """The inputs as tendon displacements [m] (their units must be lengths)."""
    factors = []
    for name, unit in zip(session.names, session.units):
        if unit not in LENGTH_UNITS:
            raise SoftrnnInputError(f"{session.path}: input {name!r} has the unit {unit or 'none'!r}; the tendon "
                                    "physics needs tendon displacements in m or mm (name the column e.g. "
                                    "servo_1_mm or act_servo_1[mm]), or leave the physics out with --families")
        factors.append(LENGTH_UNITS[unit])
    return session.inputs * np.asarray(factors)


MEMO_SIZE = 256
"""Most entries a model's memo keeps before it starts again."""

REFITS: dict = {}
"""The physics' refits made in this process (``Physics.refit``), by what determines them (``refit_key``):
the intervals' refits of the physics and of the hybrid (its physics refitted without the same blocks of
patterns, ``softrnn.lab.uncertainty``) are the same fits, made once. A fit is deterministic, so a refit
taken from here is the one a new fit would make. ``shared_refits`` and ``remember_refits`` carry them to
another process."""
REFITS_SIZE = 64
"""Most refits ``REFITS`` keeps before it starts again."""


def sessions_key(sessions) -> str:
    """A digest of what a fit on ``sessions`` (a list of ``Recording``) reads: each session's commands
    (``Recording.commands_key``) and tips (NaN where masked)."""
    h = hashlib.sha256()
    for s in sessions:
        h.update(s.commands_key().encode())
        h.update(np.ascontiguousarray(s.tip, dtype=float).tobytes())
    return h.hexdigest()


def shared_refits() -> dict:
    """The physics' refits made in this process so far ({key: ``Physics``}, ``REFITS``), to hand to another
    (``remember_refits``)."""
    return dict(REFITS)


def _room_for_refits(n: int) -> None:
    """``REFITS`` emptied where ``n`` more would take it beyond ``REFITS_SIZE``."""
    if len(REFITS) + n > REFITS_SIZE:
        REFITS.clear()


def remember_refits(refits: dict | None) -> None:
    """Take the physics' refits another process made (``shared_refits``) as this process's own."""
    if refits:
        _room_for_refits(len(refits))
        REFITS.update(refits)


@dataclass(frozen=True, eq=False)
class Physics:
    """The calibrated tendon robot (``softrnn.lab.tendon_robot``; gravity and friction as
    ``options`` say); ``start``: parameters to refine from instead of the multi-start search."""

    robot: TendonRobot
    options: CalibrationOptions = CalibrationOptions()
    name: str = "physics"
    calibration: Calibration | None = None
    progress: object = None
    start: object = None
    memo: dict = field(default_factory=dict, init=False, repr=False)
    """The predictions (and synthetic sessions, ``softrnn.lab.synthetic``) of this calibration already
    computed, by ``Recording.commands_key``: the hold-out's candidates run it over the same sessions."""

    def fit(self, sessions, spread=here, pieces: int = 1) -> Physics:
        """The model calibrated on training sessions (a list of ``Recording``, each solved from its start,
        in order; rows whose tip is NaN are run but not fitted, ``masked``); ``spread``, ``pieces``: where
        its search's fits run (``softrnn.fitting.multistart``)."""
        q, tip = np.vstack([displacements(s) for s in sessions]), np.vstack([s.tip for s in sessions])
        cal = calibrate(self.robot, q, tip, self.options, progress=self.progress, start=self.start,
                        resets=session_resets([s.n_rows for s in sessions]), spread=spread, pieces=pieces,
                        times=np.concatenate([s.time for s in sessions]))
        return replace(self, calibration=cal)

    @property
    def runs_through(self) -> bool:
        """Whether the model runs through every row in order, its state carried along (the tendons' creep):
        it is then refitted without rows by masking their tips (``masked``), not by cutting them out."""
        return self.options.creep

    def refit(self, sessions) -> Physics:
        """The model calibrated on ``sessions``, refined from this calibration (no multi-start search); a
        refit made before in this process (``REFITS``) is taken from there."""
        key = self.refit_key(sessions)
        if key not in REFITS:
            _room_for_refits(1)
            REFITS[key] = replace(self, start=self.calibration.params, calibration=None).fit(list(sessions))
        return REFITS[key]

    def refit_key(self, sessions) -> tuple:
        """What determines ``refit(sessions)``: the robot, the options, this calibration's parameters (the
        refinement's start) and the sessions (``sessions_key``)."""
        return (self.robot, self.options, self.name, pack(self.calibration.params).tobytes(), sessions_key(sessions))

    def predict(self, session: Recording) -> np.ndarray:
        """The tip (T, 3) [m] over ``session``, free running from its start on its inputs."""
        key = ("predict", session.commands_key())
        if key not in self.memo:
            if len(self.memo) > MEMO_SIZE:
                self.memo.clear()
            self.memo[key] = self.calibration.predict(displacements(session), times=session.time)
        return self.memo[key].copy()

    def describe(self) -> dict:
        """What the model is and its options, JSON-ready."""
        return {"kind": "calibrated tendon robot physics", "variant": self.options.variant} | self.calibration.to_dict()


# ------------------------------------------------------------------------------------------- choice
HOLDOUT_FRACTION = 0.75
"""The share of the training rows that fit while options are chosen; the rest is held out."""
HOLDOUT_BLOCKS = (4, 12)
"""A sole training session is cut into this many stretches of rows at least and at most (about one
per ``BLOCK_ROWS`` rows); a quarter of them, the least covered by the rest, are held out."""
BLOCK_ROWS = 20
HOLDOUT_RULES = ("the quarter of the training session's stretches of rows farthest in command space from the rest",
                 "the training session farthest in command space from the others")
"""What ``holdout_split`` holds out of one session and of several, in words (the reports'
``chosen_on_training.holdout``)."""


def novelty(parts) -> np.ndarray:
    """(P,) how far each of ``parts`` (``Recording``s) lies from the others in command space: the mean
    distance of its rows' inputs to the nearest row of the other parts, each input scaled by its
    standard deviation over all the parts (a channel that never moves counts nothing)."""
    inputs = np.vstack([p.inputs for p in parts])
    spread = inputs.std(axis=0)
    scaled = inputs / np.where(spread > 0, spread, np.inf)
    owner = np.repeat(np.arange(len(parts)), [p.n_rows for p in parts])
    out = np.empty(len(parts))
    for i in range(len(parts)):
        mine = owner == i
        out[i] = cKDTree(scaled[~mine]).query(scaled[mine])[0].mean()
    return out


def _runs(session: Recording, edges: np.ndarray, blocks) -> list[Recording]:
    """The rows of ``session`` in the stretches ``blocks`` (indices into ``edges``' stretches), joined
    where consecutive."""
    out, start = [], None
    for b in range(len(edges) - 1):
        if b in blocks and start is None:
            start = edges[b]
        if start is not None and b + 1 not in blocks:
            out.append(session.rows(start, edges[b + 1]))
            start = None
    return out


def stretch_edges(rows: int) -> np.ndarray:
    """(K + 1,) the first row of each of the K stretches a session of ``rows`` rows is cut into
    (``HOLDOUT_BLOCKS``: about one per ``BLOCK_ROWS`` rows), and ``rows``."""
    low, high = HOLDOUT_BLOCKS
    return np.linspace(0, rows, min(high, max(low, rows // BLOCK_ROWS)) + 1).round().astype(int)


def holdout_split(sessions) -> tuple[list, list]:
    """Training sessions split for choosing options, so that the choice tests a model where its data
    end: (fitting part, held-out part), lists of ``Recording``. With two or more sessions, the session
    farthest from the others in command space (``novelty``) is held out; with one, the session is cut
    into stretches of rows (``HOLDOUT_BLOCKS``) and the quarter of them farthest from the rest is held
    out, each run of held or kept stretches a session of its own (rows in order, never shuffled) and a
    stretch (``Recording.stretch``), so that what is held out tells whether it is whole sessions
    (``uncertainty.held_sessions``)."""
    sessions = list(sessions)
    if len(sessions) >= 2:
        far = int(np.argmax(novelty(sessions)))
        return [s for i, s in enumerate(sessions) if i != far], [sessions[far]]
    s = sessions[0]
    edges = stretch_edges(s.n_rows)
    parts = [s.rows(a, b) for a, b in zip(edges[:-1], edges[1:])]
    count = max(1, int(round((1.0 - HOLDOUT_FRACTION) * len(parts))))
    held = set(np.argsort(-novelty(parts), kind="stable")[:count].tolist())
    return _runs(s, edges, set(range(len(parts))) - held), _runs(s, edges, held)


def masked(sessions, held) -> list[Recording]:
    """``sessions`` (a list of ``Recording``) with the tips of the rows of ``held`` (pieces of them, e.g.
    ``holdout_split``'s held part: rows of the same path, time and inputs) set to NaN: a model with memory
    (the tendons' creep) is then fitted on the other rows while it runs through every row in order, the
    held ones included, as the robot did."""
    keys = {(h.path, t, row.tobytes()) for h in held for t, row in zip(h.time, h.inputs)}
    out = []
    for s in sessions:
        hide = np.array([(s.path, t, row.tobytes()) in keys for t, row in zip(s.time, s.inputs)], dtype=bool)
        tip = s.tip.copy()
        tip[hide] = np.nan
        out.append(replace(s, tip=tip))
    return out


def finite_or_inf(value: float) -> float:
    """``value``, inf where it is not finite: a run that diverged (NaN) scores worst."""
    return value if math.isfinite(value) else math.inf


def parsimonious(scores: dict, rows: int):
    """The label of ``scores`` ({label: hold-out RMSE [mm]}, listed simplest first) to choose, by the
    one-standard-error rule: the first whose score is within one standard error of the best score,
    taken as 1/sqrt(2 ``rows``) of it (the standard error of an RMSE over ``rows`` independent rows;
    a recording's rows are correlated, so the true one is larger). A more complex candidate is chosen
    only where the hold-out shows it better by more than its score's own uncertainty."""
    finite = {k: v for k, v in scores.items() if math.isfinite(v)}
    if not finite:
        return next(iter(scores))
    limit = min(finite.values()) * (1.0 + 1.0 / math.sqrt(2.0 * max(int(rows), 1)))
    return next(k for k, v in finite.items() if v <= limit)


def held_rows(held) -> int:
    """The rows of the held-out sessions ``held`` (a list of ``Recording``)."""
    return sum(s.n_rows for s in held)


@dataclass(frozen=True)
class Choice:
    """The option chosen for a family and the hold-out scores of each candidate [mm]."""

    chosen: object
    scores: dict = field(default_factory=dict)


def choose(candidates: dict, sessions, split: tuple | None = None) -> Choice:
    """Fit each candidate (``{label: factory() -> model}``, simplest first) on the fitting part of
    ``sessions`` and score its free run on the hold-out part (Euclidean tip RMSE [mm]); the simplest
    within one standard error of the best wins (``parsimonious``). ``split``: ``holdout_split(sessions)``
    where already made."""
    fit_part, held = holdout_split(sessions) if split is None else split
    scores = {}
    for label, factory in candidates.items():
        model = factory().fit(fit_part)
        pred = np.vstack([model.predict(s) for s in held])
        ref = np.vstack([s.tip for s in held])
        score = tip_errors(pred, ref).rmse_mm
        scores[label] = finite_or_inf(score)
    return Choice(chosen=parsimonious(scores, held_rows(held)), scores=scores)


# ---------------------------------------------------------------------------------- the node model
def as_dataset(sessions, length: float, dt: float | None = None):
    """The sessions as one ``softrnn.io.Dataset`` of the tip (node 1 of a 2-node rod of ``length``
    [m]) and the inputs as actuation channels: the rows in order, each later session's times
    shifted to follow the previous one's last row by the median interval. The node model reads the
    rows as steps of ``dt`` [s] (None: the median interval), one row a step: give the training
    data's to every session the model meets, however its rows are paced."""
    times, offset = [], 0.0
    for s in sessions:
        t = s.time - s.time[0] + offset
        times.append(t)
        offset = t[-1] + float(np.median(np.diff(s.time)))
    time = np.concatenate(times)
    tip = np.vstack([s.tip for s in sessions])
    T = time.size
    quats = np.zeros((T, 1, 4), dtype=np.float32)
    quats[..., 0] = 1.0
    units = {"time": "s", "positions": "m", "quaternions": "1 (unit, scalar first w x y z, body to world)",
             "forces": "N", "torques": "N m"}
    first = sessions[0]
    return Dataset(time=time, nodes=np.array([1]), positions=tip[:, None, :].astype(np.float32), quaternions=quats,
                   forces=np.zeros((T, 1, 3), np.float32), torques=np.zeros((T, 1, 3), np.float32),
                   attrs={"units": units, "rod": {"length": length}, "n_nodes_total": 2,
                          "dt": float(np.median(np.diff(time))) if dt is None else float(dt),
                          "has_orientations": False},
                   actuation=np.vstack([s.inputs for s in sessions]).astype(np.float32),
                   actuation_units={n: (u or "1") for n, u in zip(first.names, first.units)})


NODE_TRAINING = TrainConfig(rollout_steps=8, epochs=60, patience=20, max_train_windows=6000)
"""The lab's training of the node LSTM (those of the lab workflow guide): 8 steps of the multi-step
loss, at most 60 epochs, 20 epochs' patience on the hold-out part, at most 6,000 windows per epoch
(more rows are taken at an even stride: neighbouring windows overlap in all but one row, so a
15,000-row recording trains in less than half the time, at about the same validation error: 55.3 mm
against 55.5 on a pneumatic-like stand-in, 6.75 against 6.43 on the lab-example arm; a recording of a
few thousand rows is not thinned at all); ``dataclasses.replace`` it to change one."""


@dataclass(frozen=True)
class NodeOptions:
    """The node LSTM's settings (``NodeFamily``; those of the lab workflow guide): its window and
    size, and its training (``softrnn.learned.node``'s own ``TrainConfig``)."""

    history: int = 4
    """Past rows a prediction reads (the first rows of a session are the run's initial condition)."""
    units: int = 64
    """LSTM units."""
    training: TrainConfig = NODE_TRAINING
    """How it is trained (the multi-step loss, epochs, patience on the hold-out part, seed)."""
    synthetic_amount: float = 1.0
    """With the physics' synthetic sessions (``NodeFamily.mode`` ``mixed``): at most this many synthetic
    rows per real row (the LSTM's training time grows with its rows)."""

    def __post_init__(self):
        nonnegative("synthetic_amount", self.synthetic_amount, "x the real rows")

    def describe(self) -> dict:
        """The options, JSON-ready: the window, the size and the training settings the lab sets."""
        t = self.training
        return {"history": self.history, "units": self.units, "rollout_steps": t.rollout_steps,
                "epochs": t.epochs, "patience": t.patience, "seed": t.seed}


def rms_error(model, sessions) -> float:
    """The RMS [m] of ``model``'s tip error over the rows of ``sessions`` where its run is finite (rows
    where it diverged are the cross-fit's inf); inf where there is none."""
    err = np.concatenate([np.linalg.norm(model.predict(s) - s.tip, axis=1) for s in sessions])
    finite = err[np.isfinite(err)]
    return float(np.sqrt(np.mean(finite ** 2))) if finite.size else math.inf


@dataclass(frozen=True, eq=False)
class InputDistance:
    """The distance of a row's inputs from the nearest training row, each input standardised by
    its training mean ``mu`` and deviation ``sd`` (``of(sessions)``)."""

    tree: cKDTree
    mu: np.ndarray
    sd: np.ndarray

    @classmethod
    def of(cls, sessions) -> InputDistance:
        """The distance from the rows of training ``sessions`` (a list of ``Recording``) with a measured tip
        (the rows a model was fitted on: not those masked, ``families.masked``)."""
        u = np.vstack([s.inputs[np.all(np.isfinite(s.tip), axis=1)] for s in sessions])
        mu, sd = u.mean(axis=0), u.std(axis=0) + 1e-12
        return cls(cKDTree((u - mu) / sd), mu, sd)

    def __call__(self, session) -> np.ndarray:
        """(T,) the distance of each row of ``session`` [standard deviations]."""
        return self.tree.query((session.inputs - self.mu) / self.sd, k=1)[0]


def gate_weights(reach: InputDistance, gate: float, session: Recording) -> np.ndarray:
    """(T,) a learned residual's weight w = exp(-(d / ``gate``)^2) in [0, 1] per row of ``session``, d the
    distance of its standardised inputs from the nearest training row (``reach``, an
    ``InputDistance``): 1 on a training row, falling to 0 away from them; 1 everywhere where
    ``gate`` is inf."""
    if math.isinf(gate):
        return np.ones(session.n_rows)
    with np.errstate(under="ignore"):                 # far out: w = 0
        return np.exp(-(reach(session) / gate) ** 2)


def command_range(sessions) -> tuple[np.ndarray, np.ndarray]:
    """((m,), (m,)): the least and greatest command of each input over the rows of ``sessions`` (a list of
    ``Recording``), the range a learned model that carries a state reads its commands clipped to."""
    u = np.vstack([s.inputs for s in sessions])
    return u.min(axis=0), u.max(axis=0)


def calibrated(physics) -> bool:
    """Whether ``physics`` is a fitted ``Physics`` (not None, its calibration done)."""
    return getattr(physics, "calibration", None) is not None


def physics_distance(tip: np.ndarray, physics, session: Recording) -> np.ndarray:
    """(T,) [m] the distance of ``tip`` (T, 3) [m], a model's run over ``session``, from the fitted
    ``physics``' tip there, row by row; inf where either run is not finite."""
    gap = np.linalg.norm(tip - physics.predict(session), axis=1)
    return np.where(np.isfinite(gap), gap, math.inf)


PHYSICS_GAP = "the distance from the calibrated physics' tip (root sum of squares)"
"""What a scale that holds its distance from the physics (``with_physics_gap``) says of it, JSON-ready."""


def with_physics_gap(scale: np.ndarray, tip: np.ndarray, physics, session: Recording) -> np.ndarray:
    """(T,) [m] a model's own error ``scale`` (T,) [m] combined with the distance of its run ``tip`` (T, 3)
    [m] over ``session`` from the fitted ``physics``' tip (``physics_distance``): sqrt(scale^2 + gap^2);
    unbounded where either run is not finite."""
    return np.sqrt(scale ** 2 + physics_distance(tip, physics, session) ** 2)


class Anchored:
    """What a learned model anchored on a physics shares (``Sequence``, ``NodeFamily``): its fields
    ``physics`` (a fitted ``Physics``, or None) and ``physics_rms`` (the physics' RMS tip error [m] over
    the rows the model was fitted on; None without a fitted physics), and its ``predict``."""

    def anchored(self, physics, sessions):
        """The fitted model with ``physics`` (fitted, or None) as its error scale's (``error_scale``), its
        RMS error taken over ``sessions``, the rows the model was fitted on; also a candidate fitted
        before the physics was calibrated, so that it states the scale its final fit has."""
        return replace(self, physics=physics, physics_rms=rms_error(physics, sessions) if calibrated(physics) else None)

    def error_scale(self, session: Recording) -> np.ndarray:
        """(T,) [m] the scale of its error per row: |tip - the physics' tip| + the physics' RMS error over
        the training rows (``physics_rms``); 1 without a fitted physics. A learned model's error is at most
        its distance from the physics plus the physics' own error: where it leaves the physics (commands
        its real rows do not show), its interval widens; where they agree, the physics' error is the
        measure (its error on its training rows would understate a new session's). A row where either run
        is not finite gets an unbounded scale."""
        if self.physics_rms is None:
            return np.ones(session.n_rows)
        return physics_distance(self.predict(session), self.physics, session) + self.physics_rms

    def anchor_description(self) -> dict:
        """The error scale's description and the physics' RMS error [mm], JSON-ready ({} without a fitted
        physics)."""
        if self.physics_rms is None:
            return {}
        return {"error_scale": "distance from the physics' tip plus the physics' RMS error over the training rows",
                "error_scale_physics_rms_mm": round(self.physics_rms * 1e3, 4)}


@dataclass(frozen=True, eq=False)
class NodeFamily(Anchored):
    """softrnn's per-node LSTM (``softrnn train --drive actuation``, the paper's model driven by the
    inputs alone): trained on the fitting part of the training sessions and stopped early on the
    hold-out part (``holdout_split``), run free over a session from its first ``history`` rows
    (the recorded tips there are its initial condition). ``mode`` ``mixed``: the calibrated
    ``physics``' synthetic sessions (``softrnn.lab.synthetic``, ``synthetic`` with at most
    ``options.synthetic_amount`` rows per real row) join its training rows.

    ``on_physics`` (mode ``real``): the node learns what the calibrated ``physics`` leaves. Its node is
    the residual tip - physics' tip (plus ``anchor``, the physics' mean tip over the training rows, so
    that it lies where a tip does), written as the next pose itself (the node model's ``output``
    ``pose``), and its tip the physics' plus w times the residual's free run, w =
    exp(-(d / ``gate``)^2) per row (``gate_weights``: the hybrid's gate), so that away from the training
    rows it is its physics. The run starts from a zero residual: no recorded tip is read. The node reads
    the commands clipped to their training range (``low``, ``high``): its run feeds its own predictions
    back, so a command no training row reached (a servo held still through the training, moved later)
    would drive it where no row took it and spoil the rows after it, where the gate lets it act again."""

    length: float
    options: NodeOptions = NodeOptions()
    name: str = "node_lstm"
    model: object = None
    mode: str = "real"
    synthetic: SyntheticOptions = SyntheticOptions()
    physics: object = None
    step: float | None = None
    """The step [s] the model was trained on (``fit``: its training rows' median interval): every
    session it meets is read as rows of this step (``as_dataset``)."""
    physics_rms: float | None = None
    """The physics' RMS tip error [m] over the rows it was fitted on (``error_scale``; None without a fitted
    physics)."""
    on_physics: bool = False
    """Whether the node learns the residual of the fitted ``physics`` (the class docstring)."""
    gate: float = math.inf
    """With ``on_physics``: the residual's gate width d0 (``gate_weights``); inf: not gated."""
    reach: InputDistance | None = None
    """With ``on_physics``: the distance from the training rows' inputs (``InputDistance``)."""
    anchor: np.ndarray | None = None
    """With ``on_physics``: (3,) [m] the physics' mean tip over the training rows, where a zero residual lies."""
    low: np.ndarray | None = None
    high: np.ndarray | None = None
    """With ``on_physics``: (m,) the training rows' least and greatest command of each input, the range the
    node reads them clipped to."""

    def __post_init__(self):
        check_mode(self, ("real", "mixed"))
        if self.on_physics and self.mode != "real":
            raise bad("mode", self.mode, "'real' with on_physics=True: the physics' synthetic sessions have no "
                                         "residual to learn")

    def _residual(self, sessions) -> list[Recording]:
        """``sessions`` with the tip replaced by tip - the physics' tip + ``anchor`` (``on_physics``)."""
        return [replace(s, tip=s.tip - self.physics.predict(s) + self.anchor) for s in sessions]

    def _taught(self, sessions) -> list:
        """The synthetic sessions of mode ``mixed`` ([] in mode ``real``) for training on ``sessions``."""
        amount = min(self.synthetic.amount, self.options.synthetic_amount)
        return taught_sessions(self, sessions, ("real", "mixed"), replace(self.synthetic, amount=amount))

    def fit(self, sessions) -> NodeFamily:
        """The model trained on training sessions (a list of ``Recording``)."""
        from ..learned.node.data import SampleSpec  # optional extra: learn (PyTorch)
        from ..learned.node.train import train_node_model  # optional extra: learn (PyTorch)

        o = self.options
        sessions = list(sessions)
        model = self
        if self.on_physics:
            if not calibrated(self.physics):
                raise bad("on_physics", True, "a calibrated physics to learn what it leaves (Physics fitted), "
                                              "or False")
            anchor = np.mean(np.vstack([self.physics.predict(s) for s in sessions]), axis=0)
            low, high = command_range(sessions)
            model = replace(self, anchor=anchor, reach=InputDistance.of(sessions), low=low, high=high)
        fit_part, held = holdout_split(model._residual(sessions) if self.on_physics else sessions)
        spec = SampleSpec(node=1, neighbours=(), history=o.history, inputs="positions", wrench="none",
                          drive="actuation")
        taught = self._taught(fit_part)
        data = as_dataset(fit_part + taught, self.length)
        step = data.attrs["dt"]                  # the held rows read at it too, however they are paced
        # over the physics the node writes the residual itself, not its increment: integrated along a free
        # run, an increment's small bias adds up without bound, while a residual stays where the data put it
        config = {"lstm_units": o.units} | ({"output": "pose"} if self.on_physics else {})
        with tempfile.TemporaryDirectory() as folder:
            net = train_node_model(data, spec, config, o.training, folder,
                                   validation=as_dataset(held, self.length, step))
        return replace(model, model=net, step=step).anchored(self.physics, sessions)

    def predict(self, session: Recording) -> np.ndarray:
        """The tip (T, 3) [m] over ``session``, free running from its start on its inputs; NaN from the
        row where the run diverges (``learned.horizons.RolloutDiverged``) on (over the physics: where the
        residual's weight is not zero; elsewhere the physics' tip)."""
        from ..learned.horizons import RolloutDiverged  # optional extra: learn (PyTorch)
        from ..learned.node.rollout import rollout  # optional extra: learn (PyTorch)

        H = self.options.history
        start = session
        if self.on_physics:                      # from a zero residual, on the commands in their training range
            start = replace(session, tip=np.broadcast_to(self.anchor, session.tip.shape),
                            inputs=np.clip(session.inputs, self.low, self.high))
        data = as_dataset([start], self.length, self.step)
        tip = np.full((session.n_rows, 3), np.nan)
        tip[:H] = start.tip[:H]
        try:
            tip[H:] = rollout(self.model, data, H, session.n_rows).node_positions(1)
        except RolloutDiverged as err:
            if err.sample > H:                   # the rows before, from the same run stopped there
                tip[H:err.sample] = rollout(self.model, data, H, err.sample).node_positions(1)
        if not self.on_physics:
            return tip
        w = gate_weights(self.reach, self.gate, session)[:, None]
        with np.errstate(invalid="ignore"):      # a diverged run counts only where its weight is not zero
            return self.physics.predict(session) + np.where(w > 0.0, w * (tip - self.anchor), 0.0)

    def physics_weights(self, session: Recording) -> np.ndarray | None:
        """(T,) the residual's weight w per row over the physics (``gate_weights``; ``on_physics``), with which
        ``lab benchmark`` blends its interval with the physics' as the hybrid's; None without ``on_physics``."""
        return gate_weights(self.reach, self.gate, session) if self.on_physics else None

    def describe(self) -> dict:
        """What the model is and its options, JSON-ready."""
        out = {"kind": "per-node LSTM driven by the inputs alone (softrnn train --drive actuation)" +
                       (", of what the calibrated physics' tip leaves" if self.on_physics else "") +
                       (", gated off away from the training data" if self.on_physics and not math.isinf(self.gate)
                        else ""),
               **self.options.describe(), "mode": self.mode}
        if self.on_physics:
            out["gate_d0"] = None if math.isinf(self.gate) else self.gate
        if self.mode != "real":
            out["synthetic"] = self.synthetic.describe() | {"amount_x_real_rows": min(
                self.synthetic.amount, self.options.synthetic_amount)}
        return out | self.anchor_description()
