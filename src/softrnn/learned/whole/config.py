"""``DynamicConfig``: the architecture and training of a whole-manipulator model (frozen, validated)."""

from __future__ import annotations

from dataclasses import asdict, dataclass, fields, replace

from ...errors import bad, integer, is_finite_number, nonnegative, positive

MEMORIES = ("window", "lstm")
CONV_READS = ("all", "displacements", "loads")
FRAMES = ("world", "vessel")
"""The coordinates of a model's state (``DynamicConfig.frame``; ``softrnn.learned.whole.frame``)."""
DRIVES = ("wrench", "actuation", "both")
"""What a model's load input holds: the nodal wrenches, the data's actuation inputs, or both."""


@dataclass(frozen=True)
class DynamicConfig:
    """How a whole-manipulator model is built and trained (each field is described beneath it)."""

    model_dt: float = 0.02
    """The model's step [s]; a whole multiple of the data's saved interval (default 20 ms)."""
    node_stride: int | None = None
    """Predict every ``node_stride``-th node and both ends (None: about 20 segments along the rod)."""
    history: int = 3
    """States the model reads per step (>= 2): the current one and ``history - 1`` velocities."""
    memory: str = "window"
    """Temporal memory: the ``history`` window alone, or also a per-node LSTM cell (shared along
    the rod) carried from step to step."""
    width: int = 48
    """The 1-D convolution along the rod: its channels."""
    layers: int = 3
    """The convolution's hidden layers."""
    kernel: int = 5
    """The convolution's kernel size (odd)."""
    linear: bool = True
    """Add a global linear map of the whole state (initialised by ridge regression)."""
    conv: bool = True
    """Add the convolution (one set of weights shared along the rod)."""
    bound: float = 0.0
    """The convolution's output is limited to +-bound (in units of the velocity-change scale) by
    a tanh: a correction cannot run away by itself; 0: no limit."""
    noise: float = 0.01
    """Input noise during training, as a random walk on the history's velocities, in units of
    their standard deviation (GNS-style); 0 switches it off."""
    unroll: int = 20
    """Free steps in the training loss (the model feeds its own predictions back); 1 is a
    one-step loss. The unroll grows from 1 to this over the first half of training."""
    steps: int = 4000
    """Optimiser steps."""
    batch: int = 32
    """Windows per optimiser step."""
    start_fraction: float = 0.0
    """The fraction of each batch's windows drawn from a trajectory's first steps
    (``training.START_STEPS``), the rest uniformly: a run from rest (a trajectory's start, where
    the loads rise from zero) is otherwise a rare window, and its first steps go untrained."""
    lr: float = 2e-3
    """Adam's learning rate (cosine decay to 5 % of it)."""
    linear_lr: float = 0.01
    """The linear term's learning rate as a fraction of ``lr`` (0 keeps the ridge fit as it is)."""
    ridge: float = 1e-6
    """Ridge penalty of the linear term's initial fit (relative to the mean feature variance): where
    its ladder of penalties starts. The linear baseline's ladder starts at 1e-6 whatever this is
    (``training.BASELINE_RIDGE``)."""
    load_ridge: float | None = None
    """The ridge penalty on the load coefficients of the network's linear term (same units as
    ``ridge``; None: the same penalty as the rest). A stiff penalty keeps a free run stable, but
    on the loads it shrinks the response to a load change; the loads are known inputs and
    need no shrinking to stay stable."""
    seed: int = 0
    """Seeds weights, window draws and noise: the same seed and data give the same weights."""
    ema: float = 0.995
    """Decay of a running average of the weights (Polyak averaging), validated beside the current
    weights at every checkpoint (and kept without validation); 0 switches it off."""
    conv_reads: str = "all"
    """What the convolution reads: every state and velocity column but not the loads ("all"), the
    displacements only (rotations then reach the next state through the linear term alone), or
    every feature, the loads included ("loads": where the loads' effect depends on the rod's
    shape, as a tendon's does)."""
    feedback: bool = True
    """Where a data set's scenario has PD tracking loads, apply their law to the model's own state
    (the target and gains are the inputs; ``softrnn.learned.whole.feedback``) instead of taking the
    recorded forces, which the simulated rod's state produced, as inputs. Used with
    ``drive = "wrench"`` only."""
    drive: str = "wrench"
    """The model's load input per kept node: the lumped mean force and torque (6 channels; the
    default), the data's actuation inputs (``Dataset.actuation``, every channel, their mean over
    the step: m channels, the same at every node), or both (6 + m). The training data must
    record actuation inputs for the last two (one-line error otherwise)."""
    prescribed: bool = True
    """Where a data set's scenario moves a clamp along a prescribed path (a clamp with a
    displacement or rotation profile), take the clamp's recorded path as an input: the node is
    not predicted, it follows the data, and its change over each step reaches every node as 6
    load channels (``Encoding.prescribed``). False: the clamp is predicted like any other node,
    from its own history."""
    obstacles: bool = True
    """Where the data record obstacles (runs simulated with contact), keep the poses a free run
    reports out of them: a predicted node inside an obstacle is moved back to its surface
    (``softrnn.learned.whole.obstacles``; in evaluations, rollouts and the validation that picks
    the weights; the model steps on its own states, and the training loss and an exported step do
    not project). False: the reported nodes may lie inside the obstacles."""
    contact: bool = False
    """Where the data record obstacles (runs simulated with contact), each kept node's signed gap to
    the nearest obstacle and its normal there are inputs of the network's correction (4 load
    channels, measured on the model's own state at every step: ``softrnn.learned.whole.obstacles``
    ``ContactFeatures``); the linear term does not read them. False: the model knows the obstacles
    only through the motion the data show near them."""
    frame: str = "world"
    """The coordinates of the model's state: displacements and rotations in the world frame
    ("world"), or in curvilinear coordinates along the centreline of the vessel the training data
    were simulated in ("vessel": the arc parameter along it and two offsets across it, the rotation in
    the frame carried along it; ``softrnn.learned.whole.frame``), so that a node keeping its
    velocity keeps going along the vessel. "vessel" needs training data recorded in one vessel."""
    envelope: float | None = 0.25
    """Where the network's correction acts (``DynamicNet.envelope_gate``): fully on a node whose
    features lie within the training data's range of each channel, fading linearly to zero at
    this fraction of the range beyond it, where its inputs are clipped (None: everywhere,
    unclipped). The correction is then bounded and vanishes far from the data: there the model
    is its linear term and extrapolates like a damped linear system, not like a network."""
    prior_tau: float | None = 0.5
    """The ridge fit of the linear term is shrunk toward a model in which every moving coordinate
    relaxes to the reference pose, critically damped with this time constant [s]
    (``training.damping_prior``), not toward zero, which would leave the directions the data
    never excite ballistic (None: toward zero). Default 0.5 s: on the paper's three cases it
    gave smaller validation errors than 1 s (docs/guide/dynamic.md, fourth round)."""

    def __post_init__(self):
        positive("model_dt", self.model_dt, "s")
        if self.node_stride is not None:
            integer("node_stride", self.node_stride, 1)
        integer("history", self.history, 2)
        if self.memory not in MEMORIES:
            raise bad("memory", self.memory, f"one of {', '.join(MEMORIES)}")
        integer("width", self.width, 1)
        integer("layers", self.layers, 1)
        integer("kernel", self.kernel, 1)
        if self.kernel % 2 == 0:
            raise bad("kernel", self.kernel, "an odd kernel size (1, 3, 5, ...)")
        for name in ("linear", "conv", "feedback", "prescribed", "obstacles", "contact"):
            if not isinstance(getattr(self, name), bool):
                raise bad(name, getattr(self, name), "true or false")
        if not (self.linear or self.conv or self.memory == "lstm"):
            raise bad("linear", False, "at least one of linear, conv or memory = 'lstm'")
        nonnegative("bound", self.bound)
        nonnegative("noise", self.noise)
        integer("unroll", self.unroll, 1)
        integer("steps", self.steps, 0)
        integer("batch", self.batch, 1)
        if not (is_finite_number(self.start_fraction) and 0.0 <= float(self.start_fraction) < 1.0):
            raise bad("start_fraction", self.start_fraction, "a fraction in [0, 1) of each batch")
        positive("lr", self.lr)
        nonnegative("linear_lr", self.linear_lr)
        nonnegative("ridge", self.ridge)
        if self.load_ridge is not None:
            nonnegative("load_ridge", self.load_ridge)
        integer("seed", self.seed, 0)
        if self.conv_reads not in CONV_READS:
            raise bad("conv_reads", self.conv_reads, f"one of {', '.join(CONV_READS)}")
        if not (0.0 <= float(self.ema) < 1.0):
            raise bad("ema", self.ema, "a decay in [0, 1) (0: no averaging)")
        if self.envelope is not None:
            positive("envelope", self.envelope)
        if self.prior_tau is not None:
            positive("prior_tau", self.prior_tau, "s")
        if self.frame not in FRAMES:
            raise bad("frame", self.frame, "'world' (the default) or 'vessel' (along the data's vessel)")
        if self.drive not in DRIVES:
            raise bad("drive", self.drive, "'wrench' (the nodal wrenches), 'actuation' (the data's actuation "
                                           "inputs) or 'both'")

    def to_dict(self) -> dict:
        """The fields as a dict (model.json's ``config``); ``drive``, ``start_fraction``,
        ``load_ridge``, ``prescribed``, ``obstacles``, ``contact`` and ``frame`` only when they are not
        their defaults (so models, checkpoints and reproduce step files written before them are recorded, and
        resumed, as before)."""
        d = asdict(self)
        for key, default in _LATER_DEFAULTS.items():
            if d[key] == default:
                del d[key]
        return d

    @classmethod
    def from_dict(cls, d: dict) -> DynamicConfig:
        """A config from ``to_dict``'s dict; an unknown key is a one-line error."""
        if not isinstance(d, dict):
            raise bad("config", type(d).__name__, "a dict of DynamicConfig fields")
        names = {f.name for f in fields(cls)}
        unknown = sorted(set(d) - names)
        if unknown:
            raise bad("config", unknown[0], f"one of {', '.join(sorted(names))}")
        return cls(**d)


