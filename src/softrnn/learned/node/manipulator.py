"""The whole manipulator as a set of node models (paper Fig. 2C): which model predicts which node,
from which neighbours and wrenches, bound to a data set's columns. Shared by the free-running
rollout (``rollout``) and the compiled inference engine (``engine``), which both import it.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ...errors import SoftrnnInputError, bad
from ..horizons import DIVERGED_M, RolloutDiverged

UNMODELLED = ("reference", "hold")
_POSE_WIDTH = {"positions": 3, "poses": 7}
_WRENCH_WIDTH = {"none": 0, "force": 3, "wrench": 6}


# --------------------------------------------------------------------------------------- models
def _spec_of(model):
    spec = getattr(model, "spec", None)
    if spec is None or not callable(getattr(model, "predict", None)):
        raise bad("model", type(model).__name__,
                  "a NodeModel (softrnn.learned.node.artifact.load_model) with .spec and .predict")
    return spec


def model_inputs(model, node: int | None = None) -> tuple[int, tuple[int, ...]]:
    """(node, neighbours) the model reads when applied to ``node`` (default: its own ``spec.node``);
    neighbours are taken at the same offsets from the node as in the model's resolved spec."""
    spec = _spec_of(model)
    own = int(spec.node)
    if spec.neighbours is None:
        raise bad("model.spec", spec, "a resolved SampleSpec (neighbours filled in, as load_model gives)")
    neighbours = tuple(int(n) for n in spec.neighbours)
    if node is None:
        return own, neighbours
    node = int(node)
    return node, tuple(node + (n - own) for n in neighbours)


def describe_model(model) -> str:
    """A short text such as ``node 50 <- 49, 51; history 2; positions + force`` (``+ actuation
    tendon_1, tendon_2`` for a model driven by actuation inputs)."""
    spec = _spec_of(model)
    node, neigh = model_inputs(model)
    extra = {"none": "", "force": " + force", "wrench": " + force, torque"}.get(str(spec.wrench), "")
    if getattr(spec, "drive", "wrench") != "wrench":
        extra += " + actuation " + ", ".join(spec.channels or ("(all channels)",))
    return (f"node {node} <- {', '.join(map(str, neigh)) or 'no neighbours'}; history {int(spec.history)}; "
            f"{spec.inputs}{extra}")


@dataclass(frozen=True, eq=False)
class Manipulator:
    """Node models of a manipulator, stepped together by ``rollout``.

    Parameters
    ----------
    models : dict {node: model}
        The model predicting each node (``NodeModel`` or any object with ``spec`` and
        ``predict(poses (B,H,P), wrenches (B,H,W)) -> (B,3)`` [m]). One object may serve several
        nodes; for a node other than its ``spec.node`` the neighbours are shifted by the same offset.
        Build it with ``Manipulator.of(...)``.
    """

    models: dict

    def __post_init__(self):
        if not isinstance(self.models, dict) or not self.models:
            raise bad("models", type(self.models).__name__, "a non-empty dict {node: model}")
        clean = {}
        for node, model in self.models.items():
            if isinstance(node, bool) or not isinstance(node, (int, np.integer)) or node < 0:
                raise bad("node", node, "a 0-based node index >= 0")
            spec = _spec_of(model)
            if str(spec.inputs) not in _POSE_WIDTH:
                raise bad("spec.inputs", spec.inputs, "'positions' or 'poses'")
            if str(spec.wrench) not in _WRENCH_WIDTH:
                raise bad("spec.wrench", spec.wrench, "'none', 'force' or 'wrench'")
            if isinstance(spec.history, bool) or int(spec.history) < 1:
                raise bad("spec.history", spec.history, "an integer >= 1")
            clean[int(node)] = model
        object.__setattr__(self, "models", dict(sorted(clean.items())))

    @classmethod
    def of(cls, models=(), *, shared=None, shared_nodes=()) -> Manipulator:
        """Each model of ``models`` predicts its own ``spec.node``; ``shared`` (one model), if
        given, predicts every node of ``shared_nodes`` not already covered. Two models for one node
        is an error."""
        out: dict = {}
        for model in models:
            node = int(_spec_of(model).node)
            if node in out:
                raise bad("models", f"two models for node {node}", "one model per node")
            out[node] = model
        if shared is not None:
            _spec_of(shared)
            for node in shared_nodes:
                out.setdefault(int(node), shared)
        elif len(tuple(shared_nodes)):
            raise bad("shared_nodes", list(shared_nodes), "a shared model to apply to them")
        return cls(out)

    @property
    def nodes(self) -> tuple[int, ...]:
        """The modelled nodes, ascending."""
        return tuple(self.models)

    @property
    def history(self) -> int:
        """The longest history of the models: samples of seed a rollout needs."""
        return max(int(_spec_of(m).history) for m in self.models.values())

    def distinct_models(self) -> list:
        """The distinct model objects, in order of their first node."""
        seen: dict = {}
        for model in self.models.values():
            seen.setdefault(id(model), model)
        return list(seen.values())


