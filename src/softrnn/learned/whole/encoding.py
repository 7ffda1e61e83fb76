"""What a whole-manipulator model sees, and the way back to every node (NumPy only).

A model steps at ``stride`` times the data's saved interval (its own, coarser step) on a subset of
the nodes (``kept``: every ``node_stride``-th node and both ends). Each kept node's pose is encoded
relative to a fixed reference pose of the rod (the first sample of the first training trajectory):

* the displacement ``r - r_ref`` [m] (world frame) and
* the rotation vector ``log(R_ref^T R)`` [rad] (body frame of the reference: bending and twist),

so one state row is (M, 6). The applied loads reach the model as the mean force and torque over
each model step (the loads are known inputs over time), lumped onto the kept nodes with the linear
"hat" weights along the rod (the total force is kept; the small moment of moving a force along the
rod to a kept node is not added). With actuation inputs (``Encoding.drive`` 'actuation' or 'both')
the data's actuation channels (tendon tensions, pressures, currents: ``Dataset.actuation``) are also
averaged over each model step and given to every kept node alike, after the wrench's 6 channels
('both') or instead of them ('actuation'). A hub's channels (``softrnn.io.schema.hub_inputs``: its
prescribed insertion and rotation, or the force and torque that drive it) are inputs whatever the
drive; with 'wrench' the encoding reads them as 'both' with those channels alone.

**Prescribed nodes** (``Encoding.prescribed``): a clamp that the scenario moves along a prescribed
path (``[[boundary]]`` of kind clamp with a displacement or rotation) is not predicted. Its pose is
known: its change of state over each model step (6 numbers per prescribed node) is appended to every
kept node's load channels, and a model step sets the node to its last state plus that change, so in
a free run it follows its recorded path exactly and the other nodes are driven by it.

**Contact inputs** (``Encoding.contact``): where the data record obstacles, each kept node's signed
gap to the nearest obstacle and its normal (``obstacles.ContactFeatures``, 4 channels) follow the
wrench and actuation channels, before the prescribed nodes' ones. A free run measures them on its
own state at every step (``Trajectory.inputs``); the network's correction reads them, its linear
term does not.

**The vessel frame** (``Encoding.frame``, a ``frame.VesselFrame``): the displacement and rotation
columns are taken in curvilinear coordinates along the centreline of the data's vessel instead of
the world frame (``softrnn.learned.whole.frame``); the loads stay in the world frame.

Decoding interpolates displacements and rotation vectors along the node index with a cubic spline,
so every node gets a pose and orientations stay unit quaternions by construction (in the vessel
frame the interpolated coordinates are then mapped to the world, so the nodes follow the vessel).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.interpolate import CubicSpline
from scipy.spatial.transform import Rotation

from ...errors import SoftrnnInputError, bad
from ...io.schema import HUB_CHANNELS, hub_inputs
from .config import path_columns, resolve_stride
from .feedback import feedback_of, moving_clamps
from .frame import FramedFeatures, FramedProjection, LocalPose, vessel_frame
from .obstacles import CONTACT_CHANNELS, ContactFeatures, ObstacleProjection, rod_radius

FIXED_TOLERANCE_M = 1e-9
"""A kept node whose position never moves by more than this [m], and whose orientation never turns
(1 - |q . q_ref| at most ``FIXED_TURN``, about 3 mrad; float32 quaternions are not exactly unit),
in any training trajectory is held at the reference (a clamped boundary) instead of being
predicted."""
FIXED_TURN = 1e-6


def _rotation(q: np.ndarray) -> Rotation:
    """scipy Rotation of scalar-first quaternions (..., 4), flattened."""
    q = np.asarray(q, dtype=np.float64).reshape(-1, 4)
    return Rotation.from_quat(q[:, [1, 2, 3, 0]])


def _quaternions(rot: Rotation, shape: tuple[int, ...]) -> np.ndarray:
    """Scalar-first unit quaternions with w >= 0, reshaped to ``shape + (4,)``."""
    q = rot.as_quat()[:, [3, 0, 1, 2]]
    q *= np.where(q[:, :1] < 0, -1.0, 1.0)
    return q.reshape(*shape, 4)


def kept_nodes(n_nodes: int, node_stride: int) -> np.ndarray:
    """Every ``node_stride``-th node from 0 and the last node: (M,) int64."""
    kept = list(range(0, n_nodes, node_stride))
    if kept[-1] != n_nodes - 1:
        kept.append(n_nodes - 1)
    return np.asarray(kept, dtype=np.int64)


def lumping_matrix(n_nodes: int, kept: np.ndarray) -> np.ndarray:
    """(M, N) hat weights: node i between kept nodes a < b gives (b - i)/(b - a) of its load to a
    and the rest to b; every column sums to 1."""
    P = np.zeros((len(kept), n_nodes))
    for j in range(len(kept) - 1):
        a, b = int(kept[j]), int(kept[j + 1])
        i = np.arange(a, b + 1)
        w = (b - i) / (b - a)
        P[j, a:b + 1] = np.maximum(P[j, a:b + 1], w)
        P[j + 1, a:b + 1] = 1.0 - w
    P[:, kept] = np.eye(len(kept))
    return P


@dataclass(frozen=True, eq=False)
class Trajectory:
    """One trajectory as a model sees it: ``states`` (S, M, 6) encoded poses at the model's step
    times ``time`` (S,) [s] and ``loads`` (S, M, L): the mean force [N] and torque [N m] over each
    step (the last row: the last sample's loads), L = 6, or with actuation inputs the mean of each
    channel over the step (in its unit), L = m ('actuation') or 6 + m ('both'). ``feedback``: the
    PD laws applied to the model's own state (``softrnn.learned.whole.feedback``; their nodes' recorded
    forces are not in ``loads``), or None. ``name`` says where it came from."""

    time: np.ndarray
    states: np.ndarray
    loads: np.ndarray
    name: str = ""
    feedback: object = None
    prescribed: tuple = ()
    projection: object = None
    contact: object = None
    contact_columns: slice | None = None

    def inputs(self, hist: np.ndarray, k: int) -> np.ndarray:
        """The loads (M, L) of model step ``k`` given the history ``hist`` (H, M, 6) ending at state
        k: the recorded loads plus the feedback laws' forces from ``hist``'s last two states, and the
        contact inputs (``contact``, a ``ContactFeatures``) measured on ``hist``'s last state."""
        if self.feedback is None and self.contact is None:
            return self.loads[k]
        out = np.array(self.loads[k], dtype=np.float64)
        if self.feedback is not None:
            out[:, :6] += self.feedback.force(hist[-1], hist[-2], k)
        if self.contact is not None:
            out[:, self.contact_columns] = self.contact(hist[-1])
        return out

    def forced_loads(self) -> np.ndarray:
        """The loads (S, M, L) with the feedback laws applied to the recorded states (teacher forcing)."""
        if self.feedback is None:
            return self.loads
        out = np.array(self.loads, dtype=np.float64)
        out[..., :6] += self.feedback.forced(self.states)
        return out

    def follow(self, nxt: np.ndarray, x: np.ndarray, loads: np.ndarray) -> np.ndarray:
        """``nxt`` (M, 6) with each prescribed node set to its state ``x`` (M, 6) plus its change over
        the step, read from the step's ``loads`` (M, L) (``Encoding.prescribed_columns``), in place;
        a baseline that knows nothing of the prescribed path follows it this way."""
        for m, c in self.prescribed:
            nxt[m] = x[m] + loads[m, c:c + 6]
        return nxt

    def project(self, nxt: np.ndarray) -> np.ndarray:
        """``nxt`` (M, 6) with its predicted nodes moved out of the data's obstacles, in place
        (``softrnn.learned.whole.obstacles``; unchanged without ``projection``)."""
        return nxt if self.projection is None else self.projection(nxt)

    def projected(self, states: np.ndarray) -> np.ndarray:
        """``states`` (K, M, 6) with every finite row moved out of the data's obstacles (in place)."""
        if self.projection is not None:
            for row in states:
                if np.all(np.isfinite(row)):
                    self.project(row)
        return states

    @property
    def n_steps(self) -> int:
        """S, the model steps held."""
        return int(self.states.shape[0])