_LATER_DEFAULTS = {"drive": "wrench", "start_fraction": 0.0, "load_ridge": None, "prescribed": True,
                   "obstacles": True, "contact": False, "frame": "world"}
"""Fields added after models were first saved, left out of ``to_dict`` at their defaults."""


def resolve_stride(model_dt: float, data_dt: float) -> int:
    """The model's step in data samples; ``model_dt`` must be a whole multiple of ``data_dt``."""
    k = round(model_dt / data_dt)
    if k < 1 or abs(k * data_dt - model_dt) > 1e-6 * model_dt:
        raise bad("model_dt", model_dt, f"a whole multiple of the data's saved interval {data_dt:g} s")
    return int(k)


def resolve_node_stride(node_stride: int | None, n_nodes: int) -> int:
    """``node_stride``, or about 20 segments along the rod when None."""
    if node_stride is None:
        return max(1, round((n_nodes - 1) / 20))
    if node_stride >= n_nodes:
        raise bad("node_stride", node_stride, f"a stride below the rod's {n_nodes} nodes")
    return int(node_stride)



def linear_config(config: DynamicConfig) -> DynamicConfig:
    """The linear baseline's config: the linear term alone, same inputs, no training."""
    return replace(config, linear=True, conv=False, memory="window", steps=0, envelope=None, load_ridge=None)


