"""The learned model families of a robot's recordings, taught by the calibrated physics where the
recordings do not reach.

* ``LearnedMap``: an ensemble of MLPs of the current and previous inputs (and optionally a hysteresis
  state, play operators of each input) to the tip: a static map with the path dependence of friction.
* ``Hybrid``: the calibrated physics plus an MLP ensemble of the same inputs and the physics' tip that
  predicts what the physics misses, its contribution gated off away from the training data (``gate``
  d0: w = exp(-(d / d0)^2), d the distance of the row's standardised inputs to the nearest training
  row), so that out of range the hybrid is its physics.
* ``Sequence``: a GRU reading the commands and the interval since the previous row (lag, creep,
  hysteresis), and optionally the hysteresis state of the map; it runs free from a zero state. With
  ``linear``, it learns what a linear ARX model of the commands, run free from rest, leaves: the
  robot's linear dynamics (a lightly damped swing, a slow settling) from the linear model, fitted by
  least squares on every row, and the nonlinear rest from the GRU. With ``on_physics``, it learns what
  the calibrated physics leaves, the physics' tip its base in the same way.

Physics-pretrained learning (``mode``): with a fitted ``physics`` (``families.Physics``) and
``SyntheticOptions``, a family draws synthetic sessions from the physics (``synthetic_sessions``) and
learns from them and the real rows: ``finetune`` trains on the synthetic sessions, then continues on
the real rows; ``mixed`` trains once on both, the synthetic rows weighing ``weight`` against all the
real ones (for the hybrid they teach a zero residual where no real row is); ``real`` ignores them.
The benchmark chooses the mode, the hysteresis state and the gate on the training hold-out; the map
and the hybrid also try ``mixed`` on four times the synthetic rows (``DENSE_MODE``).

Every family states a 90 % interval per row (``predict_interval``, ``softrnn.lab.uncertainty``): an
error scale (the map's ensemble spread plus its training error, for the hybrid its physics' refit
spread plus its ensemble's spread where the residual acts, for the sequence model and the node LSTM
their distance from the physics' tip plus the physics' RMS error over the training rows,
``families.Anchored``; 1 without a calibrated physics) times
q + b max(0, d - d0), d the distance from the training rows, q, b and d0 calibrated on the hold-out
split (``uncertainty.calibrate``).
"""

from __future__ import annotations

import copy
import math
import zlib
from contextlib import contextmanager
from dataclasses import dataclass, field, replace

import numpy as np

from ..errors import bad, integer
from .families import (
    PHYSICS_GAP,
    PLAY_WIDTHS,
    Anchored,
    LinearARXFamily,
    NodeFamily,
    Physics,
    _previous,
    calibrated,
    choose,
    command_range,
    gate_weights,
    held_rows,
    holdout_split,
    parsimonious,
    play,
    with_physics_gap,
)
from .recording import Recording
from .synthetic import SyntheticOptions, taught_sessions
from .uncertainty import InputDistance, Intervals, RefitSpread, WithInterval, calibrate

"""How a family uses the physics' synthetic sessions (module docstring)."""
GATES = (0.5, 1.0, 2.0, 4.0, 8.0)
"""The hybrid's gate widths d0 tried on the hold-out, in standardised input units: all finite, so that
whichever wins, the residual falls to zero away from the training rows and the hybrid follows its
physics there (an ungated residual, d0 = inf, can still be built by hand)."""


@dataclass(frozen=True)
class NetOptions:
    """The networks' size and training (``LearnedMap``, ``Hybrid``): an ensemble of two-layer tanh
    MLPs, averaged, each trained with AdamW on all its rows per step, or on a random draw of ``batch``
    of them where it has more."""

    hidden: int = 64
    """Units in each of the two tanh layers."""
    members: int = 3
    """Networks in the ensemble."""
    steps: int = 1500
    """AdamW steps per network (and again for the fine-tuning on the real rows)."""
    batch: int = 2048
    """Most rows per step: a recording of more rows (a dynamic arm at 20 Hz: 15,000) takes a random draw
    of this many at each step, a step then costs what it costs on this many rows, and the steps together
    still see every row many times over (1,500 x 2,048 rows); fewer rows are taken whole."""
    lr: float = 3e-3
    """Learning rate."""
    weight_decay: float = 0.1
    """AdamW's weight decay."""
    seed: int = 0
    """Seed of member m: seed * 1000 + m."""

    def __post_init__(self):
        for name in ("hidden", "members", "steps", "batch"):
            integer(name, getattr(self, name), 1)


BEYOND_GATE = {"interval_90_beyond_gate": "the physics' interval: the radius (1 - w) r_physics + w r_own, w the "
                                         "learned part's weight"}
"""What a model that follows its physics (``FollowsPhysics``) with the physics' interval says of it, JSON-ready."""


def follow_physics(w: np.ndarray, physics: np.ndarray, own: np.ndarray) -> np.ndarray:
    """(T,) [m] the radius (1 - w) r_physics + w r_own per row: the physics' ball ``physics`` (T,) [m] where the
    learned part's weight ``w`` (T,) is 0, the model's own ``own`` (T,) [m] where it is 1; an unbounded radius
    counts only where its weight is not zero."""
    with np.errstate(invalid="ignore"):
        return np.where(w < 1.0, (1.0 - w) * physics, 0.0) + np.where(w > 0.0, w * own, 0.0)


class FollowsPhysics(Intervals):
    """What a model shares that is its calibrated physics where the weight w of its learned part falls to 0
    (``Hybrid``; ``Sequence`` over the physics): with ``physics_interval``, its physics with the physics' own
    calibrated 90 % interval (``uncertainty.with_interval``, as ``lab benchmark`` scores the physics), the
    radius is (1 - w) r_physics + w r_own per row. Where the gate is off the model is its physics, and so
    is its interval; its own q and b, calibrated where its learned part acts and errs on patterns it did
    not see, would widen the physics' ball there."""

    physics_interval: object

    def physics_weights(self, session: Recording) -> np.ndarray | None:
        """(T,) the learned part's weight w in [0, 1] per row, or None: the model does not follow a physics."""
        return None

    def predict_interval(self, session: Recording) -> tuple[np.ndarray, np.ndarray]:
        """The tip (T, 3) [m] and the radius (T,) [m] of its 90 % ball: its own (``Intervals``), or with
        ``physics_interval`` (1 - w) r_physics + w r_own (``physics_weights``)."""
        tip, own = super().predict_interval(session)
        w = None if self.physics_interval is None else self.physics_weights(session)
        if w is None:
            return tip, own
        return tip, follow_physics(w, self.physics_interval.predict_interval(session)[1], own)

    def follows_description(self) -> dict:
        """The interval's blend with the physics', JSON-ready ({} without ``physics_interval``)."""
        return {} if self.physics_interval is None else dict(BEYOND_GATE)


