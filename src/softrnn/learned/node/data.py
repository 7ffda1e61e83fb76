"""Training samples of a per-node model (paper section 3, Fig. 2A/B).

A sample of node n is a window of H = eta + 1 consecutive past time steps,

* input I: the poses of the node and its neighbours, one row per step, laid out node first, then
  the neighbours in ``spec.neighbours`` order (``spec.window_nodes``); per node 3 position values
  (``inputs="positions"``) or 3 + 4 (position, then quaternion w x y z; ``inputs="poses"``);
* input II: the node's applied force (3) or force and torque (6) over the same steps (none for
  Fig. 2A), or the data set's actuation inputs (``Dataset.actuation``: tendon tensions, chamber
  pressures, coil currents, ...) over the same steps, or both, force first (``spec.drive``);

and the target is the node's position at the step after the window. The window of the target at
sample index i covers samples i-H .. i-1, so with ``make_windows(dataset, spec, start, stop)`` every
sample a window touches (inputs and target) lies in ``[start, stop)``.

``split`` cuts the series chronologically (the paper's first 60 % for training); the training and
test spans are disjoint and windows are built inside each span, so no window straddles the cut.
``Normalizer`` (``normalizer``) holds z-score statistics fitted on training windows only.
"""

from __future__ import annotations

import hashlib
import math
from dataclasses import dataclass, replace

import numpy as np

from ...errors import SoftrnnInputError, bad, is_int
from ..artifacts import from_fields
from .normalizer import NODE_POSITION, OUTPUTS, STD_RELATIVE_FLOOR, Normalizer  # noqa: F401 - re-exported

INPUTS = ("positions", "poses")
WRENCHES = ("none", "force", "wrench")
DRIVES = ("wrench", "actuation", "both")
"""What input II holds: the node's wrench (``SampleSpec.wrench``), the actuation channels, or both."""
_PER_NODE = {"positions": 3, "poses": 7}
_WRENCH_WIDTH = {"none": 0, "force": 3, "wrench": 6}