@dataclass(frozen=True, eq=False)
class Encoding:
    """The state layout of a whole-manipulator model.

    Parameters
    ----------
    n_nodes : int
        N, the rod's nodes (all of them must be in the data)
    kept : ndarray (M,)
        the predicted nodes (0-based), increasing, both ends included
    model_dt : float
        the model's step [s]; a data set is read every model_dt / its dt samples
    data_dt : float
        the training data's saved interval [s] (for the record)
    length : float
        rod length L [m] (errors are reported in % of it)
    ref_positions : ndarray (N, 3)
        reference positions [m]
    ref_quaternions : ndarray (N, 4)
        reference orientations, scalar-first unit quaternions
    fixed : ndarray (M,) bool
        kept nodes held at the reference (clamped boundaries)
    prescribed : ndarray (M,) bool or None
        kept nodes moved along a prescribed path (a moving clamp): inputs, not predicted (None:
        none)
    contact : bool
        each kept node's gap to the nearest obstacle and its normal are load channels
        (``contact_columns``; the data's recorded obstacles, none where a data set has none)
    obstacles : bool
        keep the predicted nodes of a free run out of a data set's obstacles (its recorded
        contact; ``softrnn.learned.whole.obstacles``)
    feedback : bool
        apply the PD laws of a data set's scenario to the model's own state
        (``softrnn.learned.whole.feedback``) instead of taking their recorded forces
    drive : str
        the load input: 'wrench' (6 channels), 'actuation' (the m channels) or 'both' (6 + m), as
        ``DynamicConfig.drive``
    channels : tuple of str
        the actuation channels read (``Dataset.actuation_names``), () for 'wrench'
    frame : VesselFrame or None
        the state's displacements and rotations in curvilinear coordinates along this vessel's
        centreline (``softrnn.learned.whole.frame``); None: the world frame
    """

    n_nodes: int
    kept: np.ndarray
    model_dt: float
    data_dt: float
    length: float
    ref_positions: np.ndarray
    ref_quaternions: np.ndarray
    fixed: np.ndarray
    feedback: bool = False
    drive: str = "wrench"
    channels: tuple = ()
    prescribed: np.ndarray | None = None
    obstacles: bool = False
    contact: bool = False
    frame: object = None

    def __post_init__(self):
        object.__setattr__(self, "channels", tuple(str(a) for a in self.channels))
        if (self.drive == "wrench") != (not self.channels):
            raise bad("channels", list(self.channels), "actuation channels exactly when drive is 'actuation' or 'both'")
        kept = np.asarray(self.kept, dtype=np.int64)
        ends = len(kept) >= 2 and kept[0] == 0 and kept[-1] == self.n_nodes - 1
        if kept.ndim != 1 or not ends or np.any(np.diff(kept) <= 0):
            raise bad("kept", kept.tolist(), f"increasing node indices from 0 to {self.n_nodes - 1}")
        object.__setattr__(self, "kept", kept)
        object.__setattr__(self, "ref_positions", np.asarray(self.ref_positions, dtype=np.float64))
        object.__setattr__(self, "ref_quaternions", np.asarray(self.ref_quaternions, dtype=np.float64))
        object.__setattr__(self, "fixed", np.asarray(self.fixed, dtype=bool))
        presc = np.zeros(len(kept), dtype=bool) if self.prescribed is None else np.asarray(self.prescribed, dtype=bool)
        if presc.shape != (len(kept),) or np.any(presc & self.fixed):
            raise bad("prescribed", presc.tolist(), f"{len(kept)} flags, one per kept node, none on a fixed node")
        object.__setattr__(self, "prescribed", presc)
        object.__setattr__(self, "_lump", lumping_matrix(self.n_nodes, kept))
        object.__setattr__(self, "_pose", None if self.frame is None else
                           LocalPose(self.frame, self.ref_positions, _rotation(self.ref_quaternions)))

    def stride(self, dt: float) -> int:
        """The model's step in samples of data saved every ``dt`` [s]."""
        return resolve_stride(self.model_dt, dt)

    @property
    def load_width(self) -> int:
        """L, load channels per kept node: 6 (wrench), m (actuation) or 6 + m (both), 4 more with
        contact inputs and 6 more per prescribed node."""
        return ((0 if self.drive == "actuation" else 6) + len(self.channels) + self.n_contact
                + 6 * int(self.prescribed.sum()))

    @property
    def n_contact(self) -> int:
        """The contact input channels per kept node: 4 with ``contact``, else 0."""
        return CONTACT_CHANNELS if self.contact else 0

    @property
    def contact_columns(self) -> slice | None:
        """Where the contact inputs sit among the load channels (before the prescribed nodes'), or None."""
        if not self.contact:
            return None
        end = self.load_width - 6 * int(self.prescribed.sum())
        return slice(end - CONTACT_CHANNELS, end)

    @property
    def prescribed_columns(self) -> tuple:
        """((kept index m, first load column c), ...) of the prescribed nodes: the node's change of
        state over a step sits in load channels c .. c + 5 (the last 6 P channels, in node order)."""
        return path_columns(self.prescribed, self.load_width)

    @property
    def n_kept(self) -> int:
        """M, the kept nodes (the model's state)."""
        return int(len(self.kept))

    @property
    def n_predicted(self) -> int:
        """The kept nodes the model predicts: all but the prescribed ones (fixed nodes count, as
        the model holds them)."""
        return self.n_kept - int(self.prescribed.sum())

    def node_features(self) -> np.ndarray:
        """Per-node constants (M, 3): arc position s/L in [0, 1], distance to the nearest fixed node
        in units of L (1 where none is fixed), and the fixed flag."""
        s = self.kept / (self.n_nodes - 1)
        if self.fixed.any():
            d = np.min(np.abs(s[:, None] - s[self.fixed][None, :]), axis=1)
        else:
            d = np.ones_like(s)
        return np.stack([s, d, self.fixed.astype(float)], axis=1)

    # ------------------------------------------------------------------ poses
    def encode(self, positions: np.ndarray, quaternions: np.ndarray) -> np.ndarray:
        """Poses of all N nodes (T, N, 3) [m] and (T, N, 4) -> states (T, M, 6)."""
        p = np.asarray(positions, dtype=np.float64)[:, self.kept]
        q = np.asarray(quaternions, dtype=np.float64)[:, self.kept]
        if self._pose is not None:
            return self._pose.encode(p, _rotation(q), self.kept)
        T, M = p.shape[:2]
        ref = _rotation(np.broadcast_to(self.ref_quaternions[self.kept], (T, M, 4)))
        theta = (ref.inv() * _rotation(q)).as_rotvec().reshape(T, M, 3)
        return np.concatenate([p - self.ref_positions[self.kept], theta], axis=-1)

    def decode(self, states: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """States (T, M, 6) -> positions (T, N, 3) [m] and unit quaternions (T, N, 4) of every node,
        interpolated along the node index (cubic spline) between kept nodes."""
        X = np.asarray(states, dtype=np.float64)
        if X.ndim != 3 or X.shape[1:] != (self.n_kept, 6):
            raise bad("states", f"array of shape {X.shape}", f"shape (T, {self.n_kept}, 6)")
        T = X.shape[0]
        if self.n_kept == self.n_nodes:
            full = X
        else:
            full = CubicSpline(self.kept, X, axis=1)(np.arange(self.n_nodes))
        if self._pose is not None:
            return self._pose.positions(full), _quaternions(self._pose.rotations(full), (T, self.n_nodes))
        positions = self.ref_positions[None] + full[..., :3]
        ref = _rotation(np.broadcast_to(self.ref_quaternions, (T, self.n_nodes, 4)))
        rot = ref * Rotation.from_rotvec(full[..., 3:].reshape(-1, 3))
        return positions, _quaternions(rot, (T, self.n_nodes))

    def positions(self, states: np.ndarray) -> np.ndarray:
        """Positions of every node (T, N, 3) [m] from states (T, M, 6) (no orientations)."""
        X = np.asarray(states, dtype=np.float64)[..., :3]
        full = X if self.n_kept == self.n_nodes else CubicSpline(self.kept, X, axis=1)(np.arange(self.n_nodes))
        if self._pose is not None:
            return self._pose.positions(full)
        return self.ref_positions[None] + full

    # ------------------------------------------------------------------ loads
    def loads(self, forces: np.ndarray, torques: np.ndarray, n_steps: int, k: int) -> np.ndarray:
        """Data-rate loads (T, N, 3) [N] and [N m] -> (n_steps, M, 6): the mean over each model step
        of ``k`` samples (samples j*k .. j*k + k - 1), lumped onto the kept nodes."""
        W = np.concatenate([np.asarray(forces, dtype=np.float64), np.asarray(torques, dtype=np.float64)], axis=-1)
        out = np.empty((n_steps, self.n_nodes, 6))
        full = min(n_steps, W.shape[0] // k)
        if full:
            out[:full] = W[:full * k].reshape(full, k, self.n_nodes, 6).mean(axis=1)
        for j in range(full, n_steps):
            out[j] = W[j * k:(j + 1) * k].mean(axis=0)
        return np.einsum("mn,tnc->tmc", self._lump, out)

    def trajectory(self, dataset, name: str = "") -> Trajectory:
        """A ``softrnn.io.Dataset`` holding every node, subsampled to the model's step."""
        check_compatible(self, dataset, "dataset")
        k = self.stride(float(dataset.dt))
        n_steps = (dataset.n_samples - 1) // k + 1
        idx = np.arange(n_steps) * k
        states = self.encode(dataset.positions[idx], dataset.quaternions[idx])
        time = np.asarray(dataset.time[idx], dtype=np.float64)
        fb, forces = None, dataset.forces
        if self.feedback:
            fb = feedback_of(self, dataset, time)
            if fb is not None and self.frame is not None:
                raise bad("frame", "vessel", "data without PD tracking loads, or --recorded-feedback (the laws act "
                                             "on world positions)")
            if fb is not None:       # the law's recorded force is replaced by the law itself
                forces = np.array(forces, dtype=np.float64)
                forces[:, list(fb.nodes)] = 0.0
        loads = self.loads(forces, dataset.torques, n_steps, k)
        if self.drive != "wrench":
            act = self.actuation(dataset, n_steps, k)                         # (S, M, m)
            loads = act if self.drive == "actuation" else np.concatenate([loads, act], axis=-1)
        contact = None
        if self.contact:
            contact, gaps = self.contact_inputs(dataset, states)
            loads = np.concatenate([loads, gaps], axis=-1)
        if self.prescribed.any():
            loads = np.concatenate([loads, self.path_inputs(states)], axis=-1)
        projection = None
        if self.obstacles and dataset.contact is not None:
            ref = self.ref_positions[self.kept] if self._pose is None else np.zeros((self.n_kept, 3))
            projection = ObstacleProjection(dataset.contact, ref, rod_radius(dataset), ~(self.fixed | self.prescribed))
            if self._pose is not None:
                projection = FramedProjection(projection, self._pose, self.kept)
        return Trajectory(time=time, states=states, loads=loads, name=name, feedback=fb,
                          prescribed=self.prescribed_columns, projection=projection, contact=contact,
                          contact_columns=self.contact_columns)

    def contact_inputs(self, dataset, states: np.ndarray) -> tuple:
        """(the data set's ``ContactFeatures``, their values along ``states`` (S, M, 6): (S, M, 4)); a
        data set without obstacles has every node out of reach."""
        radius = 0.0 if dataset.contact is None else rod_radius(dataset)
        ref = self.ref_positions[self.kept] if self._pose is None else np.zeros((self.n_kept, 3))
        features = ContactFeatures(dataset.contact, ref, radius, self.length)
        if self._pose is not None:
            features = FramedFeatures(features, self._pose, self.kept)
        return features, features(states)

    def path_inputs(self, states: np.ndarray) -> np.ndarray:
        """The prescribed nodes' change of state over each model step, states (S, M, 6) ->
        (S, M, 6 P), the same at every kept node (the last step's: zero)."""
        P = int(self.prescribed.sum())
        change = np.zeros((len(states), 6 * P))
        change[:-1] = np.diff(states[:, self.prescribed], axis=0).reshape(len(states) - 1, 6 * P)
        return np.broadcast_to(change[:, None], (len(states), self.n_kept, 6 * P)).copy()

    def actuation(self, dataset, n_steps: int, k: int) -> np.ndarray:
        """The data set's ``channels`` (T, m) -> (n_steps, M, m): the mean over each model step of
        ``k`` samples, the same at every kept node."""
        names = tuple(dataset.actuation_names)
        A = np.asarray(dataset.actuation, dtype=np.float64)[:, [names.index(a) for a in self.channels]]
        out = np.empty((n_steps, len(self.channels)))
        for j in range(n_steps):
            out[j] = A[j * k:(j + 1) * k].mean(axis=0)
        return np.broadcast_to(out[:, None], (n_steps, self.n_kept, out.shape[1])).copy()


def check_compatible(encoding: Encoding, dataset, argument: str) -> None:
    """Refuse a data set the encoding cannot read: missing nodes, no orientations, another step."""
    nodes = np.asarray(dataset.nodes)
    if len(nodes) != encoding.n_nodes or np.any(nodes != np.arange(encoding.n_nodes)):
        raise bad(argument, f"a data set of nodes {nodes[:3].tolist()}..{nodes[-1:].tolist()} ({len(nodes)} nodes)",
                  f"a data set holding every node 0..{encoding.n_nodes - 1} of the rod "
                  "(simulate or sweep without selecting nodes)")
    if not dataset.has_orientations:
        raise bad(argument, "a data set without orientations",
                  "a data set with node orientations (the whole-manipulator model predicts full poses)")
    have = tuple(getattr(dataset, "actuation_names", ()))
    missing = [a for a in encoding.channels if a not in have]
    if missing:
        raise bad(argument, f"a data set without the actuation channel {missing[0]!r} (it has "
                            f"{', '.join(have) or 'none'})", f"data recording the model's actuation inputs "
                                                              f"{', '.join(encoding.channels)}")
    if encoding.frame is not None:
        try:
            own = vessel_frame(dataset)
        except SoftrnnInputError:
            own = None
        if not encoding.frame.same(own):
            raise bad(argument, "a data set not recorded in the model's vessel", "data simulated in the vessel the "
                                "model was trained in (its frame = 'vessel'), or a model trained in the world frame")
    dt = float(dataset.dt)
    try:
        resolve_stride(encoding.model_dt, dt)
    except SoftrnnInputError:
        raise bad(argument, f"a data set saved every {dt:g} s",
                  f"data saved at an interval that divides the model's step {encoding.model_dt:g} s") from None


def make_encoding(datasets: list, *, model_dt: float, node_stride: int, length: float,
                  feedback: bool = False, drive: str = "wrench", prescribed: bool = False,
                  obstacles: bool = False, contact: bool = False, frame: str = "world") -> Encoding:
    """The encoding for training on ``datasets`` (each holding every node, the same saved step):
    the reference pose is the first sample of the first one; fixed nodes are those that never move;
    ``feedback``: PD laws act on the model's state (``Encoding.feedback``; 'wrench' drive only);
    ``drive``: the load input (``DynamicConfig.drive``; the channels are the first data set's,
    ``_channels``: a hub's inputs with every drive);
    ``prescribed``: the clamps the data's scenario moves along a path (``moving_clamps``, the same
    in every data set) are inputs, not predicted, and always kept (``Encoding.prescribed``);
    ``obstacles``: free runs keep out of a data set's recorded obstacles, where the first data set
    has some (``Encoding.obstacles``); ``contact``: each kept node's gap and normal to the nearest
    obstacle are inputs, where the first data set has obstacles (``Encoding.contact``); ``frame``:
    'vessel' takes the state along the first data set's vessel (``Encoding.frame``), 'world' not."""
    if not datasets:
        raise SoftrnnInputError("no training data: give at least one trajectory")
    first = datasets[0]
    channels = _channels(first.actuation_names, drive)
    feedback = bool(feedback) and drive == "wrench"
    if drive == "wrench" and channels:      # a hub's inputs reach the model beside the wrenches
        drive = "both"
    if drive != "wrench" and not channels:
        raise SoftrnnInputError(f"drive={drive!r} is invalid: the training data has no actuation inputs; record "
                                f"them (CSV columns act_<name>[<unit>], DatasetWriter(actuation_units=...)) or use "
                                f"drive='wrench'")
    n = int(first.n_nodes)
    paths = _moving_clamps(datasets) if prescribed else ()
    kept = np.union1d(kept_nodes(n, node_stride), np.asarray(paths, dtype=np.int64))
    probe = Encoding(n_nodes=n, kept=kept, model_dt=model_dt, data_dt=float(first.dt),
                     length=length, ref_positions=first.positions[0], ref_quaternions=first.quaternions[0],
                     fixed=np.zeros(len(kept), dtype=bool), drive=drive, channels=channels,
                     frame=vessel_frame(first) if frame == "vessel" else None)
    moved = np.zeros(probe.n_kept)
    for d in datasets:
        check_compatible(probe, d, "training data")
        p = np.asarray(d.positions[:, probe.kept], dtype=np.float64)
        moved = np.maximum(moved, np.abs(p - probe.ref_positions[probe.kept]).max(axis=(0, 2)))
        # a pinned node keeps its position but turns: only a node whose whole pose stays is fixed
        q = np.asarray(d.quaternions[:, probe.kept], dtype=np.float64)
        turn = 1.0 - np.abs(np.sum(q * probe.ref_quaternions[probe.kept], axis=-1))
        moved = np.maximum(moved, np.where(turn.max(axis=0) > FIXED_TURN, np.inf, 0.0))
    fixed = moved <= FIXED_TOLERANCE_M
    return Encoding(n_nodes=n, kept=probe.kept, model_dt=model_dt, data_dt=probe.data_dt, length=length,
                    ref_positions=probe.ref_positions, ref_quaternions=probe.ref_quaternions,
                    fixed=fixed, feedback=feedback, drive=drive,
                    channels=channels, prescribed=np.isin(probe.kept, paths) & ~fixed,
                    obstacles=bool(obstacles) and first.contact is not None,
                    contact=bool(contact) and first.contact is not None, frame=probe.frame)


def _channels(names, drive: str) -> tuple:
    """The actuation channels a model reads of a data set's ``names``: with drive 'wrench' a hub's
    inputs alone (``softrnn.io.schema.hub_inputs``: its prescribed insertion [m] and rotation [rad],
    or the force [N] and torque [N m] that drive it), else every channel but a driven hub's measured
    insertion and rotation (the rod's state, not an input)."""
    hub = hub_inputs(names)
    if drive == "wrench":
        return hub
    return tuple(a for a in names if a not in HUB_CHANNELS or a in hub)


def _moving_clamps(datasets: list) -> tuple:
    """The moving clamps (``moving_clamps``) of the training data, the same in every data set (a
    one-line error otherwise)."""
    nodes = moving_clamps(datasets[0])
    for d in datasets[1:]:
        other = moving_clamps(d)
        if other != nodes:
            raise bad("training data", f"data sets whose scenarios move different clamps ({list(nodes)} and "
                                       f"{list(other)})", "data of one scenario, or prescribed = false (every "
                                                          "node predicted)")
    return nodes