def _play_state(u: np.ndarray, widths) -> list:
    """The hysteresis state of the inputs ``u`` (T, m): each play operator's output less ``u``, one (T, m)
    per width of ``widths`` ([] for None)."""
    return [] if widths is None else [play(u, w) - u for w in widths]


def _features(session: Recording, widths: np.ndarray | None) -> np.ndarray:
    u = session.inputs
    return np.hstack([u, _previous(u)] + _play_state(u, widths))


class _Ensemble:
    """An ensemble of two-layer tanh MLPs, inputs standardised, targets scaled by their RMS."""

    def __init__(self, options: NetOptions):
        self.options = options
        self.members = []

    def fit(self, X: np.ndarray, Y: np.ndarray, pool: tuple | None = None, weight: float = 0.0,
            batch: int | None = None, warm: bool = False) -> _Ensemble:
        """Train the members on features ``X`` (M, F) and targets ``Y`` (M, D), each step on a random
        ``batch`` of their rows (None: all), at most the options' ``batch``, plus ``weight`` times the loss
        on a random batch of the rows of ``pool`` (Xp, Yp) as large; ``warm``: continue training the
        members (and keep the scaling) from an earlier ``fit``. Returns itself."""
        import torch  # optional extra: learn (PyTorch)

        o = self.options
        with _serial():
            if not warm:
                both = X if pool is None else np.vstack([X, pool[0]])
                self.mu, self.sd = both.mean(axis=0), both.std(axis=0) + 1e-9
                self.scale = float(np.sqrt(np.mean(Y ** 2))) or 1.0
                self.members = []
                for m in range(o.members):
                    torch.manual_seed(o.seed * 1000 + m)
                    self.members.append(torch.nn.Sequential(
                        torch.nn.Linear(X.shape[1], o.hidden), torch.nn.Tanh(), torch.nn.Linear(o.hidden, o.hidden),
                        torch.nn.Tanh(), torch.nn.Linear(o.hidden, Y.shape[1])))
            x, y = self._tensors(X, Y)
            xp, yp = self._tensors(*pool) if pool is not None else (None, None)
            size = min(batch or len(X), o.batch, len(X))
            draw = torch.Generator().manual_seed(o.seed)
            for net in self.members:
                opt = torch.optim.AdamW(net.parameters(), lr=o.lr, weight_decay=o.weight_decay)
                for _ in range(o.steps):
                    opt.zero_grad()
                    rows = torch.randint(len(X), (size,), generator=draw) if size < len(X) else slice(None)
                    loss = torch.mean((net(x[rows]) - y[rows]) ** 2)
                    if xp is not None:
                        k = torch.randint(len(xp), (min(size, len(xp)),), generator=draw)
                        loss = loss + weight * torch.mean((net(xp[k]) - yp[k]) ** 2)
                    loss.backward()
                    opt.step()
        return self

    def _tensors(self, X, Y):
        import torch  # optional extra: learn (PyTorch)

        return (torch.tensor((X - self.mu) / self.sd, dtype=torch.float32),
                torch.tensor(Y / self.scale, dtype=torch.float32))

    def outputs(self, X: np.ndarray) -> np.ndarray:
        """(members, M, D) every member's output for features ``X`` (M, F), in the targets' units."""
        import torch  # optional extra: learn (PyTorch)

        with torch.no_grad(), _serial():
            x = torch.tensor((X - self.mu) / self.sd, dtype=torch.float32)
            return np.stack([net(x).numpy() for net in self.members]).astype(float) * self.scale

    def __call__(self, X: np.ndarray) -> np.ndarray:
        return self.outputs(X).mean(axis=0)

    def spread(self, X: np.ndarray) -> np.ndarray:
        """(M,) the members' RMS Euclidean distance from their mean, in the targets' units."""
        out = self.outputs(X)
        return np.sqrt(np.mean(np.sum((out - out.mean(axis=0)) ** 2, axis=2), axis=0))


def _widths(sessions, hysteresis: bool):
    if not hysteresis:
        return None
    u = np.vstack([s.inputs for s in sessions])
    return [f * np.ptp(u, axis=0) for f in PLAY_WIDTHS]


def _train(options: NetOptions, mode: str, weight: float, real: tuple, synthetic: tuple) -> _Ensemble:
    """An ensemble trained on (X, Y) of the real rows and of the synthetic rows as ``mode`` says; the
    synthetic rows are drawn in batches as large as the real rows, so a step costs about the same."""
    (Xr, Yr), (Xs, Ys) = real, synthetic
    net = _Ensemble(options)
    if mode == "finetune":
        return net.fit(Xs, Ys, batch=len(Xr)).fit(Xr, Yr, warm=True)
    if mode == "mixed":
        return net.fit(Xr, Yr, pool=(Xs, Ys), weight=weight)
    return net.fit(Xr, Yr)


@contextmanager
def _serial():
    """PyTorch on one thread inside (small networks on a shared machine), the caller's count after."""
    import torch  # optional extra: learn (PyTorch)

    old = torch.get_num_threads()
    torch.set_num_threads(1)
    try:
        yield
    finally:
        torch.set_num_threads(old)


def _pretraining(family) -> dict:
    out = {"mode": family.mode}
    if family.mode != "real":
        out["synthetic"] = family.synthetic.describe()
    if family.interval_q is not None:         # inf (too few hold-out rows for the quantile): null
        out |= family.interval_description()
    return out