# ------------------------------------------------------------------------------------- SampleSpec
@dataclass(frozen=True, kw_only=True)
class SampleSpec:
    """Which node a model predicts and what its samples hold.

    Parameters
    ----------
    node : int
        Rod node index of the predicted node (negative: counted from the rod's end).
    neighbours : tuple of int or None
        Nodes whose poses join the node's in input I, in this order. None: ``(node-1, node+1)``
        restricted to the stored nodes' index range (one neighbour at an end of the rod). ``()``:
        the node alone.
    history : int
        H = eta + 1, past time steps per window (paper: 2, i.e. eta = 1).
    inputs : str
        ``"positions"`` (3 values per node) or ``"poses"`` (position and quaternion, 7 per node).
    wrench : str
        Input II: ``"none"`` (Fig. 2A), ``"force"`` (3) or ``"wrench"`` (force and torque, 6) of the
        node (Fig. 2B).
    train_fraction : float
        Leading fraction of the samples used for training (the paper's 60 %); the rest is the test span.
    drive : str
        What input II holds: ``"wrench"`` (default, the paper's: the node's wrench as ``wrench``
        says), ``"actuation"`` (the data set's actuation channels alone; ``wrench`` is set to
        ``"none"``) or ``"both"`` (the node's force or wrench, then the channels; ``wrench`` must
        not be ``"none"``).
    channels : tuple of str or None
        The actuation channels of input II, in this order (``Dataset.actuation_names``). None: every
        channel of the data set, filled in by ``resolve``. Unused (None) with ``drive="wrench"``.
    """

    node: int
    neighbours: tuple[int, ...] | None = None
    history: int = 2
    inputs: str = "positions"
    wrench: str = "force"
    train_fraction: float = 0.6
    drive: str = "wrench"
    channels: tuple[str, ...] | None = None

    def __post_init__(self):
        if not is_int(self.node):
            raise bad("node", self.node, "an integer node index")
        object.__setattr__(self, "node", int(self.node))
        if self.neighbours is not None:
            if isinstance(self.neighbours, (str, bytes)) or not hasattr(self.neighbours, "__iter__"):
                raise bad("neighbours", self.neighbours, "a sequence of integer node indices, or None")
            nb = tuple(self.neighbours)
            if not all(is_int(a) for a in nb):
                raise bad("neighbours", self.neighbours, "a sequence of integer node indices, or None")
            object.__setattr__(self, "neighbours", tuple(int(a) for a in nb))
        if not is_int(self.history) or self.history < 1:
            raise bad("history", self.history, "an integer >= 1 (past time steps per window, eta + 1; paper: 2)")
        object.__setattr__(self, "history", int(self.history))
        if self.inputs not in INPUTS:
            raise bad("inputs", self.inputs, "'positions' (3 per node) or 'poses' (positions and quaternions)")
        if self.wrench not in WRENCHES:
            raise bad("wrench", self.wrench, "'none' (Fig. 2A), 'force' or 'wrench' (force and torque, Fig. 2B)")
        if isinstance(self.train_fraction, bool) or not isinstance(self.train_fraction, (int, float, np.floating)) \
                or not 0.0 < float(self.train_fraction) < 1.0:
            raise bad("train_fraction", self.train_fraction, "a fraction strictly between 0 and 1 (paper: 0.6)")
        object.__setattr__(self, "train_fraction", float(self.train_fraction))
        self._check_drive()

    def _check_drive(self) -> None:
        """Validate ``drive`` and ``channels`` (and set ``wrench`` to 'none' for 'actuation')."""
        if self.drive not in DRIVES:
            raise bad("drive", self.drive, "'wrench' (the node's wrench), 'actuation' (the data set's actuation "
                                           "channels) or 'both'")
        if self.drive == "actuation":
            object.__setattr__(self, "wrench", "none")
        if self.drive == "both" and self.wrench == "none":
            raise bad("wrench", self.wrench, "'force' or 'wrench' with drive='both' (or drive='actuation' for the "
                                             "actuation channels alone)")
        if self.channels is None or self.drive == "wrench":
            if self.channels is not None:
                raise bad("channels", self.channels, "None with drive='wrench' (channels are actuation inputs)")
            return
        if isinstance(self.channels, (str, bytes)) or not hasattr(self.channels, "__iter__"):
            raise bad("channels", self.channels, "a sequence of actuation channel names, or None (all)")
        names = tuple(self.channels)
        if not names or not all(isinstance(a, str) for a in names) or len(set(names)) != len(names):
            raise bad("channels", self.channels, "distinct actuation channel names, at least one, or None (all)")
        object.__setattr__(self, "channels", names)

    def resolve_channels(self, names) -> SampleSpec:
        """This spec with ``channels`` taken from or checked against a data set's actuation channel
        ``names`` (``Dataset.actuation_names``); unchanged for ``drive="wrench"``.

        Raises
        ------
        SoftrnnInputError
            One line: the data set has no actuation (naming ``drive`` and the fix), or lacks a channel.
        """
        if self.drive == "wrench":
            return self
        have = tuple(names)
        if not have:
            raise SoftrnnInputError(
                f"drive={self.drive!r} is invalid: the data set has no actuation inputs; record them (CSV columns "
                f"act_<name>[<unit>], DatasetWriter(actuation_units=...)) or use drive='wrench'")
        missing = [a for a in (self.channels or ()) if a not in have]
        if missing:
            raise SoftrnnInputError(f"channels={list(self.channels)} is invalid: the data set has no actuation channel "
                                    f"{missing[0]!r} (it has {', '.join(have)}); pass some of those")
        return replace(self, channels=self.channels or have)

    # ------------------------------------------------------------------ resolution and layout
    def resolve(self, dataset_nodes, *, n_nodes_total: int | None = None) -> SampleSpec:
        """This spec with absolute node indices and the neighbours filled in, checked against the
        stored nodes.

        Parameters
        ----------
        dataset_nodes : array-like of int (N,)
            The stored rod node indices (``Dataset.nodes``).
        n_nodes_total : int or None
            Nodes of the rod (``Dataset.attrs['n_nodes_total']``), for negative indices; default:
            the largest stored node + 1.

        Raises
        ------
        SoftrnnInputError
            A node or neighbour that is not stored, a neighbour equal to the node, or duplicates.
        """
        stored = [int(a) for a in np.asarray(dataset_nodes).reshape(-1)]
        if not stored:
            raise bad("dataset_nodes", stored, "a non-empty list of stored node indices")
        total = int(n_nodes_total) if n_nodes_total is not None else max(stored) + 1
        have = set(stored)

        def absolute(a: int) -> int:
            return a + total if a < 0 else a

        node = absolute(self.node)
        if node not in have:
            raise SoftrnnInputError(f"node={self.node} is invalid: the dataset does not store it "
                                    f"(stored nodes: {_node_text(stored)}); pass one of those")
        if self.neighbours is None:
            lo, hi = min(stored), max(stored)
            neighbours = tuple(a for a in (node - 1, node + 1) if lo <= a <= hi)
        else:
            neighbours = tuple(absolute(a) for a in self.neighbours)
        for a in neighbours:
            if a not in have:
                raise SoftrnnInputError(f"neighbours={list(neighbours)} is invalid: node {a} is not stored "
                                        f"(stored nodes: {_node_text(stored)}); pass stored nodes as neighbours")
        if node in neighbours or len(set(neighbours)) != len(neighbours):
            raise bad("neighbours", list(neighbours), f"distinct nodes other than the node itself ({node})")
        return replace(self, node=node, neighbours=neighbours)

    @property
    def resolved(self) -> bool:
        """True once ``neighbours`` is filled in (``resolve``) and, for an actuation input, the
        ``channels`` (``resolve_channels``)."""
        return self.neighbours is not None and (self.drive == "wrench" or self.channels is not None)

    def _need_resolved(self, what: str) -> tuple[int, ...]:
        if self.neighbours is None:
            raise SoftrnnInputError(f"SampleSpec.{what} needs the neighbours: call spec.resolve(dataset.nodes) "
                                    f"first (neighbours=None means 'the adjacent stored nodes')")
        return self.neighbours

    @property
    def window_nodes(self) -> tuple[int, ...]:
        """The nodes of input I in column order: the node, then its neighbours."""
        return (self.node,) + self._need_resolved("window_nodes")

    @property
    def per_node(self) -> int:
        """Pose values per node: 3 (positions) or 7 (position, quaternion w x y z)."""
        return _PER_NODE[self.inputs]

    @property
    def pose_features(self) -> int:
        """P, values per step of input I: 3 or 7 per node x (1 + len(neighbours))."""
        return self.per_node * (1 + len(self._need_resolved("pose_features")))

    @property
    def wrench_features(self) -> int:
        """W, values per step of input II: 0, 3 (force) or 6 (force, torque), plus the m actuation
        channels with ``drive`` 'actuation' or 'both'."""
        if self.drive != "wrench" and self.channels is None:
            raise SoftrnnInputError("SampleSpec.wrench_features needs the actuation channels: call "
                                    "spec.resolve_channels(dataset.actuation_names) first")
        return _WRENCH_WIDTH[self.wrench] + (len(self.channels) if self.drive != "wrench" else 0)

    def to_dict(self) -> dict:
        """JSON-ready fields (``SampleSpec(**d)`` rebuilds it); ``drive`` and ``channels`` only when
        the drive is not the default 'wrench' (so older model folders and new ones of wrench models
        read alike)."""
        d = {"node": self.node, "neighbours": None if self.neighbours is None else list(self.neighbours),
             "history": self.history, "inputs": self.inputs, "wrench": self.wrench,
             "train_fraction": self.train_fraction}
        if self.drive != "wrench":
            d.update(drive=self.drive, channels=None if self.channels is None else list(self.channels))
        return d

    @classmethod
    def from_dict(cls, d: dict) -> SampleSpec:
        """Inverse of ``to_dict``; unknown or missing keys raise SoftrnnInputError."""
        return from_fields(cls, d, "spec", tuples=("neighbours", "channels"))


