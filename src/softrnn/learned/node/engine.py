"""The real-time inference engine: trained node models stepped in compiled code.

The PyTorch module is for training; for prediction its weights are packed into flat float32 rows
(one per model, ``pack``) and run by a numba kernel (``_engine_kernels.forward``) that keeps every
buffer preallocated. Models of one architecture are stacked, so a whole manipulator advances in one
call per architecture whatever mix of per-node and shared models it uses. A model shared by many
nodes runs through ``_engine_kernels.forward_gemm`` instead: every layer is one BLAS product over
all its nodes (split over numba's threads on request), cheaper per node than one kernel call each.

* ``Engine``: the stacked models; ``predict(poses, wrenches, which)`` is the batched, stateless
  equivalent of ``NodeModel.predict`` (outputs equal within float32 rounding, about 1e-7 of the
  motion scale).
* ``NodeStepper``: one node at batch size 1 for a control loop: ``reset`` with a window, then
  ``step(pose_row, wrench_row)`` per sample returns the node's next position.
* ``ManipulatorStepper``: every modelled node of a manipulator (paper Fig. 2C), one call per
  sample; unmodelled nodes hold their pose or take the boundary positions given to ``step``.
* ``engine_rollout``: the free-running rollout over a data set's span, every step inside numba
  (``softrnn.learned.node.rollout.rollout`` uses it).

Choice of implementation: one forward of a 2 x 32 LSTM is about 25 k multiply-adds, far less than
the per-operator cost of ONNX Runtime, TorchScript or eager PyTorch, so a compiled kernel with
preallocated buffers is the fastest at batch 1 (``softrnn bench`` times all four;
``benchmarks/README.md``).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ...errors import SoftrnnInputError, bad
from . import _engine_kernels as K
from .manipulator import RolloutDiverged, _as_manipulator, bind

_OUT_MODES = {"increment": K.OUT_INCREMENT, "acceleration": K.OUT_ACCELERATION, "pose": K.OUT_POSE}


# ------------------------------------------------------------------------------------------ packing
def _arch_key(model) -> tuple:
    c, n = model.config, model.normalizer
    return (c.pose_features, c.wrench_features, c.history, c.lstm_layers, c.lstm_units, c.dense_units,
            c.wrench_dense, c.differences, c.linear_skip, n.output, n.relative, n.per_node)


def _linears(seq) -> list:
    return [m for m in seq if hasattr(m, "weight")] if seq is not None else []


def pack(models) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Flat weights of same-architecture models.

    Returns
    -------
    tuple of ndarray
        params (M, S) float32, every model's weights; norm (M, Sn) float64, their normalisation
        statistics (one row per model); arch (1,) of ``_engine_kernels.ARCHITECTURE``, the
        architecture and offsets; layers of ``_engine_kernels.LAYER``, per LSTM then dense layer.
    """
    models = list(models)
    if not models:
        raise bad("models", [], "at least one NodeModel")
    key = _arch_key(models[0])
    for m in models[1:]:
        if _arch_key(m) != key:
            raise bad("models", "models of different architectures",
                      "models with one ModelConfig and normalisation mode (group them by architecture)")
    c, n0 = models[0].config, models[0].normalizer
    P, W, H, NL, U = c.pose_features, c.wrench_features, c.history, c.lstm_layers, c.lstm_units
    in1 = 2 * P if c.differences else P
    G = 4 * U
    gscale = np.ones(G, np.float32)
    gscale[2 * U:3 * U] = 2.0                      # cell gate g: tanh = 2 sigma(2x) - 1
    mod0 = models[0].module
    wd, hd = _linears(mod0.wrench_branch), _linears(mod0.head)
    out_in = mod0.out.weight.shape[1]
    skip_in = mod0.skip.weight.shape[1] if mod0.skip is not None else 0
    feat = U + (wd[-1].weight.shape[0] if wd else H * W) * (W > 0)
    off = 0
    layer_recs, dense_recs = [], []        # (off_w, off_u, off_b, n_in, n_out), as _engine_kernels.LAYER
    for layer in range(NL):
        n_in = in1 if layer == 0 else U
        layer_recs.append((off, off + n_in * G, off + n_in * G + U * G, n_in, G))
        off += n_in * G + U * G + G
    for lin in (wd if W else []) + hd:
        n_out, n_in = lin.weight.shape
        dense_recs.append((off, -1, off + n_in * n_out, n_in, n_out))
        off += n_in * n_out + n_out
    off_out = off                           # then the output layer, the skip, the difference scale and shift
    off_skip = off_out + out_in * 3 + 3
    off_ds = off_skip + skip_in * 3
    S = off_ds + 2 * P
    arch = np.zeros(1, K.ARCHITECTURE)
    for name, value in dict(
            pose_features=P, wrench_features=W, history=H, lstm_layers=NL, lstm_units=U, lstm_inputs=in1,
            differences=int(c.differences), relative=int(n0.relative), per_node=n0.per_node,
            wrench_dense=len(wd) if W else 0, head_dense=len(hd), features=feat, output=_OUT_MODES[n0.output],
            off_out=off_out, out_inputs=out_in, skip=int(skip_in > 0), off_skip=off_skip, skip_inputs=skip_in,
            off_delta_scale=off_ds, off_delta_shift=off_ds + P, params_length=S).items():
        arch[name] = value
    layers = np.array(layer_recs + dense_recs, dtype=K.LAYER)
    arch["work_length"] = K.work_size(arch, layers)

    params = np.zeros((len(models), S), np.float32)
    norm = np.zeros((len(models), 2 * P + 2 * W + 6), np.float64)
    for i, model in enumerate(models):
        sd = {k: v.detach().cpu().numpy() for k, v in model.module.state_dict().items()}
        row = params[i]
        for layer, (o_ih, o_hh, o_b, n_in, _) in enumerate(layer_recs):
            w_ih = sd[f"lstm.weight_ih_l{layer}"] * gscale[:, None]          # (4U, in)
            w_hh = sd[f"lstm.weight_hh_l{layer}"] * gscale[:, None]          # (4U, U)
            b = (sd[f"lstm.bias_ih_l{layer}"] + sd[f"lstm.bias_hh_l{layer}"]) * gscale
            row[o_ih:o_ih + n_in * G] = w_ih.T.ravel()
            row[o_hh:o_hh + U * G] = w_hh.T.ravel()
            row[o_b:o_b + G] = b
        lins = (_linears(model.module.wrench_branch) if W else []) + _linears(model.module.head)
        for lin, (o_w, _, o_b, n_in, n_out) in zip(lins, dense_recs):
            row[o_w:o_w + n_in * n_out] = 2.0 * lin.weight.detach().numpy().T.ravel()   # tanh = 2 sigma(2x) - 1
            row[o_b:o_b + n_out] = 2.0 * lin.bias.detach().numpy()
        row[off_out:off_out + out_in * 3] = model.module.out.weight.detach().numpy().T.ravel()
        row[off_out + out_in * 3:off_out + out_in * 3 + 3] = model.module.out.bias.detach().numpy()
        if skip_in:
            row[off_skip:off_skip + skip_in * 3] = model.module.skip.weight.detach().numpy().T.ravel()
        row[off_ds:off_ds + P] = sd["delta_scale"]
        row[off_ds + P:off_ds + 2 * P] = sd["delta_shift"]
        nm = model.normalizer
        norm[i] = np.concatenate([nm.pose_mean, nm.pose_std, nm.wrench_mean, nm.wrench_std, nm.target_mean,
                                  nm.target_std])
    return params, norm, arch, layers