@dataclass(frozen=True, eq=False)
class LearnedMap(Intervals):
    """A learned static map with input history: an MLP ensemble of (u_k, u_{k-1}[, hysteresis
    state]) to the tip; ``mode``, ``synthetic``, ``physics``: its physics pretraining (module docstring)."""

    hysteresis: bool = False
    options: NetOptions = NetOptions()
    mode: str = "real"
    synthetic: SyntheticOptions = SyntheticOptions()
    physics: Physics | None = None
    name: str = "learned_map"
    net: object = None
    widths: object = None
    offset: np.ndarray | None = None
    floor: float = 0.0
    reach: InputDistance | None = None
    interval_q: float | None = None
    interval_slope: float | None = None
    interval_knee: float = 0.0

    def fit(self, sessions) -> LearnedMap:
        """The model fitted on training sessions (a list of ``Recording``)."""
        sessions = list(sessions)
        syn = taught_sessions(self, sessions)
        widths = _widths(sessions, self.hysteresis)
        offset = np.mean(np.vstack([s.tip for s in sessions]), axis=0)

        def data(group):
            return (np.vstack([_features(s, widths) for s in group]) if group else None,
                    np.vstack([s.tip for s in group]) - offset if group else None)
        net = _train(self.options, self.mode, self.synthetic.weight, data(sessions), data(syn))
        out = replace(self, widths=widths, offset=offset, net=net, reach=InputDistance.of(sessions))
        err = np.concatenate([np.linalg.norm(out.predict(s) - s.tip, axis=1) for s in sessions])
        return replace(out, floor=float(np.sqrt(np.mean(err ** 2))) + 1e-9)

    def predict(self, session: Recording) -> np.ndarray:
        """The tip (T, 3) [m] over ``session``, free running from its start on its inputs."""
        return self.net(_features(session, self.widths)) + self.offset

    def error_scale(self, session: Recording) -> np.ndarray:
        """(T,) [m] the training RMS error plus the ensemble's spread, s; with a calibrated ``physics``
        (fitted on the same rows), sqrt(s^2 + |tip - physics' tip|^2): the ensemble's members agree where
        no training row sets them (combinations of commands the rows do not show) and are wrong together
        there, where the physics, fitted with the robot's form, tells the map apart (as the baselines'
        ``uncertainty.PhysicsGap``). A row where either run is not finite gets an unbounded scale."""
        own = self.floor + self.net.spread(_features(session, self.widths))
        if not calibrated(self.physics):
            return own
        return with_physics_gap(own, self.predict(session), self.physics, session)

    def describe(self) -> dict:
        """What the model is and its options, JSON-ready."""
        return {"kind": "MLP ensemble of the current and previous inputs" +
                        (" and a hysteresis state (play operators)" if self.hysteresis else ""),
                **{k: v for k, v in vars(self.options).items()}, **_pretraining(self),
                "error_scale": "training RMS error plus the ensemble's spread" + (
                    ", and " + PHYSICS_GAP if calibrated(self.physics) else "")}


@dataclass(frozen=True, eq=False)
class Hybrid(FollowsPhysics):
    """Calibrated physics plus a gated learned residual: tip = physics(u_k) + w(u_k) MLP(u_k, u_{k-1}[,
    hysteresis state], physics(u_k)), w = exp(-(d / ``gate``)^2) with d the distance of the
    standardised u_k to the nearest training row (``gate`` inf: w = 1); ``physics`` fitted
    (calibrated) or to be fitted with it; ``mode`` ``real`` or ``mixed`` (module docstring)."""

    physics: Physics
    hysteresis: bool = False
    options: NetOptions = NetOptions()
    mode: str = "real"
    synthetic: SyntheticOptions = SyntheticOptions()
    gate: float = math.inf
    name: str = "hybrid"
    net: object = None
    widths: object = None
    reach: InputDistance | None = None
    sessions: tuple = ()
    """The training sessions (``Recording``) it was fitted on: its physics' refits (``error_scale``)."""
    interval_q: float | None = None
    interval_slope: float | None = None
    interval_knee: float = 0.0
    memo: dict = field(default_factory=dict, init=False, repr=False)
    """Its physics' refits (``RefitSpread``), made the first time ``error_scale`` is asked for."""
    physics_interval: object = None
    """Its physics with the physics' own 90 % interval, or None (``FollowsPhysics``)."""

    def _X(self, s, base):
        return np.hstack([_features(s, self.widths), base])

    def fit(self, sessions) -> Hybrid:
        """The model fitted on training sessions (a list of ``Recording``)."""
        sessions = list(sessions)
        physics = self.physics if self.physics.calibration is not None else self.physics.fit(sessions)
        out = replace(self, physics=physics, widths=_widths(sessions, self.hysteresis))
        syn = taught_sessions(out, sessions, ("real", "mixed"))      # its synthetic residual is zero: no pretraining

        def data(group):
            if not group:
                return None, None
            bases = [physics.predict(s) for s in group]
            return (np.vstack([out._X(s, b) for s, b in zip(group, bases)]),
                    np.vstack([s.tip - b for s, b in zip(group, bases)]))
        return replace(out, net=_train(self.options, self.mode, self.synthetic.weight, data(sessions), data(syn)),
                       reach=InputDistance.of(sessions), sessions=tuple(sessions))

    def refit(self, sessions) -> Hybrid:
        """The model fitted on ``sessions`` with its physics refitted there too (``Physics.refit``, from
        its calibration): the cross-fit's refit (``uncertainty.cross_fit``) sees the physics' own error
        on the rows it holds out."""
        return replace(self, physics=self.physics.refit(list(sessions))).fit(sessions)

    def weights(self, session: Recording) -> np.ndarray:
        """(T,) the residual's weight w in [0, 1] per row: 1 on a training row, falling to 0 away from them."""
        return gate_weights(self.reach, self.gate, session)

    def predict(self, session: Recording) -> np.ndarray:
        """The tip (T, 3) [m] over ``session``, free running from its start on its inputs."""
        base = self.physics.predict(session)
        return base + self.weights(session)[:, None] * self.net(self._X(session, base))

    def error_scale(self, session: Recording) -> np.ndarray:
        """(T,) [m] the physics' error scale, the spread of its refits without each block of the training
        patterns with its RMS error over the training rows (``uncertainty.RefitSpread``, made here the
        first time), plus the ensemble's spread w s where the residual acts. The hybrid is its physics
        plus a small correction: where the gate is off it is the physics, and near the data the new
        patterns' error is the physics' own, which the hybrid's error on its training rows understates."""
        if "refits" not in self.memo:
            self.memo["refits"] = RefitSpread.of(self.physics, list(self.sessions))
        w = self.weights(session)
        spread = self.net.spread(self._X(session, self.physics.predict(session)))
        return self.memo["refits"].error_scale(session) + w * spread

    def physics_weights(self, session: Recording) -> np.ndarray:
        """(T,) the residual's weight (``weights``): where it is 0 the hybrid is its physics."""
        return self.weights(session)

    def describe(self) -> dict:
        """What the model is and its options, JSON-ready."""
        return {"kind": "calibrated physics + MLP residual" +
                        (" with a hysteresis state (play operators)" if self.hysteresis else "") +
                        (", gated off away from the training data" if not math.isinf(self.gate) else ""),
                **{k: v for k, v in vars(self.options).items()}, **_pretraining(self),
                "gate_d0": None if math.isinf(self.gate) else self.gate,
                "error_scale": "the physics' refit spread (jackknife, with the refits' median error over the rows "
                               "each was fitted without) plus the ensemble's spread where the residual acts",
                **self.follows_description()}


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
    """Most optimiser steps (long recordings; the pretraining on synthetic sessions has half as many)."""
    lane_windows: int = 2
    """Most windows per lane: each session is cut into contiguous lanes of this many windows, trained side
    by side (``_train_gru``), so that an epoch takes at most this many steps however long the sessions
    are, each about as costly as one window alone."""
    state_runs: int = 20
    """Epochs between the runs of the whole sessions (without gradients) that give each lane the state at
    its first row; in the epochs between, a lane starts from the state the lane before it in its session
    reached at its last row in the epoch before (a long session's run costs a step per row)."""
    lr: float = 3e-3
    """Learning rate."""
    weight_decay: float = 1e-3
    """AdamW's weight decay."""
    seed: int = 0
    """PyTorch's seed."""

    def __post_init__(self):
        for name in ("hidden", "window", "epochs", "max_steps", "lane_windows", "state_runs"):
            integer(name, getattr(self, name), 1)