def _node_text(nodes) -> str:
    nodes = sorted(int(a) for a in nodes)
    if len(nodes) > 3 and nodes == list(range(nodes[0], nodes[-1] + 1)):
        return f"{nodes[0]}..{nodes[-1]}"
    if len(nodes) > 12:
        return ", ".join(map(str, nodes[:10])) + f", ... ({len(nodes)} nodes)"
    return ", ".join(map(str, nodes))


# ----------------------------------------------------------------------------------------- rows
def pose_rows(dataset, spec: SampleSpec, start: int = 0, stop: int | None = None) -> np.ndarray:
    """Input I values per sample: (T', P) float32 for samples ``start:stop``, columns in
    ``spec.window_nodes`` order (the layout of ``Windows.poses[:, k]``).

    ``dataset`` is a ``softrnn.io.Dataset`` (or any object with ``nodes``, ``positions``,
    ``quaternions`` and ``attrs``) storing the window nodes; ``spec`` must be resolved.
    """
    cols = _columns(dataset, spec)
    pos = np.asarray(dataset.positions)[start:stop][:, cols]          # (T', K, 3)
    if spec.inputs == "poses":
        quat = np.asarray(dataset.quaternions)[start:stop][:, cols]   # (T', K, 4)
        pos = np.concatenate([pos, quat], axis=2)                      # (T', K, 7)
    return np.ascontiguousarray(pos.reshape(pos.shape[0], -1), dtype=np.float32)  # (T', P)