def _scratch(e) -> tuple[np.ndarray, np.ndarray]:
    """The work row and exponent scratch of ``forward`` for an ``Engine``'s architecture."""
    n = int(e.arch[0]["work_length"])
    return np.zeros(n, np.float32), np.zeros(n, np.int32)


def _shared_scratch(e, B: int) -> tuple:
    """Window and scratch arrays of ``forward_gemm`` for B nodes: X, Wr, eb."""
    widest = max(4 * int(e.arch[0]["lstm_units"]), int(e.arch[0]["work_length"]))
    return (np.zeros((B, e.history, e.pose_features), np.float32),
            np.zeros((B, e.history, e.wrench_features), np.float32),
            np.zeros(B * widest, np.int32))


# ------------------------------------------------------------------------------------------ Engine
class Engine:
    """Stacked node models of one architecture, run by the compiled kernel.

    Parameters
    ----------
    models : sequence of NodeModel
        Models of one ``ModelConfig`` architecture and normalisation mode (their weights and
        statistics may differ). Model i is addressed by index i in ``predict``.
    """

    def __init__(self, models):
        self.models = list(models)
        self.params, self.norm, self.arch, self.layers = pack(self.models)
        self.history = int(self.arch[0]["history"])
        self.pose_features = int(self.arch[0]["pose_features"])
        self.wrench_features = int(self.arch[0]["wrench_features"])
        self._wk, self._eb = _scratch(self)

    def __len__(self) -> int:
        return len(self.models)

    def predict(self, poses, wrenches=None, which=None) -> np.ndarray:
        """Next positions of B windows, like ``NodeModel.predict``.

        Parameters
        ----------
        poses : array (B, H, P)
            Input I [m, 1] (``learned.node.data`` layout).
        wrenches : array (B, H, W) or None
            Input II [N, N m]; None when the models take none.
        which : array (B,) of int or None
            The model of each window (default: model 0 for all).

        Returns
        -------
        ndarray (B, 3) float64 [m]
            The predicted position of each window's node.
        """
        H, P, W = self.history, self.pose_features, self.wrench_features
        X = np.require(poses, np.float32, ["C", "W"])   # writable: a read-only array compiles the kernel again
        if X.ndim != 3 or X.shape[1:] != (H, P):
            raise bad("poses", f"array of shape {np.shape(poses)}", f"shape (B, {H}, {P})")
        B = X.shape[0]
        Wr = np.zeros((B, H, 0), np.float32) if wrenches is None else np.require(wrenches, np.float32, ["C", "W"])
        if Wr.shape != (B, H, W):
            raise bad("wrenches", f"array of shape {Wr.shape}", f"shape {(B, H, W)}")
        which = np.zeros(B, np.int64) if which is None else np.require(which, np.int64, ["C", "W"])
        if which.shape != (B,) or (B and (which.min() < 0 or which.max() >= len(self))):
            raise bad("which", which.tolist(), f"B = {B} model indices in [0, {len(self) - 1}]")
        out = np.empty((B, 3))
        K.predict_windows(self.params, self.norm, self.arch, self.layers, which, X, Wr, self._wk, self._eb, out)
        return out