LINEAR_ORDERS = (2, 4, 8, 16)
"""The orders n (na = nb = n rows) of the ``Sequence`` model's linear base tried on the hold-out, simplest
first."""


def linear_base(sessions, order: int | None = None) -> tuple[LinearARXFamily, dict]:
    """The linear base of a ``Sequence`` model fitted on ``sessions`` (a list of ``Recording``): a linear
    ARX model of the tip driven by the commands, na = nb = ``order`` rows, run free from rest
    (``families.LinearARXFamily``, ``from_rest``); ``order`` None: the order of ``LINEAR_ORDERS`` chosen on
    a hold-out of ``sessions`` (``families.choose``: the simplest whose free run over the held rows is
    within one standard error of the best), among those that the fitting part has at least twice as
    many rows as coefficients for. Returns (the base, {candidate: hold-out RMSE [mm]})."""
    sessions = list(sessions)
    if order is not None:
        return LinearARXFamily(order, order, from_rest=True).fit(sessions), {}
    split = holdout_split(sessions)
    m = sessions[0].n_inputs

    def enough(n):
        return sum(max(0, s.n_rows - n) for s in split[0]) >= 2 * (n * (3 + m) + 1)
    orders = [n for n in LINEAR_ORDERS if enough(n)] or list(LINEAR_ORDERS[:1])
    c = choose({f"order={n}": (lambda n=n: LinearARXFamily(n, n, from_rest=True)) for n in orders}, sessions, split)
    n = int(c.chosen.split("=")[1])
    return LinearARXFamily(n, n, from_rest=True).fit(sessions), c.scores