# --------------------------------------------------------------------------------------- binding
@dataclass(frozen=True, eq=False)
class _Group:
    """All nodes that one model predicts, bound to a data set's columns."""

    model: object
    nodes: np.ndarray         # (B,) predicted nodes
    target_cols: np.ndarray   # (B,) their data set columns
    input_cols: np.ndarray    # (B, n_in) columns of [node, *neighbours] per row
    history: int
    inputs: str
    wrench: str
    drive: str = "wrench"
    channel_cols: np.ndarray = None   # (m,) columns of the data set's actuation in input II (drive != 'wrench')

    def gather(self, positions, quaternions, forces, torques, k: int, actuation=None):
        """Windows (poses (B,H,P) float32, wrenches (B,H,W) float32) for the targets at row k,
        read from rows k-H .. k-1 of the (T, N, c) arrays and of ``actuation`` (T, m_all), the
        data set's actuation inputs (needed when ``drive`` is not 'wrench')."""
        H = self.history
        rows = np.arange(k - H, k)
        B, n_in = self.input_cols.shape
        pos = positions[rows[:, None, None], self.input_cols[None]]            # (H, B, n_in, 3)
        if self.inputs == "poses":
            quat = quaternions[rows[:, None, None], self.input_cols[None]]     # (H, B, n_in, 4)
            pos = np.concatenate([pos, quat], axis=-1)
        poses = np.ascontiguousarray(pos.transpose(1, 0, 2, 3).reshape(B, H, -1), dtype=np.float32)
        parts = []
        if self.wrench in ("force", "wrench"):
            parts.append(forces[rows[:, None], self.target_cols[None]])         # (H, B, 3)
        if self.wrench == "wrench":
            parts.append(torques[rows[:, None], self.target_cols[None]])
        if self.drive != "wrench":
            a = np.asarray(actuation)[rows][:, self.channel_cols]                # (H, m)
            parts.append(np.broadcast_to(a[:, None], (H, B, a.shape[1])))      # (H, B, m)
        if parts:
            w = np.concatenate(parts, axis=-1).transpose(1, 0, 2)
        else:
            w = np.zeros((B, H, 0))
        return poses, np.ascontiguousarray(w, dtype=np.float32)


def _column_lookup(dataset) -> dict:
    return {int(a): j for j, a in enumerate(np.asarray(dataset.nodes))}


def _stored(nodes) -> str:
    nodes = [int(a) for a in nodes]
    if len(nodes) > 3 and nodes == list(range(nodes[0], nodes[-1] + 1)):
        return f"{nodes[0]}..{nodes[-1]}"
    if len(nodes) > 12:
        return ", ".join(map(str, nodes[:10])) + f", ... ({len(nodes)} nodes)"
    return ", ".join(map(str, nodes)) or "none"


def bind(manipulator: Manipulator, dataset, where: str = "the data set") -> list[_Group]:
    """Group the manipulator's nodes by model and look up their columns in ``dataset``; a node
    or neighbour the data set does not store is a one-line ``SoftrnnInputError``."""
    lookup = _column_lookup(dataset)
    groups = []
    for model in manipulator.distinct_models():
        spec = _spec_of(model)
        nodes = [a for a, m in manipulator.models.items() if m is model]
        rows = []
        for a in nodes:
            node, neigh = model_inputs(model, a)
            for b in (node, *neigh):
                if b not in lookup:
                    what = f"node {node}" if b == node else f"node {b} (a neighbour of node {node})"
                    raise SoftrnnInputError(
                        f"{where} does not store {what}, which the model ({describe_model(model)}) needs; "
                        f"stored nodes: {_stored(dataset.nodes)}; use a data set that stores the model's node "
                        f"and its neighbours")
            rows.append([lookup[b] for b in (node, *neigh)])
        groups.append(_Group(model=model, nodes=np.array(nodes, dtype=np.int64),
                             target_cols=np.array([r[0] for r in rows], dtype=np.int64),
                             input_cols=np.array(rows, dtype=np.int64).reshape(len(nodes), -1),
                             history=int(spec.history), inputs=str(spec.inputs), wrench=str(spec.wrench),
                             drive=str(getattr(spec, "drive", "wrench")),
                             channel_cols=_channel_cols(spec, dataset, where)))
    return groups


def _channel_cols(spec, dataset, where: str) -> np.ndarray:
    """(m,) columns of ``dataset.actuation`` holding the model's actuation channels (none for a
    wrench-driven model); a missing channel is a one-line ``SoftrnnInputError``."""
    if getattr(spec, "drive", "wrench") == "wrench":
        return np.zeros(0, dtype=np.int64)
    have = tuple(getattr(dataset, "actuation_names", ()))
    missing = [a for a in spec.channels if a not in have]
    if missing:
        raise SoftrnnInputError(f"{where} has no actuation channel {missing[0]!r}, which the model "
                                f"({_driven(spec)}) reads (its channels: {', '.join(have) or 'none'}); "
                                f"use a data set that records the model's actuation inputs")
    return np.array([have.index(a) for a in spec.channels], dtype=np.int64)


def _driven(spec) -> str:
    """``node N driven by actuation a, b`` for error messages."""
    return f"node {int(spec.node)} driven by actuation {', '.join(spec.channels)}"


def _diverged(node: int, t: float, sample: int):
    raise RolloutDiverged(
        f"the rollout diverged: the model of node {node} predicted a position beyond "
        f"{DIVERGED_M:g} m (or not finite) at t = {t:.6g} s (sample {sample}); the models' errors "
        f"grow without bound when fed their own predictions (try a shorter span, or models "
        f"trained for the nodes they predict)", node=node, sample=sample, time=t)


def _compiled(model) -> bool:
    """True for a NodeModel the compiled engine can run (any object with a NodeLSTM ``module``,
    ``config`` and ``normalizer``); other model objects are called through ``predict``."""
    from .model import NodeLSTM  # optional extra: learn (PyTorch)

    return isinstance(getattr(model, "module", None), NodeLSTM) and hasattr(model, "config") and hasattr(
        model, "normalizer")


def _as_manipulator(models) -> Manipulator:
    if isinstance(models, Manipulator):
        return models
    if hasattr(models, "predict"):
        return Manipulator.of([models])
    try:
        models = list(models)
    except TypeError:
        raise bad("models", type(models).__name__, "a Manipulator, a NodeModel or a list of NodeModels") from None
    return Manipulator.of(models)