class NodeStepper:
    """One node's model at batch size 1, stepped sample by sample (for a control loop).

    ``reset(poses (H, P), wrenches (H, W))`` loads a window and returns the prediction of the next
    sample; ``step(pose (P,), wrench (W,))`` appends the newest row (the oldest drops out) and
    returns the node's position at the sample after it. The returned array (3,) float64 [m] is
    reused by the next call: copy it to keep it. Pass float32 rows to avoid a conversion.

    All state lives in three preallocated arrays, so a step is one compiled call.
    """

    def __init__(self, model):
        engine = Engine([model])
        self.history, self.pose_features, self.wrench_features = (engine.history, engine.pose_features,
                                                                  engine.wrench_features)
        H, P, W = self.history, self.pose_features, self.wrench_features
        n_wk = int(engine.arch[0]["work_length"])
        S = engine.params.shape[1]
        n_norm = engine.norm.shape[1]
        # the layout of _engine_kernels.node_step: f32 = [params | window I | window II | work | scratch]
        self._f32 = np.zeros(S + H * P + H * W + 2 * n_wk, np.float32)
        self._f32[:S] = engine.params[0]
        self._f64 = np.zeros(n_norm + 3)
        self._f64[:n_norm] = engine.norm[0]
        self._arch, self._layers = engine.arch, engine.layers
        self._x = self._f32[S:S + H * P].reshape(H, P)
        self._w = self._f32[S + H * P:S + H * P + H * W].reshape(H, W)
        self._out = self._f64[n_norm:]
        self._no_wrench = np.zeros(0, np.float32)
        self.ready = False

    def reset(self, poses, wrenches=None) -> np.ndarray:
        """Load a full window (H, P) [m, 1] and (H, W) [N, N m]; return the next position (3,) [m]."""
        x = np.asarray(poses, dtype=np.float32)
        if x.shape != self._x.shape:
            raise bad("poses", f"array of shape {x.shape}", f"shape {self._x.shape} (history, pose features)")
        w = np.zeros(self._w.shape, np.float32) if wrenches is None else np.asarray(wrenches, np.float32)
        if w.shape != self._w.shape:
            raise bad("wrenches", f"array of shape {w.shape}", f"shape {self._w.shape} (history, wrench features)")
        self._x[:] = x
        self._w[:] = w
        self.ready = True
        K.node_step(self._f32, self._f64, self._arch, self._layers, self._no_wrench, self._no_wrench, False)
        return self._out

    def step(self, pose, wrench=None) -> np.ndarray:
        """Append the newest input row (P,) and wrench (W,); return the next position (3,) [m]."""
        if not self.ready:
            raise SoftrnnInputError("NodeStepper.step was called before reset: load a window of the last H "
                                    "samples with reset(poses, wrenches) first")
        if wrench is None:
            wrench = self._no_wrench
        if len(pose) != self.pose_features or len(wrench) != self.wrench_features:
            raise bad("pose, wrench", f"rows of {len(pose)} and {len(wrench)} values",
                      f"{self.pose_features} pose and {self.wrench_features} wrench values (one row of inputs I, II)")
        K.node_step(self._f32, self._f64, self._arch, self._layers, pose, wrench, True)
        return self._out