@dataclass(frozen=True, eq=False)
class Sequence(Anchored, FollowsPhysics):
    """A GRU reading (u_k, u_k - u_{k-1}, log of the interval since the previous row [s][, hysteresis
    state: the play operators of each input, as ``LearnedMap``'s]) and writing the tip: a dynamic model
    of the commands alone, run free from a zero state; ``mode`` ``real`` or ``finetune`` (pretrained on
    the physics' synthetic sessions, module docstring). With
    ``linear``, the tip is a linear model's free run from rest (``base``, ``linear_base``) plus the GRU's
    output, the base's tip one more of the GRU's inputs; with ``on_physics``, the same over the fitted
    ``physics``' tip (the GRU learns what the physics leaves). With a fitted ``physics``, its error scale is
    its distance from the physics' tip plus the physics' RMS error over the training rows
    (``error_scale``)."""

    options: SequenceOptions = SequenceOptions()
    mode: str = "real"
    synthetic: SyntheticOptions = SyntheticOptions()
    physics: Physics | None = None
    name: str = "sequence"
    net: object = None
    offset: np.ndarray | None = None
    mu: np.ndarray | None = None
    sd: np.ndarray | None = None
    scale: float = 1.0
    reach: InputDistance | None = None
    interval_q: float | None = None
    interval_slope: float | None = None
    interval_knee: float = 0.0
    pretrained: object = None
    physics_rms: float | None = None
    """The physics' RMS tip error [m] over the training rows (``error_scale``; None without a fitted physics)."""
    linear: bool = False
    """Whether the GRU learns what a linear model of the commands leaves (``base``)."""
    on_physics: bool = False
    """Whether the GRU learns what the fitted ``physics`` leaves: its tip is the base, as a linear model's
    is with ``linear``."""
    gate: float = math.inf
    """With ``on_physics``: the GRU's part weighs w = exp(-(d / gate)^2) per row (``gate_weights``, the
    hybrid's gate), so that away from the training rows the model is its physics; inf: not gated."""
    hysteresis: bool = False
    """Whether the GRU also reads the hysteresis state (play operators of each input, ``widths``): friction's
    path dependence, which a GRU learns poorly from the commands alone."""
    widths: object = None
    """The play operators' widths (``PLAY_WIDTHS`` of each input's range over the training rows; None
    without ``hysteresis``)."""
    base: LinearARXFamily | None = None
    """The fitted linear base (``linear_base``; None before the fit and without ``linear``); a refit keeps
    its order."""
    base_scores: dict = field(default_factory=dict)
    """The hold-out scores of the base's orders {candidate: tip RMSE [mm]} (``linear_base``)."""
    physics_interval: object = None
    """With ``on_physics``: its physics with the physics' own 90 % interval, or None (``FollowsPhysics``)."""
    low: np.ndarray | None = None
    high: np.ndarray | None = None
    """With ``on_physics``: (m,) the training rows' least and greatest command of each input, the range the
    GRU reads them clipped to (``families.command_range``; None: not clipped). Its state carries from row
    to row, so a command no training row reached (a servo held still through the training, moved later)
    would drive it where no row took it and spoil the rows after it, where the gate lets it act again;
    the physics reads the commands as they are."""

    def __post_init__(self):
        if self.linear and self.on_physics:
            raise bad("linear", True, "linear=False with on_physics=True: the base is the physics' tip or a "
                                      "linear model's, not both")

    def _base(self, s: Recording) -> np.ndarray:
        """(T, 3) [m] the base's tip over ``s``: the physics' (``on_physics``), the linear base's, or zeros."""
        if self.on_physics:
            return self.physics.predict(s)
        return np.zeros((s.n_rows, 3)) if self.base is None else self.base.predict(s)

    def _inputs(self, s: Recording, base: np.ndarray) -> np.ndarray:
        u = s.inputs if self.low is None else np.clip(s.inputs, self.low, self.high)
        dt = np.concatenate([[np.median(np.diff(s.time))], np.diff(s.time)])
        return np.hstack([u, u - _previous(u), np.log(dt)[:, None]] + _play_state(u, self.widths) +
                         ([base] if self.linear or self.on_physics else []))

    def fit(self, sessions) -> Sequence:
        """The model fitted on training sessions (a list of ``Recording``): in mode ``finetune``
        pretrained on the physics' synthetic sessions, then trained on the real rows; the pretrained
        network is kept (``pretrained``) for ``refit``."""
        import torch  # optional extra: learn (PyTorch)

        sessions = list(sessions)
        if self.on_physics and not calibrated(self.physics):
            raise bad("on_physics", True, "a calibrated physics to learn what it leaves (Physics fitted), or False")
        syn = taught_sessions(self, sessions, ("real", "finetune"))
        model = replace(self._with_base(sessions), widths=_widths(sessions, self.hysteresis),
                        **self._range(sessions))
        torch.manual_seed(self.options.seed)
        bases = [model._base(s) for s in sessions + syn]
        offset = np.mean(np.vstack([s.tip - b for s, b in zip(sessions, bases)]), axis=0)
        X = [model._inputs(s, b) for s, b in zip(sessions + syn, bases)]
        Y = [s.tip - b - offset for s, b in zip(sessions + syn, bases)]
        allX = np.vstack(X)
        mu, sd = allX.mean(axis=0), allX.std(axis=0) + 1e-9
        scale = float(np.sqrt(np.mean(np.vstack(Y) ** 2))) or 1.0
        xs = [torch.tensor((x - mu) / sd, dtype=torch.float32)[None] for x in X]
        ys = [torch.tensor(y / scale, dtype=torch.float32)[None] for y in Y]
        n = len(sessions)
        pretrained = None
        with _serial():
            if syn:
                pre = replace(self.options, max_steps=self.options.max_steps // 2)
                pretrained = _train_gru(pre, xs[n:], ys[n:], allX.shape[1])
            net = _train_gru(self.options, xs[:n], ys[:n], allX.shape[1], copy.deepcopy(pretrained))
        return replace(model, net=net, offset=offset, mu=mu, sd=sd, scale=scale, reach=InputDistance.of(sessions),
                       pretrained=pretrained).anchored(self.physics, sessions)

    def _range(self, sessions) -> dict:
        """{"low": ..., "high": ...}: the command range of ``sessions`` that the GRU reads its commands
        clipped to (``on_physics``); {} otherwise."""
        return dict(zip(("low", "high"), command_range(sessions))) if self.on_physics else {}

    def _with_base(self, sessions) -> Sequence:
        """The model with its linear base fitted on ``sessions`` (``linear_base``: the order chosen there, or
        a fitted base's order kept); the model itself without ``linear``."""
        if not self.linear:
            return self
        base, scores = linear_base(sessions, None if self.base is None else self.base.na)
        return replace(self, base=base, base_scores=scores or self.base_scores)

    def refit(self, sessions) -> Sequence:
        """The model trained anew on the real rows of ``sessions`` from its pretrained network, with the
        pretraining's standardisation (``fit`` in mode ``real``, or before a fit): the cross-fit's refit
        (``uncertainty.cross_fit``). The physics' lesson stays what it was; only the real rows change,
        and the pretraining, most of a fit's cost, is not repeated. The real-row training draws no
        random numbers, so ``refit`` on the rows the model was fitted on gives the model again. With
        ``linear``, the linear base is refitted first, of the same order."""
        if self.pretrained is None:
            return self.fit(sessions)
        import torch  # optional extra: learn (PyTorch)

        sessions = list(sessions)
        model = replace(self._with_base(sessions), **self._range(sessions))
        bases = [model._base(s) for s in sessions]
        xs = [torch.tensor((model._inputs(s, b) - self.mu) / self.sd, dtype=torch.float32)[None]
              for s, b in zip(sessions, bases)]
        ys = [torch.tensor((s.tip - b - self.offset) / self.scale, dtype=torch.float32)[None]
              for s, b in zip(sessions, bases)]
        with _serial():
            net = _train_gru(self.options, xs, ys, xs[0].shape[-1], copy.deepcopy(self.pretrained))
        return replace(model, net=net, reach=InputDistance.of(sessions), interval_q=None,
                       interval_slope=None, interval_knee=0.0).anchored(self.physics, sessions)

    def predict(self, session: Recording) -> np.ndarray:
        """The tip (T, 3) [m] over ``session``, free running from its start on its inputs."""
        import torch  # optional extra: learn (PyTorch)

        gru, head = self.net
        base = self._base(session)
        with torch.no_grad(), _serial():
            out, _ = gru(torch.tensor((self._inputs(session, base) - self.mu) / self.sd, dtype=torch.float32)[None])
            y = head(out)[0].numpy().astype(float) * self.scale
        if self.on_physics:
            return base + gate_weights(self.reach, self.gate, session)[:, None] * (y + self.offset)
        return y + self.offset + base

    def physics_weights(self, session: Recording) -> np.ndarray | None:
        """(T,) the GRU's weight w per row over the physics (``gate_weights``); None without ``on_physics``."""
        return gate_weights(self.reach, self.gate, session) if self.on_physics else None

    def describe(self) -> dict:
        """What the model is and its options, JSON-ready."""
        out = {"kind": "GRU of the commands and intervals" +
                       (" and a hysteresis state (play operators)" if self.hysteresis else "") +
                       (", over a linear ARX model's free run from rest" if self.linear else "") +
                       (", over the calibrated physics' tip" if self.on_physics else "") +
                       (", gated off away from the training data" if self.on_physics and not math.isinf(self.gate)
                        else ""),
               **{k: v for k, v in vars(self.options).items()}, **_pretraining(self)}
        if self.on_physics:
            out["gate_d0"] = None if math.isinf(self.gate) else self.gate
        if self.base is not None:
            out |= {"linear_order": self.base.na, "linear_holdout_rmse_mm": {
                k: round(v, 4) if math.isfinite(v) else None for k, v in self.base_scores.items()}}
        return out | self.anchor_description() | (self.follows_description() if self.on_physics else {})


def _lanes(o: SequenceOptions, xs: list) -> list[tuple[int, int, int]]:
    """The lanes of ``_train_gru``: (session, first row, end row) of each session's contiguous pieces, as
    few as hold at most ``o.lane_windows`` windows of ``o.window`` rows each, of about equal length, each
    of whole windows but the session's last."""
    out = []
    for i, x in enumerate(xs):
        windows = -(-x.shape[1] // o.window)
        cuts = np.linspace(0, windows, -(-windows // o.lane_windows) + 1).round().astype(int) * o.window
        out += [(i, int(a), int(min(b, x.shape[1]))) for a, b in zip(cuts[:-1], cuts[1:])]
    return out


def _train_gru(o: SequenceOptions, xs: list, ys: list, n_inputs: int, net: tuple | None = None) -> tuple:
    """(GRU, linear head) trained on the sessions' standardised inputs ``xs`` and scaled tips ``ys``
    (each a (1, T, .) float32 tensor); ``net``: a (GRU, head) to continue training (None: new ones).

    Each session is cut into contiguous lanes of at most ``o.lane_windows`` windows (``_lanes``), all
    trained side by side as one batch, window after window of ``o.window`` rows, each lane carrying its
    state from window to window. A lane starts an epoch from the state that the whole session's run
    (without gradients, with the epoch's first weights) reaches at its first row, every ``o.state_runs``
    epochs, and in the epochs between from the state the lane before it reached at its last row in the
    epoch before: every row is learnt from about the state its session's free run carries there, as
    ``Sequence.predict`` runs it. Side by side, a step costs about what one window alone costs (a small
    GRU's step is spent on its per-row overhead), and an epoch takes at most ``o.lane_windows`` steps
    however long the sessions are."""
    import torch  # optional extra: learn (PyTorch)

    gru, head = net if net is not None else (torch.nn.GRU(n_inputs, o.hidden, batch_first=True),
                                             torch.nn.Linear(o.hidden, 3))
    params = list(gru.parameters()) + list(head.parameters())
    opt = torch.optim.AdamW(params, lr=o.lr, weight_decay=o.weight_decay)
    lanes = _lanes(o, xs)
    rows = max(b - a for _, a, b in lanes)
    per_epoch = -(-rows // o.window)
    # the lanes side by side, padded past their ends with rows masked out of the loss
    X = torch.zeros(len(lanes), per_epoch * o.window, n_inputs)
    Y = torch.zeros(len(lanes), per_epoch * o.window, 3)
    mask = torch.zeros(len(lanes), per_epoch * o.window, 1)
    for k, (i, a, b) in enumerate(lanes):
        X[k, :b - a], Y[k, :b - a], mask[k, :b - a] = xs[i][0, a:b], ys[i][0, a:b], 1.0
    # the sessions side by side up to their last lane's first row, padded past their ends (a GRU's state
    # at a row depends on the rows before it alone), for the lanes' first states
    reach = max(1, max(a for _, a, _ in lanes))
    runs = torch.zeros(len(xs), reach, n_inputs)
    for i, x in enumerate(xs):
        runs[i, :min(reach, x.shape[1])] = x[0, :reach]
    first = [(i, a) for i, a, _ in lanes]
    # the lane before each lane in its session (-1: none), and where each lane's last row lies
    before = torch.tensor([k - 1 if a else -1 for k, (_, a, _) in enumerate(lanes)])
    last = [((b - a - 1) // o.window * o.window, (b - a - 1) % o.window) for _, a, b in lanes]
    # per window: the lanes whose last row lies in it, and that row's place in the window
    ending = {w: (torch.tensor([k for k, (v, _) in enumerate(last) if v == w]),
                  torch.tensor([r for v, r in last if v == w])) for w in {v for v, _ in last}}
    ends = torch.zeros(len(lanes), o.hidden)                      # each lane's state at its last row
    for epoch in range(max(1, min(o.epochs, o.max_steps // per_epoch))):
        if epoch % o.state_runs == 0:
            with torch.no_grad():                 # each lane's state at its first row, from its session's run
                states = gru(runs)[0]
                h = torch.stack([states[i, a - 1] if a else torch.zeros(o.hidden) for i, a in first])[None]
        else:                                     # the state the lane before it ended the last epoch with
            h = torch.where((before >= 0)[:, None], ends[before.clamp(min=0)], 0.0)[None]
        for a in range(0, X.shape[1], o.window):
            m = mask[:, a:a + o.window]
            out, h = gru(X[:, a:a + o.window], h)
            loss = torch.sum(m * (head(out) - Y[:, a:a + o.window]) ** 2) / (3.0 * torch.sum(m))
            opt.zero_grad()
            loss.backward()
            opt.step()
            h = h.detach()
            if a in ending:
                k, r = ending[a]
                ends[k] = out[k, r].detach()
    return gru, head


# ------------------------------------------------------------------ fitted with their options chosen

@contextmanager
def seeded(name: str):
    """PyTorch's global random numbers seeded from ``name`` inside (where PyTorch is installed), the
    caller's state restored after: a family's (or a candidate's) figures do not depend on what ran
    before it, nor in which process."""
    try:
        import torch  # optional extra: learn (PyTorch)
    except ImportError:
        yield
        return
    with torch.random.fork_rng(devices=[]):
        torch.manual_seed(zlib.crc32(name.encode()))
        yield


def candidate(mode: str, hysteresis: bool | None = None) -> str:
    """A candidate's label in the hold-out scores and its seed: its hysteresis state (None: the family
    has none) and its mode, e.g. ``hysteresis=False,mode=real`` or ``mode=finetune``."""
    return f"mode={mode}" if hysteresis is None else f"hysteresis={hysteresis},mode={mode}"


def staged(make, modes, train, held_score, variants=lambda model: {"": model}, name: str = "",
           early: dict | None = None) -> tuple:
    """A learned family's options chosen on the hold-out part in two stages (``make(hysteresis, mode,
    i)`` a family with the physics ``pair[i]``): the hysteresis state on the real rows alone, then
    ``modes`` of the physics' synthetic data with that state, each fit scored in its ``variants``
    ({label suffix: model}); the winner refitted on every training row, its 90 % interval calibrated
    on the hold-out split (``uncertainty.calibrate``). Each candidate's fit is seeded by its label
    (``seeded``, with the family's ``name``); ``early``: candidates fitted already ({label: model},
    ``early_candidates``). Returns (model, {candidate: hold-out RMSE [mm]})."""
    fit_part, held = holdout_split(train)
    scores, fitted, early = {}, {}, dict(early or {})

    def attempt(h, m):
        base = candidate(m, h)
        if base not in early:
            with seeded(f"{name} {base}"):
                early[base] = make(h, m, 0).fit(fit_part)
        for suffix, model in variants(early[base]).items():
            label = base + suffix
            fitted[label] = (h, m, suffix, model)
            scores[label] = held_score(model)
    for h in (False, True):
        attempt(h, "real")
    rows = held_rows(held)
    h = fitted[parsimonious(scores, rows)][0]
    for m in modes:
        attempt(h, m)
    h, m, suffix, model = fitted[parsimonious(scores, rows)]
    final = variants(make(h, m, 1).fit(train))[suffix]
    return replace(final, **calibrate(model, fit_part, held)), scores


def early_candidates(name: str, train, syn, options) -> dict:
    """The candidates of the learned family ``name`` that need no physics (on the real rows alone),
    fitted on the hold-out split's fitting part of ``train``, each seeded by its label as the family's
    own fit seeds it (``staged``, ``fit_node``; the sequence model seeds itself): {label: model}. A job
    of its own, which the workers take while the physics calibrates; {} for a family without any."""
    fit_part = holdout_split(train)[0]
    if name == "sequence":
        return {label: _sequence(options, mode, syn, None, h, base).fit(fit_part)
                for label, (h, mode, base) in sequence_candidates(syn).items()}
    out = {}
    if name == "learned_map":
        for h in (False, True):
            with seeded(f"{name} {candidate('real', h)}"):
                out[candidate("real", h)] = LearnedMap(h, options.nets, "real", syn).fit(fit_part)
    elif name == "node_lstm":
        with seeded(f"{name} {candidate('real')}"):
            out[candidate("real")] = NodeFamily(options.length, options.node, mode="real", synthetic=syn).fit(fit_part)
    return out


DENSE = 4
"""The dense mixed candidate's synthetic rows, as a multiple of the synthetic options' ``amount``
(``DENSE_MODE``)."""
DENSE_MODE = f"mixed,synthetic=x{DENSE}"
"""The mode of a learned map or hybrid trained as in ``mixed`` on ``DENSE`` times as many synthetic rows:
the synthetic rows keep their weight and each step draws as many of them, so the physics' map is
sampled more densely at about the same cost (the synthetic sessions aside). Tried on the hold-out
after ``mixed``, as more complex: chosen only where the hold-out shows it better."""


def _synthetic_mode(mode: str, syn: SyntheticOptions) -> tuple[str, SyntheticOptions]:
    """(the family's mode, its synthetic options) of a candidate's ``mode`` (``DENSE_MODE`` among them)."""
    return ("mixed", replace(syn, amount=syn.amount * DENSE)) if mode == DENSE_MODE else (mode, syn)


def fit_learned_map(train, pair, syn, options, held_score, early: dict | None = None) -> tuple:
    """``LearnedMap``: its hysteresis state and mode (``finetune``, ``mixed``, ``DENSE_MODE`` with
    synthetic data) chosen on the hold-out part (``staged``); each with the physics of ``pair`` fitted on
    its rows, which its error scale reads where calibrated (``LearnedMap.error_scale``)."""
    # the candidates fitted before the physics was calibrated state their distance from it too
    early = {label: replace(model, physics=pair[0]) for label, model in (early or {}).items()}
    return staged(lambda h, m, i: LearnedMap(h, options.nets, *_synthetic_mode(m, syn), pair[i]),
                  ("finetune", "mixed", DENSE_MODE) if syn.on else (), train, held_score, name="learned_map",
                  early=early)


def fit_hybrid(train, pair, syn, options, held_score) -> tuple:
    """``Hybrid``: its hysteresis state and mode (``mixed``, ``DENSE_MODE`` with synthetic data) chosen on
    the hold-out part (``staged``), and its gate: each fit scored there with every gate width of ``GATES``."""
    return staged(lambda h, m, i: Hybrid(pair[i], h, options.nets, *_synthetic_mode(m, syn)),
                  ("mixed", DENSE_MODE) if syn.on else (), train, held_score, _gated, name="hybrid")


def _gated(model) -> dict:
    """{label suffix: ``model`` with that gate}: every gate width of ``GATES`` (the hybrid's residual, the
    sequence model's GRU and the node LSTM over the physics), scored on the hold-out without refitting."""
    return {f",gate={g:g}": replace(model, gate=g) for g in GATES}


def sequence_candidates(syn, hysteresis: bool | None = None, physics: bool = False) -> dict:
    """The ``Sequence`` model's candidates {label: (hysteresis, mode, base)}, simplest first, in two
    stages: (``hysteresis`` None) the GRU on the real rows without and with the hysteresis state; then,
    with the state the first stage chose, the GRU over a linear base (base ``linear``), where there are
    synthetic sessions (``syn``) the GRU pretrained on them (mode ``finetune``), and where there is a
    calibrated ``physics`` the GRU over its tip (base ``physics``, ``Sequence.on_physics``); base None:
    the GRU alone."""
    if hysteresis is None:
        return {candidate("real", h): (h, "real", None) for h in (False, True)}
    out = {candidate("real", hysteresis) + ",linear": (hysteresis, "real", "linear")}
    out |= {candidate("finetune", hysteresis): (hysteresis, "finetune", None)} if syn.on else {}
    return out | ({candidate("real", hysteresis) + ",physics": (hysteresis, "real", "physics")} if physics else {})


def linear_first(scores: dict) -> dict:
    """``scores`` ({candidate: hold-out RMSE [mm]}) reordered for the final choice (``parsimonious``): the
    GRU over a linear base before the GRU alone, the rest in their order. The GRU over a linear base
    holds what a linear model of the commands explains, so the GRU's part is smaller; it carries more
    from one session to another, which a hold-out session fitted from fewer sessions cannot show (fitted
    on one session and scored on another, it ties with the GRU alone; fitted on every session, it
    validates better on a session of their kind), so where the two are within one standard error it
    is kept. Where its linear base extrapolates without bound (rows at equilibrium seconds apart), the
    hold-out shows it far worse."""
    return dict(sorted(scores.items(), key=lambda item: ",linear" not in item[0]))


def _sequence(options, mode, syn, physics, h, base) -> Sequence:
    """The ``Sequence`` family of a candidate (``sequence_candidates``: ``h``, ``mode``, ``base``)."""
    return Sequence(options.sequence, mode, syn, physics, hysteresis=h, linear=base == "linear",
                    on_physics=base == "physics")


def fit_sequence(train, pair, syn, options, held_score, early: dict | None = None) -> tuple:
    """``Sequence``: its hysteresis state chosen on the hold-out part first (on the real rows), then with
    that state alone, over a linear base, pretrained on the synthetic sessions, or over the calibrated
    physics' tip (where ``pair`` holds calibrated physics), as the hold-out part prefers
    (``sequence_candidates``; within one standard error, the GRU over a linear base before the GRU alone:
    ``linear_first``); its interval calibrated on the hold-out split. ``early``:
    candidates fitted already ({label: model}, ``early_candidates``)."""
    fit_part, held = holdout_split(train)
    fitted, scores, options_of = dict(early or {}), {}, {}

    def attempt(candidates):
        for label, (h, mode, base) in candidates.items():
            if label not in fitted:
                fitted[label] = _sequence(options, mode, syn, pair[0], h, base).fit(fit_part)
            # over the physics, the GRU's part is gated as the hybrid's residual (no refit)
            for suffix, model in (_gated(fitted[label]) if base == "physics" else {"": fitted[label]}).items():
                fitted[label + suffix] = model
                scores[label + suffix], options_of[label + suffix] = held_score(model), (h, mode, base, model.gate)
    attempt(sequence_candidates(syn))
    attempt(sequence_candidates(syn, options_of[parsimonious(scores, held_rows(held))][0],
                                all(calibrated(p) for p in pair)))
    best = parsimonious(linear_first(scores), held_rows(held))
    interval = calibrate(fitted[best].anchored(pair[0], fit_part), fit_part, held)
    h, mode, base, gate = options_of[best]
    final = replace(_sequence(options, mode, syn, pair[1], h, base).fit(train), gate=gate)
    return replace(final, **interval), scores


def fit_node(train, pair, syn, options, held_score, early: dict | None = None) -> tuple:
    """``NodeFamily`` (``options.node``), taught by the physics' synthetic sessions (mode ``mixed``) or
    not, or (where ``pair`` holds calibrated physics) learning what the physics leaves, its residual gated
    with each width of ``GATES`` (``NodeFamily.on_physics``; tried last, ``mode=real,physics,gate=...``),
    as the hold-out part prefers, each candidate seeded by its label (``seeded``); the winner
    refitted on every training row, with a 90 % interval (``uncertainty.WithInterval``, its scale from
    the physics: ``families.Anchored``) calibrated on the hold-out split. ``early``: candidates fitted
    already ({label: model}, ``early_candidates``). With a single candidate (``node_single``) the refit
    is ``node_final``'s, which a job of its own can run beside this choice (``node_choice``)."""
    best, interval, scores = node_choice(train, pair, syn, options, held_score, early)
    if node_single(pair, syn):
        final = node_final(train, pair, syn, options)
    else:
        final = _node_refit(best, pair, syn, options).fit(train)
    return WithInterval(final, InputDistance.of(train), **interval), scores


def node_single(pair, syn) -> bool:
    """Whether ``fit_node`` has one candidate alone, the node on the real rows (no synthetic data, no calibrated
    physics in ``pair``): then its refit on every training row waits for no choice (``node_final``)."""
    return not syn.on and not all(calibrated(p) for p in pair)


def node_choice(train, pair, syn, options, held_score, early: dict | None = None) -> tuple:
    """``fit_node``'s choice: (the candidate the hold-out part prefers, fitted on the fitting part; its
    interval's parameters, calibrated on the hold-out split; the candidates' hold-out scores [mm])."""
    fit_part, held = holdout_split(train)
    fitted = dict(early or {})
    for m in ("real", "mixed") if syn.on else ("real",):
        if candidate(m) not in fitted:
            with seeded(f"node_lstm {candidate(m)}"):
                fitted[candidate(m)] = NodeFamily(options.length, options.node, mode=m, synthetic=syn,
                                                 physics=pair[0]).fit(fit_part)
    if all(calibrated(p) for p in pair):
        label = candidate("real") + ",physics"
        with seeded(f"node_lstm {label}"):
            over = NodeFamily(options.length, options.node, physics=pair[0], on_physics=True).fit(fit_part)
        fitted |= {label + suffix: model for suffix, model in _gated(over).items()}
    scores = {k: held_score(v) for k, v in fitted.items()}
    best = fitted[parsimonious(scores, held_rows(held))]
    interval = calibrate(WithInterval(best.anchored(pair[0], fit_part), InputDistance.of(fit_part)), fit_part, held)
    return best, interval, scores


def _node_refit(best, pair, syn, options) -> NodeFamily:
    """The node model of ``best``'s candidate, with the physics fitted on every training row (``pair[1]``),
    to be fitted on every training row."""
    return NodeFamily(options.length, options.node, mode=best.mode, synthetic=syn, physics=pair[1],
                      on_physics=best.on_physics, gate=best.gate)


NODE_FINAL = "node_lstm final"
"""The label of ``node_final``: its job's and its random numbers' (``seeded``)."""


def node_final(train, pair, syn, options) -> NodeFamily:
    """The single candidate of ``fit_node`` (``node_single``: the node on the real rows) fitted on every
    training row, seeded by its own label (``NODE_FINAL``): the same model whether it runs after the choice or
    beside it, in a job of its own."""
    with seeded(NODE_FINAL):
        return _node_refit(NodeFamily(options.length, options.node), pair, syn, options).fit(train)
