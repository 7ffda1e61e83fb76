"""Z-score statistics of a node model's inputs and targets (``Normalizer``), fitted on training windows only."""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from ...errors import bad, store_frozen
from ..artifacts import from_fields

OUTPUTS = ("increment", "pose", "acceleration")

NODE_POSITION = slice(0, 3)
"""Columns of the predicted node's own position in a pose row (the node comes first)."""

STD_RELATIVE_FLOOR = 1e-3
"""Smallest standard deviation kept, relative to the largest of its group (poses, step differences,
wrenches, targets): a constant feature (z of a planar motion, the forces of a free motion) is then
centred but not blown up from rounding noise."""


# ------------------------------------------------------------------------------------ Normalizer
def _std(x: np.ndarray, groups=None) -> np.ndarray:
    """Per-column standard deviation with the relative floor (float64), within each group of
    columns that share a label in ``groups`` (None: one group)."""
    with np.errstate(under="ignore"):
        s = x.std(axis=0) if x.shape[0] else np.ones(x.shape[1:])
        labels = np.zeros(s.shape[0], dtype=int) if groups is None else np.unique(list(groups), return_inverse=True)[1]
        out = np.empty_like(s)
        for g in np.unique(labels):
            mine = labels == g
            top = float(s[mine].max())
            floor = max(top * STD_RELATIVE_FLOOR, 1e-12) if top > 0 else 1.0
            out[mine] = np.maximum(s[mine], floor)
        return out


def _units(units, W: int):
    """``wrench_units`` checked against input II's width W (None stays None)."""
    if units is None:
        return None
    units = tuple(units)
    if len(units) != W:
        raise bad("wrench_units", list(units), f"one unit per input II column ({W})")
    return units


def _vec(name: str, value, n: int | None = None) -> np.ndarray:
    try:
        arr = np.asarray(value, dtype=np.float64)
    except (TypeError, ValueError):       # strings, ragged lists, objects (a damaged normalizer.json)
        arr = np.full((0, 0), np.nan)
    if arr.ndim != 1 or (n is not None and arr.shape[0] != n) or not np.all(np.isfinite(arr)):
        raise bad(name, value if arr.size <= 8 else f"array of shape {arr.shape}",
                  f"a finite 1-D array{f' of length {n}' if n is not None else ''}")
    return arr