class ManipulatorStepper:
    """Every modelled node of a manipulator advanced together, one compiled call per sample and
    architecture (Fig. 2C).

    Parameters
    ----------
    models : Manipulator, NodeModel or sequence of NodeModel
        The node models (``softrnn.learned.node.manipulator.Manipulator``; nodes may share a model). Models
        of one architecture (``ModelConfig`` and normalisation mode) are stacked; the architectures
        must agree on history and wrench width.
    nodes : sequence of int
        The rod nodes whose positions make up the state (N), in state order; every modelled node
        and neighbour must be among them.
    threads : int
        1: serial. More: the nodes are split over numba's thread pool (``numba.set_num_threads``
        caps it); worth it from a few tens of nodes.

    Notes
    -----
    ``reset(positions (H, N, 3), wrenches (H, B, W), quaternions (H, N, 4) or None)`` loads the
    last H samples; ``step(wrench_next (B, W), boundary (N, 3) or None)`` predicts the modelled
    nodes' positions at the next sample, takes the other nodes' positions from ``boundary`` (None:
    they hold their pose, a clamp), stores ``wrench_next`` as the loads acting at that sample, and
    returns the new positions (N, 3) float32 [m] (a view reused by the next call). B counts the
    modelled nodes in ``modelled`` order; quaternions (for ``inputs="poses"`` models) hold their
    last value.
    """

    def __init__(self, models, nodes, *, threads: int = 1):

        manip = _as_manipulator(models)
        nodes = np.asarray(nodes, dtype=np.int64).reshape(-1)
        if isinstance(threads, bool) or not isinstance(threads, (int, np.integer)) or threads < 1:
            raise bad("threads", threads, "an integer >= 1")
        self.threads = int(threads)

        class _Nodes:   # bind() only needs the stored node list
            pass

        holder = _Nodes()
        holder.nodes = nodes
        bound = group_by_architecture(bind(manip, holder, "the stepper's node list"))
        shapes = {(g.engine.history, g.engine.wrench_features) for g in bound}
        if len(shapes) != 1:
            raise bad("models", f"(history, wrench width) pairs {sorted(shapes)}",
                      "models that agree on history and wrench inputs (one ManipulatorStepper per such set)")
        H, W = shapes.pop()
        self.history, self.wrench_features, self.n_nodes, self.nodes = H, W, int(nodes.size), nodes
        self.modelled = tuple(int(a) for g in bound for a in g.nodes)
        B = len(self.modelled)
        self._pos = np.zeros((H + 1, nodes.size, 3), np.float32)
        self._quat = np.zeros((H + 1, nodes.size, 4), np.float32)
        self._quat[..., 0] = 1.0
        self._wr = np.zeros((H + 1, B, W), np.float32)
        self._pred = np.zeros((B, 3))
        self._tgt = np.ascontiguousarray(np.concatenate([g.target_cols for g in bound]))
        self._calls = []
        lo = 0
        for g in bound:
            e, n = g.engine, g.which.size
            wr = self._wr[:, lo:lo + n] if len(bound) > 1 else self._wr
            head = (e.params, e.norm, e.arch, e.layers, g.which, g.input_cols, self._pos, self._quat, wr, H, _LIMIT,
                    self._pred[lo:lo + n])
            if len(e) == 1 and n > 1:   # one weight set: every layer one BLAS product over the nodes
                X, Wr, eb = _shared_scratch(e, n)
                if self.threads > 1 and n >= 2 * self.threads:
                    chunks = np.linspace(0, n, self.threads + 1).round().astype(np.int64)
                    eb = np.zeros((self.threads, eb.size), np.int32)
                    self._calls.append((K.predict_row_shared_parallel, head[:4] + head[5:] + (X, Wr, eb, chunks), lo))
                else:
                    self._calls.append((K.predict_row_shared, head[:4] + head[5:] + (X, Wr, eb), lo))
            elif self.threads > 1:
                n_wk = int(e.arch[0]["work_length"])
                tail = (np.zeros((n, n_wk), np.float32), np.zeros((n, n_wk), np.int32), np.zeros(n, np.int64))
                self._calls.append((K.predict_row_parallel, head + tail, lo))
            else:
                self._calls.append((K.predict_row, head + _scratch(e), lo))
            lo += n
        self._no_wrench = np.zeros((B, W), np.float32)
        self.ready = False

    @property
    def positions(self) -> np.ndarray:
        """(N, 3) float32 [m] the latest sample's positions (a view)."""
        return self._pos[self.history - 1]

    def reset(self, positions, wrenches=None, quaternions=None) -> None:
        """Load the last H samples: positions (H, N, 3) [m], wrenches (H, B, W), quaternions (H, N, 4)."""
        H, N, B, W = self.history, self.n_nodes, self._wr.shape[1], self.wrench_features
        x = np.asarray(positions, np.float32)
        if x.shape != (H, N, 3):
            raise bad("positions", f"array of shape {x.shape}", f"shape {(H, N, 3)} (history, nodes, xyz)")
        self._pos[:H] = x
        w = np.zeros((H, B, W), np.float32) if wrenches is None else np.asarray(wrenches, np.float32)
        if w.shape != (H, B, W):
            raise bad("wrenches", f"array of shape {w.shape}", f"shape {(H, B, W)} (history, modelled nodes, W)")
        self._wr[:H] = w
        if quaternions is not None:
            q = np.asarray(quaternions, np.float32)
            if q.shape != (H, N, 4):
                raise bad("quaternions", f"array of shape {q.shape}", f"shape {(H, N, 4)}")
            self._quat[:H] = q
        self.ready = True

    def step(self, wrench_next=None, boundary=None) -> np.ndarray:
        """Advance one sample; returns the new positions (N, 3) float32 [m] (a view)."""
        if not self.ready:
            raise SoftrnnInputError("ManipulatorStepper.step was called before reset: load the last H samples "
                                    "with reset(positions, wrenches) first")
        for kernel, args, lo in self._calls:
            status, b = kernel(*args)
            if status:
                node = self.modelled[lo + b]
                raise RolloutDiverged(f"the manipulator diverged: the model of node {node} predicted a position "
                                      f"beyond {_LIMIT:g} m (or not finite); reset the stepper from measured poses",
                                      node=node, sample=-1, time=float("nan"))
        hold = boundary is None
        if not hold:
            self._pos[self.history] = boundary
        K.commit_row(self._pos, self._quat, self._wr, self._no_wrench if wrench_next is None else wrench_next,
                     self._tgt, self._pred, hold)
        return self._pos[self.history - 1]