def wrench_rows(dataset, spec: SampleSpec, start: int = 0, stop: int | None = None) -> np.ndarray:
    """Input II values per sample: (T', W) float32 of samples ``start:stop``: the node's force [N]
    (3) and torque [N m] (3) as ``spec.wrench`` says, then the ``spec.channels`` actuation inputs
    (m, in their units) with ``spec.drive`` 'actuation' or 'both'."""
    col = _columns(dataset, spec)[0]
    n = len(np.asarray(dataset.time)[start:stop])
    parts = [np.zeros((n, 0), dtype=np.float32)]                       # (T', 0)
    if spec.wrench != "none":
        parts.append(np.asarray(dataset.forces)[start:stop, col])      # (T', 3)
    if spec.wrench == "wrench":
        parts.append(np.asarray(dataset.torques)[start:stop, col])     # (T', 3)
    if spec.drive != "wrench":
        parts.append(actuation_rows(dataset, spec)[start:stop])        # (T', m)
    return np.ascontiguousarray(np.concatenate(parts, axis=1), dtype=np.float32)  # (T', W)


def wrench_units(dataset, spec: SampleSpec) -> tuple[str, ...]:
    """The unit of every input II column (W,), in ``wrench_rows``' order: "N" for the forces, "N m"
    for the torques, then each actuation channel's unit from the data set (``Dataset.actuation_units``).
    ``Normalizer.fit`` floors the spread of each unit's columns separately."""
    units = {"none": (), "force": ("N",) * 3, "wrench": ("N",) * 3 + ("N m",) * 3}[spec.wrench]
    if spec.drive != "wrench":
        have = dict(getattr(dataset, "actuation_units", {}) or {})
        units += tuple(str(have.get(a, "")) for a in spec.channels)
    return units


def actuation_rows(dataset, spec: SampleSpec) -> np.ndarray:
    """(T, m) the data set's actuation inputs of ``spec.channels``, in that order (float32; m = 0
    for ``drive='wrench'``); a channel the data set lacks is a one-line SoftrnnInputError."""
    names = tuple(getattr(dataset, "actuation_names", ()))
    T = len(np.asarray(dataset.time))
    if spec.drive == "wrench":
        return np.zeros((T, 0), dtype=np.float32)
    spec.resolve_channels(names)                                       # the one-line errors
    cols = [names.index(a) for a in spec.channels]
    return np.asarray(dataset.actuation, dtype=np.float32)[:, cols]   # (T, m)


def _columns(dataset, spec: SampleSpec) -> list[int]:
    nodes = spec.window_nodes
    stored = {int(a): j for j, a in enumerate(np.asarray(dataset.nodes).reshape(-1))}
    missing = [a for a in nodes if a not in stored]
    if missing:
        raise SoftrnnInputError(f"node {missing[0]} is invalid: the dataset does not store it (stored nodes: "
                                f"{_node_text(stored)}); read the dataset with nodes={list(nodes)}")
    return [stored[a] for a in nodes]


# -------------------------------------------------------------------------------------- windows
@dataclass(frozen=True)
class Windows:
    """M samples in physical units.

    Attributes
    ----------
    poses : ndarray (M, H, P) float32
        Input I: poses of the window nodes over the H steps before the target [m, 1].
    wrenches : ndarray (M, H, W) float32
        Input II: the node's force (and torque) [N, N m] and/or the actuation channels (in their
        units) over the same steps (``wrench_rows``); W may be 0.
    targets : ndarray (M, 3) float32
        The node's position at the next step [m].
    index : ndarray (M,) int64
        Sample index of each target; its window covers samples index-H .. index-1.
    """

    poses: np.ndarray
    wrenches: np.ndarray
    targets: np.ndarray
    index: np.ndarray

    def __len__(self) -> int:
        return int(self.index.shape[0])

    def take(self, which) -> Windows:
        """The windows selected by ``which`` (indices, a slice or a boolean mask)."""
        return Windows(poses=self.poses[which], wrenches=self.wrenches[which], targets=self.targets[which],
                       index=self.index[which])

    @property
    def last_position(self) -> np.ndarray:
        """(M, 3) the node's position at the last step of each window [m]."""
        return self.poses[:, -1, NODE_POSITION]