def _in_frame(poses, relative: bool, per_node: int) -> np.ndarray:
    """(B, H, P) poses as float64, every node's position minus the node's last position if
    ``relative`` (quaternions unchanged)."""
    x = np.array(poses, dtype=np.float64)                                    # (B, H, P) copy
    if relative:
        B, H, P = x.shape
        nodes = x.reshape(B, H, P // per_node, per_node)                      # (B, H, K, per_node) view
        nodes[..., :3] -= x[:, -1, None, None, NODE_POSITION].copy()          # minus (B, 1, 1, 3)
    return x


@dataclass(frozen=True)
class Normalizer:
    """Z-score statistics of the inputs and targets, fitted on training windows only.

    Attributes
    ----------
    pose_mean, pose_std : ndarray (P,) float64
        Of input I per column, over every step of every training window.
    wrench_mean, wrench_std : ndarray (W,) float64
        Of input II (W may be 0).
    target_mean, target_std : ndarray (3,) float64
        Of the model's output before scaling: the increment (next position minus the node's last
        position) for ``output="increment"``, its change (next - 2 last + previous position) for
        ``"acceleration"``, the next position for ``"pose"``.
    delta_mean, delta_std : ndarray (P,) float64
        Of the step-to-step differences of input I (the velocity-like inputs the model derives).
    output : str
        ``"increment"``, ``"acceleration"`` or ``"pose"``: what the target statistics describe.
    relative : bool
        Input I is expressed relative to the node's last position (every node's position minus it;
        quaternions unchanged) before the z-score; the statistics are of those relative poses.
    per_node : int
        Pose values per node in input I (3 or 7), to find the position columns.

    Notes
    -----
    Standard deviations are floored at ``STD_RELATIVE_FLOOR`` times the largest of their group
    (1 for an all-constant group), so constant features stay finite.
    """

    pose_mean: np.ndarray
    pose_std: np.ndarray
    wrench_mean: np.ndarray
    wrench_std: np.ndarray
    target_mean: np.ndarray
    target_std: np.ndarray
    delta_mean: np.ndarray = field(default=None)
    delta_std: np.ndarray = field(default=None)
    output: str = "increment"
    relative: bool = False
    per_node: int = 3

    def __post_init__(self):
        if self.output not in OUTPUTS:
            raise bad("output", self.output, "'increment', 'acceleration' or 'pose'")
        if not isinstance(self.relative, (bool, np.bool_)):
            raise bad("relative", self.relative, "true or false")
        object.__setattr__(self, "relative", bool(self.relative))
        if self.per_node not in (3, 7):
            raise bad("per_node", self.per_node, "3 (positions) or 7 (positions and quaternions)")
        pm = _vec("pose_mean", self.pose_mean)
        P = pm.shape[0]
        values = {"pose_mean": pm, "pose_std": _vec("pose_std", self.pose_std, P)}
        values["wrench_mean"] = _vec("wrench_mean", self.wrench_mean)
        values["wrench_std"] = _vec("wrench_std", self.wrench_std, values["wrench_mean"].shape[0])
        values["target_mean"] = _vec("target_mean", self.target_mean, 3)
        values["target_std"] = _vec("target_std", self.target_std, 3)
        values["delta_mean"] = np.zeros(P) if self.delta_mean is None else _vec("delta_mean", self.delta_mean, P)
        values["delta_std"] = np.ones(P) if self.delta_std is None else _vec("delta_std", self.delta_std, P)
        if P % self.per_node:
            raise bad("pose_mean", f"{P} values", f"a multiple of per_node={self.per_node}")
        for name in ("pose_std", "wrench_std", "target_std", "delta_std"):
            if np.any(values[name] <= 0):
                raise bad(name, values[name].tolist(), "positive standard deviations")
        store_frozen(self, **values)

    @property
    def pose_features(self) -> int:
        """P."""
        return int(self.pose_mean.shape[0])

    @property
    def wrench_features(self) -> int:
        """W."""
        return int(self.wrench_mean.shape[0])

    @classmethod
    def fit(cls, windows, *, output: str = "increment", relative: bool = False,
            per_node: int = 3, wrench_units=None) -> Normalizer:
        """Statistics of ``windows`` (``data.Windows``: the training windows; never pass test windows).

        ``relative``: express every position of a window relative to the node's last position
        (translation-invariant inputs); ``per_node``: pose values per node (3 or 7);
        ``wrench_units``: the unit of each input II column (W,) (``wrench_units``): the floor of
        the spreads applies within each unit, so a channel in kPa does not squeeze one in N (None:
        input II is one group).
        """
        if len(windows) == 0:
            raise bad("windows", "0 windows", "at least one training window to fit the normalisation on")
        poses = _in_frame(windows.poses, relative, per_node)                  # (M, H, P) float64
        P, W = poses.shape[2], windows.wrenches.shape[2]
        flat = poses.reshape(-1, P)                                           # (M*H, P)
        wr = windows.wrenches.astype(np.float64).reshape(flat.shape[0], W)    # (M*H, W)
        if poses.shape[1] > 1:
            delta = np.diff(poses, axis=1).reshape(-1, P)                     # (M*(H-1), P)
        else:
            delta = np.zeros((1, P))
        target = cls._raw_target(windows.targets, windows.poses, output)      # (M, 3)
        wrench_std = _std(wr, _units(wrench_units, W)) if W else np.zeros(0) + 1.0
        with np.errstate(under="ignore"):
            return cls(pose_mean=flat.mean(0), pose_std=_std(flat),
                       wrench_mean=wr.mean(0) if W else np.zeros(0), wrench_std=wrench_std,
                       target_mean=target.mean(0), target_std=_std(target),
                       delta_mean=delta.mean(0), delta_std=_std(delta), output=output, relative=relative,
                       per_node=per_node)

    @staticmethod
    def _raw_target(targets, poses, output: str) -> np.ndarray:
        t = np.asarray(targets, dtype=np.float64)                            # (M, 3)
        if output == "pose":
            return t
        last = np.asarray(poses[:, -1, NODE_POSITION], dtype=np.float64)      # (M, 3)
        if output == "increment":
            return t - last
        if poses.shape[1] < 2:
            raise bad("output", output, "'increment' or 'pose' for history 1 ('acceleration' needs two past steps)")
        prev = np.asarray(poses[:, -2, NODE_POSITION], dtype=np.float64)      # (M, 3)
        return t - 2.0 * last + prev

    # ------------------------------------------------------------------ transforms
    def normalise_poses(self, poses) -> np.ndarray:
        """(B, H, P) physical -> (B, H, P) float32 z-scores (of the relative poses if ``relative``)."""
        x = _in_frame(poses, self.relative, self.per_node)                   # (B, H, P) float64
        return ((x - self.pose_mean) / self.pose_std).astype(np.float32)

    def normalise_wrenches(self, wrenches) -> np.ndarray:
        """(B, H, W) physical -> (B, H, W) float32 z-scores."""
        w = np.asarray(wrenches, dtype=np.float64)
        return ((w - self.wrench_mean) / self.wrench_std).astype(np.float32)

    def normalise_targets(self, targets, poses) -> np.ndarray:
        """Next positions (B, 3) [m] and their windows' poses (B, H, P) -> the model's targets
        (B, 3) float32 (normalised increment or position)."""
        raw = self._raw_target(targets, poses, self.output)                  # (B, 3)
        return ((raw - self.target_mean) / self.target_std).astype(np.float32)

    def denormalise_outputs(self, outputs, poses) -> np.ndarray:
        """The model's outputs (B, 3) and the windows' physical poses (B, H, P) -> next positions
        (B, 3) float64 [m]."""
        y = np.asarray(outputs, dtype=np.float64) * self.target_std + self.target_mean  # (B, 3)
        if self.output == "pose":
            return y
        poses = np.asarray(poses)
        last = poses[:, -1, NODE_POSITION].astype(np.float64)                   # (B, 3)
        if self.output == "increment":
            return y + last
        return y + 2.0 * last - poses[:, -2, NODE_POSITION].astype(np.float64)

    def delta_scale(self) -> np.ndarray:
        """(P,) factor turning differences of normalised poses into normalised differences:
        pose_std / delta_std."""
        return self.pose_std / self.delta_std

    # ------------------------------------------------------------------ serialisation
    def to_dict(self) -> dict:
        """JSON-ready lists."""
        d = {name: getattr(self, name).tolist() for name in
             ("pose_mean", "pose_std", "wrench_mean", "wrench_std", "target_mean", "target_std",
              "delta_mean", "delta_std")}
        d.update(output=self.output, relative=self.relative, per_node=self.per_node)
        return d

    @classmethod
    def from_dict(cls, d: dict) -> Normalizer:
        """Inverse of ``to_dict``; a malformed dict raises SoftrnnInputError."""
        return from_fields(cls, d, "normalizer")