_LIMIT = 16.0   # softrnn.learned.horizons.DIVERGED_M


# ------------------------------------------------------------------------------------------ rollout
@dataclass(frozen=True, eq=False)
class BoundGroup:
    """Same-architecture models bound to a data set's columns (see ``rollout.bind``)."""

    engine: Engine
    which: np.ndarray       # (B,) model index of each predicted node
    nodes: np.ndarray       # (B,) predicted rod nodes
    target_cols: np.ndarray  # (B,) their data set columns
    input_cols: np.ndarray  # (B, K) window columns, node first
    wrench: str
    drive: str = "wrench"
    channel_cols: np.ndarray = None  # (m,) actuation columns of input II (drive != 'wrench')


def group_by_architecture(groups) -> list[BoundGroup]:
    """Stack ``rollout._Group`` entries (one per distinct model) into engines, one per architecture."""
    by_arch: dict = {}
    for g in groups:
        key = (_arch_key(g.model), g.wrench, g.drive, tuple(np.asarray(g.channel_cols).tolist()))
        by_arch.setdefault(key, []).append(g)
    out = []
    for gs in by_arch.values():
        engine = Engine([g.model for g in gs])
        which = np.concatenate([np.full(g.nodes.size, i, np.int64) for i, g in enumerate(gs)])
        out.append(BoundGroup(engine=engine, which=which, nodes=np.concatenate([g.nodes for g in gs]),
                              target_cols=np.concatenate([g.target_cols for g in gs]),
                              input_cols=np.ascontiguousarray(np.concatenate([g.input_cols for g in gs])),
                              wrench=gs[0].wrench, drive=gs[0].drive, channel_cols=gs[0].channel_cols))
    return out