N_CONST = 3
"""Per-node constant features (``Encoding.node_features``)."""


def n_channels(history: int, loads: int = 6) -> int:
    """Features per node: state 6, velocities 6 (history - 1), the ``loads`` load channels (6 for
    the wrench; m or 6 + m with actuation inputs), constants 3."""
    return 6 + 6 * (history - 1) + loads + N_CONST


def conv_channels(history: int, reads: str = "all", loads: int = 6, contact: slice | None = None) -> list[int]:
    """The feature columns the convolution (and the LSTM cell) read: every one but the ``loads``
    load channels, with ``reads = "displacements"`` also none of the rotation columns of the state
    and velocities, with ``reads = "loads"`` every one; ``contact``: the contact inputs among the
    load channels (``Encoding.contact_columns``), read whatever ``reads`` says."""
    C = n_channels(history, loads)
    cut = load_channels(history, loads)
    if reads == "loads":
        return list(range(C))
    cols = [c for c in range(C) if not cut.start <= c < cut.stop]
    if reads == "displacements":
        cols = [c for c in cols if c >= cut.stop or c % 6 < 3]
    if contact is not None:
        cols = sorted(cols + list(range(cut.start + contact.start, cut.start + contact.stop)))
    return cols


def load_channels(history: int, loads: int = 6) -> slice:
    """Where the ``loads`` load channels sit among the features (the convolution skips them)."""
    return slice(6 * history, 6 * history + loads)


def path_columns(prescribed, loads: int) -> tuple:
    """((kept index m, first load column c), ...) of the prescribed nodes (a (M,) bool mask) among
    ``loads`` load channels: each one's change of state over a step sits in channels c .. c + 5,
    the last 6 P channels in node order (``Encoding.prescribed``)."""
    nodes = [int(m) for m, flag in enumerate(prescribed) if flag]
    first = int(loads) - 6 * len(nodes)
    return tuple((m, first + 6 * j) for j, m in enumerate(nodes))