def make_windows(dataset, spec: SampleSpec, start: int, stop: int) -> Windows:
    """Every window that lies entirely inside samples ``[start, stop)``.

    Parameters
    ----------
    dataset : softrnn.io.Dataset or a Dataset-like object
        Storing at least the window nodes (``read_dataset(path, nodes=spec.window_nodes)``).
    spec : SampleSpec
        Resolved against the dataset's nodes if it is not yet.
    start, stop : int
        Sample span, 0 <= start <= stop <= T. Targets are the samples ``start+H .. stop-1``.

    Returns
    -------
    Windows
        M = max(0, stop - start - H) samples, in chronological order.
    """
    if not spec.resolved:
        if spec.neighbours is None:
            total = (getattr(dataset, "attrs", None) or {}).get("n_nodes_total")
            spec = spec.resolve(dataset.nodes, n_nodes_total=total)
        spec = spec.resolve_channels(getattr(dataset, "actuation_names", ()))
    T = int(np.asarray(dataset.time).shape[0])
    for name, value in (("start", start), ("stop", stop)):
        if not is_int(value) or not 0 <= value <= T:
            raise bad(name, value, f"a sample index in 0..{T}")
    if stop < start:
        raise bad("stop", stop, f"an index >= start ({start})")
    H = spec.history
    M = max(0, stop - start - H)
    rows = pose_rows(dataset, spec, start, stop)                     # (L, P), L = stop - start
    wr = wrench_rows(dataset, spec, start, stop)                     # (L, W)
    col = _columns(dataset, spec)[0]
    P, W = rows.shape[1], wr.shape[1]
    if M == 0:
        return Windows(poses=np.zeros((0, H, P), np.float32), wrenches=np.zeros((0, H, W), np.float32),
                       targets=np.zeros((0, 3), np.float32), index=np.zeros(0, np.int64))
    # window m covers rows m .. m+H-1 and predicts row m+H
    poses = np.lib.stride_tricks.sliding_window_view(rows[:-1], H, axis=0)     # (M, P, H) view
    poses = np.ascontiguousarray(poses.transpose(0, 2, 1))                     # (M, H, P)
    wrenches = np.lib.stride_tricks.sliding_window_view(wr[:-1], H, axis=0)    # (M, W, H) view
    wrenches = np.ascontiguousarray(wrenches.transpose(0, 2, 1))               # (M, H, W)
    targets = np.ascontiguousarray(np.asarray(dataset.positions)[start + H:stop, col], dtype=np.float32)  # (M, 3)
    index = np.arange(start + H, stop, dtype=np.int64)                         # (M,)
    return Windows(poses=poses, wrenches=wrenches, targets=targets, index=index)


def split(n_samples: int, spec: SampleSpec) -> tuple[range, range]:
    """Chronological train/test spans of sample indices.

    Returns ``(range(0, cut), range(cut, n_samples))`` with ``cut = floor(train_fraction *
    n_samples)``. Build the windows of each span with ``make_windows(dataset, spec, r.start,
    r.stop)``: the test windows then start at or after the cut, and no training window reaches it.

    Raises
    ------
    SoftrnnInputError
        A span too short to hold one window (history + 1 samples).
    """
    if not is_int(n_samples) or n_samples < 0:
        raise bad("n_samples", n_samples, "a number of samples >= 0")
    cut = int(math.floor(spec.train_fraction * n_samples))
    check_spans(spec, cut, n_samples - cut, f"the {n_samples} samples split at {spec.train_fraction:g} give spans "
                                            f"of {cut} and {n_samples - cut} samples")
    return range(0, cut), range(cut, n_samples)


def check_spans(spec: SampleSpec, first: int, second: int, split_as: str) -> None:
    """Refuse ``spec``'s history where either of two spans (``first``, ``second`` samples; cut as
    ``split_as`` says, for the message) is too short to hold one window (history + 1 samples)."""
    need = spec.history + 1
    if min(first, second) < need:
        raise bad("history", spec.history, f"a history that fits the data: {split_as}, and a window needs "
                                           f"history + 1 = {need}; use a shorter history or a longer dataset")


def node_positions_sha256(data, node: int) -> str:
    """SHA-256 (hex) of ``node``'s positions in ``data`` (as float32, the files' precision): tells
    a model's training record apart from another file, wherever it was moved or renamed."""
    col = int(np.flatnonzero(np.asarray(data.nodes) == int(node))[0])
    column = np.ascontiguousarray(np.asarray(data.positions)[:, col], dtype=np.float32)
    return hashlib.sha256(column.tobytes()).hexdigest()


IRREGULAR_DT_TOLERANCE = 0.1
"""Largest relative difference between a model's and a recording's sample intervals where the rows
come at irregular intervals (``dt`` is then the median
step): sessions of one lab loop differ a little in their median."""


def regular_times(data) -> bool:
    """Whether every step of ``data.time`` is its nominal ``dt`` (to 1e-6 of it)."""
    steps, dt = np.diff(np.asarray(data.time, dtype=float)), data.attrs.get("dt")
    return steps.size == 0 or not isinstance(dt, (int, float)) or bool(np.max(np.abs(steps - dt)) <= 1e-6 * dt)
