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
* ``LearnedMap``: a small network (an ensemble of MLPs) of the current and previous inputs, and optionally a
  hysteresis state (play operators of each input), to the tip: a static map with the path dependence of friction.
* ``Hybrid``: the calibrated physics plus a network of the same inputs and the physics' tip that predicts only
  what the physics misses.
* ``Sequence``: a recurrent network (GRU) reading the commands and the interval since the previous row, so it
  can represent lag, creep and hysteresis; it runs free from a zero state.
* ``NodeFamily``: softrnn's per-node LSTM (``softrnn.learned.node``) driven by the commands alone.

The errors of a prediction are ``softrnn.learned.metrics.tip_errors``. Options with more than one sensible value
(the ARX orders, the polynomial's degree and ridge, the hysteresis state) are chosen on a hold-out part of the
training sessions (``choose``), never on the session a model is reported on.
"""

from __future__ import annotations

import math
import tempfile
from dataclasses import dataclass, field, replace
from typing import Protocol

import numpy as np

from ..errors import SoftrnnInputError
from ..io.reader import Dataset
from ..learned.baselines import ConstantVelocity, Persistence, free_run
from ..learned.linear import LinearARX
from ..learned.metrics import tip_errors
from ..learned.node.train_config import TrainConfig
from .recording import Recording
from .tendon_robot import LENGTH_UNITS, Calibration, CalibrationOptions, TendonRobot, calibrate, session_resets

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
        """The tip (T, 3) [m] over ``session``, free running from its first ``history`` rows."""
        H, T = self.baseline.history, session.n_rows
        run = free_run(self.baseline, session.tip[:, None], None, H, T)[:, 0] if T > H else session.tip[H:]
        return np.concatenate([session.tip[:H], run])                              # (T, 3)

    def describe(self) -> dict:
        """What the model is and its options, JSON-ready."""
        return {"kind": self.kind}


@dataclass(frozen=True)
class ConstantVelocityFamily(PersistenceFamily):
    """The tip keeps the velocity of the session's first two rows (``learned.baselines.ConstantVelocity``)."""

    name: str = "constant_velocity"
    baseline, kind = ConstantVelocity(), "the first two rows' velocity kept"


@dataclass(frozen=True, eq=False)
class LinearARXFamily:
    """The tip as a linear ARX model of the commands (``learned.linear.LinearARX``, ``na`` tip lags,
    ``nb`` input lags), free running."""

    na: int = 1
    nb: int = 1
    name: str = "linear_arx"
    arx: LinearARX | None = None

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
        return self.arx.run(session.tip, session.inputs)

    def describe(self) -> dict:
        """What the model is and its options, JSON-ready."""
        return {"kind": "linear ARX, least squares, free running", "na": self.na, "nb": self.nb}


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

    def fit(self, sessions) -> Physics:
        """The model calibrated on training sessions (a list of ``Recording``, each solved from its start)."""
        q, tip = np.vstack([displacements(s) for s in sessions]), np.vstack([s.tip for s in sessions])
        cal = calibrate(self.robot, q, tip, self.options, progress=self.progress, start=self.start,
                        resets=session_resets([s.n_rows for s in sessions]))
        return replace(self, calibration=cal)

    def predict(self, session: Recording) -> np.ndarray:
        """The tip (T, 3) [m] over ``session``, free running from its start on its inputs."""
        return self.calibration.predict(displacements(session))

    def describe(self) -> dict:
        """What the model is and its options, JSON-ready."""
        return {"kind": "calibrated tendon robot physics", "variant": self.options.variant} | self.calibration.to_dict()


@dataclass(frozen=True)
class NetOptions:
    """The networks' size and training (``LearnedMap``, ``Hybrid``): an ensemble of two-layer tanh
    MLPs, averaged, each trained full batch with AdamW."""

    hidden: int = 64
    """Units in each of the two tanh layers."""
    members: int = 3
    """Networks in the ensemble."""
    steps: int = 1500
    """Full-batch AdamW steps per network."""
    lr: float = 3e-3
    """Learning rate."""
    weight_decay: float = 0.1
    """AdamW's weight decay."""
    seed: int = 0
    """Seed of member m: seed * 1000 + m."""


def _features(session: Recording, widths: np.ndarray | None) -> np.ndarray:
    u = session.inputs
    parts = [u, _previous(u)]
    if widths is not None:
        parts += [play(u, w) - u for w in widths]
    return np.hstack(parts)


class _Ensemble:
    """An ensemble of two-layer tanh MLPs, inputs standardised, targets scaled by their RMS."""

    def __init__(self, options: NetOptions):
        self.options = options
        self.members = []

    def fit(self, X: np.ndarray, Y: np.ndarray) -> _Ensemble:
        """Train the members on features ``X`` (M, F) and targets ``Y`` (M, D); returns itself."""
        import torch  # optional extra: learn (PyTorch)

        o = self.options
        self.mu, self.sd = X.mean(axis=0), X.std(axis=0) + 1e-9
        self.scale = float(np.sqrt(np.mean(Y ** 2))) or 1.0
        x = torch.tensor((X - self.mu) / self.sd, dtype=torch.float32)
        y = torch.tensor(Y / self.scale, dtype=torch.float32)
        for m in range(o.members):
            torch.manual_seed(o.seed * 1000 + m)
            net = torch.nn.Sequential(torch.nn.Linear(X.shape[1], o.hidden), torch.nn.Tanh(),
                                      torch.nn.Linear(o.hidden, o.hidden), torch.nn.Tanh(),
                                      torch.nn.Linear(o.hidden, Y.shape[1]))
            opt = torch.optim.AdamW(net.parameters(), lr=o.lr, weight_decay=o.weight_decay)
            for _ in range(o.steps):
                opt.zero_grad()
                loss = torch.mean((net(x) - y) ** 2)
                loss.backward()
                opt.step()
            self.members.append(net)
        return self

    def __call__(self, X: np.ndarray) -> np.ndarray:
        import torch  # optional extra: learn (PyTorch)

        with torch.no_grad():
            x = torch.tensor((X - self.mu) / self.sd, dtype=torch.float32)
            return np.mean([net(x).numpy() for net in self.members], axis=0).astype(float) * self.scale


def _widths(sessions, hysteresis: bool):
    if not hysteresis:
        return None
    u = np.vstack([s.inputs for s in sessions])
    return [f * np.ptp(u, axis=0) for f in PLAY_WIDTHS]


@dataclass(frozen=True, eq=False)
class LearnedMap:
    """A learned static map with input history: an MLP ensemble of (u_k, u_{k-1}[, hysteresis
    state]) to the tip."""

    hysteresis: bool = False
    options: NetOptions = NetOptions()
    name: str = "learned_map"
    net: object = None
    widths: object = None
    offset: np.ndarray | None = None

    def fit(self, sessions) -> LearnedMap:
        """The model fitted on training sessions (a list of ``Recording``)."""
        widths = _widths(sessions, self.hysteresis)
        X = np.vstack([_features(s, widths) for s in sessions])
        offset = np.mean(np.vstack([s.tip for s in sessions]), axis=0)
        Y = np.vstack([s.tip for s in sessions]) - offset
        return replace(self, widths=widths, offset=offset, net=_Ensemble(self.options).fit(X, Y))

    def predict(self, session: Recording) -> np.ndarray:
        """The tip (T, 3) [m] over ``session``, free running from its start on its inputs."""
        return self.net(_features(session, self.widths)) + self.offset

    def describe(self) -> dict:
        """What the model is and its options, JSON-ready."""
        return {"kind": "MLP ensemble of the current and previous inputs" +
                        (" and a hysteresis state (play operators)" if self.hysteresis else ""),
                **{k: v for k, v in vars(self.options).items()}}


@dataclass(frozen=True, eq=False)
class Hybrid:
    """Calibrated physics plus a learned residual: tip = physics(u_k) + MLP(u_k, u_{k-1}[,
    hysteresis state], physics(u_k)); ``physics`` fitted (calibrated) or to be fitted with it."""

    physics: Physics
    hysteresis: bool = False
    options: NetOptions = NetOptions()
    name: str = "hybrid"
    net: object = None
    widths: object = None

    def _X(self, s, base):
        return np.hstack([_features(s, self.widths), base])

    def fit(self, sessions) -> Hybrid:
        """The model fitted on training sessions (a list of ``Recording``)."""
        physics = self.physics if self.physics.calibration is not None else self.physics.fit(sessions)
        out = replace(self, physics=physics, widths=_widths(sessions, self.hysteresis))
        bases = [physics.predict(s) for s in sessions]
        X = np.vstack([out._X(s, b) for s, b in zip(sessions, bases)])
        Y = np.vstack([s.tip - b for s, b in zip(sessions, bases)])
        return replace(out, net=_Ensemble(self.options).fit(X, Y))

    def predict(self, session: Recording) -> np.ndarray:
        """The tip (T, 3) [m] over ``session``, free running from its start on its inputs."""
        base = self.physics.predict(session)
        return base + self.net(self._X(session, base))

    def describe(self) -> dict:
        """What the model is and its options, JSON-ready."""
        return {"kind": "calibrated physics + MLP residual" +
                        (" with a hysteresis state (play operators)" if self.hysteresis else ""),
                **{k: v for k, v in vars(self.options).items()}}


@dataclass(frozen=True)
class SequenceOptions:
    """The recurrent model (``Sequence``) and its training with AdamW."""

    hidden: int = 32
    """GRU units."""
    window: int = 64
    """Rows per training window (the state carried from the session's start through the windows before)."""
    epochs: int = 300
    """Passes over the sessions, or fewer where that would take more than ``max_steps``."""
    max_steps: int = 6000
    """Most optimiser steps (long recordings)."""
    lr: float = 3e-3
    """Learning rate."""
    weight_decay: float = 1e-3
    """AdamW's weight decay."""
    seed: int = 0
    """PyTorch's seed."""


@dataclass(frozen=True, eq=False)
class Sequence:
    """A GRU reading (u_k, u_k - u_{k-1}, log of the interval since the previous row [s]) and
    writing the tip: a dynamic model of the commands alone, run free from a zero state."""

    options: SequenceOptions = SequenceOptions()
    name: str = "sequence"
    net: object = None
    offset: np.ndarray | None = None
    mu: np.ndarray | None = None
    sd: np.ndarray | None = None
    scale: float = 1.0

    def _inputs(self, s: Recording) -> np.ndarray:
        u = s.inputs
        dt = np.concatenate([[np.median(np.diff(s.time))], np.diff(s.time)])
        return np.hstack([u, u - _previous(u), np.log(dt)[:, None]])

    def fit(self, sessions) -> Sequence:
        """The model fitted on training sessions (a list of ``Recording``)."""
        import torch  # optional extra: learn (PyTorch)

        torch.manual_seed(self.options.seed)
        offset = np.mean(np.vstack([s.tip for s in sessions]), axis=0)
        X = [self._inputs(s) for s in sessions]
        Y = [s.tip - offset for s in sessions]
        allX = np.vstack(X)
        mu, sd = allX.mean(axis=0), allX.std(axis=0) + 1e-9
        scale = float(np.sqrt(np.mean(np.vstack(Y) ** 2))) or 1.0
        xs = [torch.tensor((x - mu) / sd, dtype=torch.float32)[None] for x in X]
        ys = [torch.tensor(y / scale, dtype=torch.float32)[None] for y in Y]
        return replace(self, net=_train_gru(self.options, xs, ys, allX.shape[1]), offset=offset, mu=mu, sd=sd,
                       scale=scale)

    def predict(self, session: Recording) -> np.ndarray:
        """The tip (T, 3) [m] over ``session``, free running from its start on its inputs."""
        import torch  # optional extra: learn (PyTorch)

        gru, head = self.net
        with torch.no_grad():
            out, _ = gru(torch.tensor((self._inputs(session) - self.mu) / self.sd, dtype=torch.float32)[None])
            y = head(out)[0].numpy().astype(float) * self.scale
        return y + self.offset

    def describe(self) -> dict:
        """What the model is and its options, JSON-ready."""
        return {"kind": "GRU of the commands and intervals", **{k: v for k, v in vars(self.options).items()}}


def _train_gru(o: SequenceOptions, xs: list, ys: list, n_inputs: int) -> tuple:
    """(GRU, linear head) trained on the sessions' standardised inputs ``xs`` and scaled tips ``ys``
    (each a (1, T, .) float32 tensor), windows of ``o.window`` rows carrying the state."""
    import torch  # optional extra: learn (PyTorch)

    gru = torch.nn.GRU(n_inputs, o.hidden, batch_first=True)
    head = torch.nn.Linear(o.hidden, 3)
    params = list(gru.parameters()) + list(head.parameters())
    opt = torch.optim.AdamW(params, lr=o.lr, weight_decay=o.weight_decay)
    per_epoch = sum(-(-x.shape[1] // o.window) for x in xs)
    for _ in range(max(1, min(o.epochs, o.max_steps // per_epoch))):
        for x, y in zip(xs, ys):
            h = None
            for a in range(0, x.shape[1], o.window):
                out, h = gru(x[:, a:a + o.window], h)
                loss = torch.mean((head(out) - y[:, a:a + o.window]) ** 2)
                opt.zero_grad()
                loss.backward()
                opt.step()
                h = h.detach()
    return gru, head


# ------------------------------------------------------------------------------------------- choice
def holdout_split(sessions) -> tuple[list, list]:
    """Training sessions split for choosing options: with two or more sessions, the last one is
    held out; with one, its last quarter (the rows in order, so the hold-out part is a later,
    unseen stretch of the session)."""
    sessions = list(sessions)
    if len(sessions) >= 2:
        return sessions[:-1], sessions[-1:]
    s = sessions[0]
    cut = int(round(0.75 * s.n_rows))

    def part(a, b):
        return replace(s, time=s.time[a:b], inputs=s.inputs[a:b], tip=s.tip[a:b],
                       labels=s.labels[a:b] if s.labels else ())
    return [part(0, cut)], [part(cut, s.n_rows)]


@dataclass(frozen=True)
class Choice:
    """The option chosen for a family and the hold-out scores of each candidate [mm]."""

    chosen: object
    scores: dict = field(default_factory=dict)


def choose(candidates: dict, sessions) -> Choice:
    """Fit each candidate (``{label: factory() -> model}``) on the fitting part of ``sessions``
    and score its free run on the hold-out part (Euclidean tip RMSE [mm]); the best label wins."""
    fit_part, held = holdout_split(sessions)
    scores = {}
    for label, factory in candidates.items():
        model = factory().fit(fit_part)
        pred = np.vstack([model.predict(s) for s in held])
        ref = np.vstack([s.tip for s in held])
        score = tip_errors(pred, ref).rmse_mm
        scores[label] = score if math.isfinite(score) else math.inf
    return Choice(chosen=min(scores, key=scores.get), scores=scores)


# ---------------------------------------------------------------------------------- the node model
def as_dataset(sessions, length: float):
    """The sessions as one ``softrnn.io.Dataset`` of the tip (node 1 of a 2-node rod of ``length``
    [m]) and the inputs as actuation channels: the rows in order, each later session's times
    shifted to follow the previous one's last row by the median interval. The node model reads the
    rows as steps of the median interval (``dt``)."""
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
                          "dt": float(np.median(np.diff(time))), "has_orientations": False},
                   actuation=np.vstack([s.inputs for s in sessions]).astype(np.float32),
                   actuation_units={n: (u or "1") for n, u in zip(first.names, first.units)})


NODE_TRAINING = TrainConfig(rollout_steps=8, epochs=60, patience=20)
"""The lab's training of the node LSTM (those of the lab workflow guide): 8 steps of the multi-step
loss, at most 60 epochs, 20 epochs' patience on the hold-out part; ``dataclasses.replace`` it to
change one."""


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

    def describe(self) -> dict:
        """The options, JSON-ready: the window, the size and the training settings the lab sets."""
        t = self.training
        return {"history": self.history, "units": self.units, "rollout_steps": t.rollout_steps,
                "epochs": t.epochs, "patience": t.patience, "seed": t.seed}


@dataclass(frozen=True, eq=False)
class NodeFamily:
    """softrnn's per-node LSTM (``softrnn train --drive actuation``, the paper's model driven by the
    inputs alone): trained on the first part of the training sessions and stopped early on the
    hold-out part (``holdout_split``), run free over a session from its first ``history`` rows
    (the recorded tips there are its initial condition)."""

    length: float
    options: NodeOptions = NodeOptions()
    name: str = "node_lstm"
    model: object = None

    def fit(self, sessions) -> NodeFamily:
        """The model trained on training sessions (a list of ``Recording``)."""
        from ..learned.node.data import SampleSpec  # optional extra: learn (PyTorch)
        from ..learned.node.train import train_node_model  # optional extra: learn (PyTorch)

        o = self.options
        fit_part, held = holdout_split(sessions)
        spec = SampleSpec(node=1, neighbours=(), history=o.history, inputs="positions", wrench="none",
                          drive="actuation")
        with tempfile.TemporaryDirectory() as folder:
            model = train_node_model(as_dataset(fit_part, self.length), spec, {"lstm_units": o.units}, o.training,
                                     folder, validation=as_dataset(held, self.length))
        return replace(self, model=model)

    def predict(self, session: Recording) -> np.ndarray:
        """The tip (T, 3) [m] over ``session``, free running from its start on its inputs."""
        from ..learned.node.rollout import rollout  # optional extra: learn (PyTorch)

        H = self.options.history
        data = as_dataset([session], self.length)
        result = rollout(self.model, data, H, session.n_rows)
        return np.vstack([session.tip[:H], result.node_positions(1)])

    def describe(self) -> dict:
        """What the model is and its options, JSON-ready."""
        return {"kind": "per-node LSTM driven by the inputs alone (softrnn train --drive actuation)",
                **self.options.describe()}