def wrench_rows(forces, torques, cols, kind: str, actuation=None, channel_cols=None) -> np.ndarray:
    """(T, B, W) float32 inputs II of the nodes in data set columns ``cols``: their force and
    torque as ``kind`` says, then the ``channel_cols`` columns of ``actuation`` (T, m_all) (the
    same for every node; none when ``channel_cols`` is None or empty)."""
    parts = []
    if kind in ("force", "wrench"):
        parts.append(np.asarray(forces[:, cols], np.float32))
    if kind == "wrench":
        parts.append(np.asarray(torques[:, cols], np.float32))
    if channel_cols is not None and len(channel_cols):
        a = np.asarray(actuation, np.float32)[:, channel_cols]                  # (T, m)
        parts.append(np.broadcast_to(a[:, None], (a.shape[0], len(cols), a.shape[1])))
    if not parts:
        return np.zeros((forces.shape[0], len(cols), 0), np.float32)
    return np.ascontiguousarray(np.concatenate(parts, axis=-1))


def engine_rollout(bound: list[BoundGroup], positions, quaternions, forces, torques, k0: int, k1: int,
                   limit: float, actuation=None) -> tuple[int, int, int]:
    """Free-run rows ``k0 .. k1-1`` of ``positions`` (T, N, 3) float32 in place, every group's
    nodes updated synchronously (``actuation`` (T, m_all): the data set's actuation inputs, for
    models driven by them). Returns (status, node, k): 0 done, 1 the model of ``node``
    predicted a non-finite position or one beyond ``limit`` [m] at row k."""
    quats = np.ascontiguousarray(quaternions, dtype=np.float32)
    wrenches = [wrench_rows(forces, torques, g.target_cols, g.wrench, actuation, g.channel_cols) for g in bound]
    scratch = [(np.zeros((g.which.size, 3)),) + _scratch(g.engine) for g in bound]
    if len(bound) == 1 and len(bound[0].engine) == 1 and bound[0].which.size > 1:   # one shared model
        g, wr = bound[0], wrenches[0]
        e = g.engine
        status, b, k = K.rollout_steps_shared(e.params, e.norm, e.arch, e.layers, g.input_cols, g.target_cols,
                                              positions, quats, wr, k0, k1, float(limit), scratch[0][0],
                                              *_shared_scratch(e, g.which.size))
        return int(status), (int(g.nodes[b]) if status else -1), int(k)
    if len(bound) == 1:   # the common case: every step inside one kernel call
        g, (pred, wk, eb), wr = bound[0], scratch[0], wrenches[0]
        e = g.engine
        status, b, k = K.rollout_steps(e.params, e.norm, e.arch, e.layers, g.which, g.input_cols, g.target_cols,
                                       positions, quats, wr, k0, k1, float(limit), pred, wk, eb)
        return int(status), (int(g.nodes[b]) if status else -1), int(k)
    for k in range(k0, k1):   # several architectures: predict all, then write all (synchronous)
        preds = []
        for g, (pred, wk, eb), wr in zip(bound, scratch, wrenches):
            status, b, _ = _predict_row(g.engine, g, positions, quats, wr, k, float(limit), pred, wk, eb)
            if status:
                return 1, int(g.nodes[b]), k
            preds.append(pred.copy())
        for g, pred in zip(bound, preds):
            positions[k, g.target_cols] = pred.astype(np.float32)
    return 0, -1, k1


def _predict_row(e: Engine, g: BoundGroup, positions, quats, wr, k: int, limit: float, pred, wk, eb):
    """Predictions for row k into ``pred`` (B, 3) without writing them (status, b, k)."""
    H = e.history
    X = np.empty((g.which.size, H, e.pose_features), np.float32)
    rows = np.arange(k - H, k, dtype=np.int64)
    per = int(e.arch[0]["per_node"])
    for b in range(g.which.size):
        K.gather_window(positions, quats, rows, g.input_cols[b], per, X[b])
    K.predict_windows(e.params, e.norm, e.arch, e.layers, g.which, X,
                      np.ascontiguousarray(wr[k - H:k].transpose(1, 0, 2)), wk, eb, pred)
    bad_rows = ~(np.abs(pred) <= limit).all(axis=1)
    if bad_rows.any():
        return 1, int(np.flatnonzero(bad_rows)[0]), k
    return 0, -1, k
