"""The vessel frame of a whole-manipulator model's state: curvilinear coordinates along the centreline
of the vessel the data were simulated in (NumPy only; ``DynamicConfig.frame = "vessel"``).

A guidewire in a vessel slides along it: a node's motion is a push along the centreline plus a few
millimetres across it. In the world frame a linear model cannot turn a node's velocity round a bend
(the turn depends on where along the vessel the node is), so a free run runs straight on into the
wall. In the vessel frame a kept node's displacement is that of its curvilinear coordinates:

* tau, the centreline's spline parameter at the point of the centreline closest to the node [m]
  (the cubic spline over the chord length through the centreline points that ``Vessel`` builds; it
  is the arc length to within its chords' sagitta, 0.04 % on 5 mm chords round a 50 mm bend);
* u and w, the node's offsets across the vessel along the normals n1, n2 of a rotation-minimising
  frame (t, n1, n2) carried along the centreline from its start [m];

and its rotation vector is taken in that frame: ``log(Q_ref^T Q)`` with ``Q = F(tau)^T R`` (F the
frame's rotation, body to world), so a wire that follows the vessel keeps its state. "Keep going"
is then "keep going along the vessel", the linear term and the correction both act in that frame,
and a node decoded between kept nodes follows the vessel instead of cutting its bends. Beyond the
centreline's ends the centreline runs on straight along its end tangent (the frame stays).

The start normal n1 is the world axis least aligned with the start tangent (the first of those
within 0.001 of the least: a spline's start tangent is straight only to rounding), made normal to
it; n2 = t x n1. So in a straight vessel along +x the frame is the world's axes and the state is
the world frame's (the reference's offsets aside).
"""

from __future__ import annotations

import numpy as np
from scipy.interpolate import CubicSpline
from scipy.spatial.transform import Rotation

from ...errors import bad
from ...geometry.contact import contact_from_record
from ...geometry.obstacles import Vessel, closest_segments

SAMPLES_PER_POINT = 64
"""Frame samples per centreline chord (the rotation-minimising frame is carried between them)."""
COARSE = 8
"""Every COARSE-th frame sample starts the closest-point search (Newton's method refines it)."""
NEWTON_STEPS = 30
_TOL = 1e-15


class VesselFrame:
    """Curvilinear coordinates along a vessel's centreline (see the module docstring).

    Parameters
    ----------
    centreline : array_like (m, 3)
        the vessel's centreline points [m], m >= 2, distinct consecutive points (``Vessel.centreline``)
    """

    def __init__(self, centreline):
        p = np.array(centreline, dtype=np.float64)
        if p.ndim != 2 or p.shape[1] != 3 or len(p) < 2 or not np.all(np.isfinite(p)):
            raise bad("centreline", f"an array of shape {p.shape}", "(m, 3) finite points in m, m >= 2")
        chords = np.linalg.norm(np.diff(p, axis=0), axis=1)
        if np.any(chords <= 0):
            raise bad("centreline", "repeated consecutive points", "distinct consecutive points")
        self.centreline = p
        self.knots = np.concatenate([[0.0], np.cumsum(chords)])
        self.end = float(self.knots[-1])
        self._spline = CubicSpline(self.knots, p, axis=0)
        self._ends = (self._spline(0.0, 1), self._spline(self.end, 1))
        n = max(2, SAMPLES_PER_POINT * (len(p) - 1) + 1)
        self.samples = np.linspace(0.0, self.end, n)
        self._points = self._spline(self.samples)
        self._normals = _transported_normals(self._points, self.tangent(self.samples))

    # --------------------------------------------------------------------------- the centreline
    def curve(self, tau: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """The centreline at parameters ``tau`` (n,) [m]: points c, c' and c'' (n, 3) each; beyond the
        ends the straight continuation along the end tangent (c'' = 0)."""
        tau = np.asarray(tau, dtype=np.float64)
        inside = np.clip(tau, 0.0, self.end)
        c, d1, d2 = self._spline(inside), self._spline(inside, 1), self._spline(inside, 2)
        for beyond, at, slope in ((tau < 0.0, 0.0, self._ends[0]), (tau > self.end, self.end, self._ends[1])):
            if beyond.any():
                c[beyond] += (tau[beyond] - at)[:, None] * slope
                d1[beyond] = slope
                d2[beyond] = 0.0
        return c, d1, d2

    def tangent(self, tau: np.ndarray) -> np.ndarray:
        """Unit tangents (n, 3) at ``tau`` (n,) [m]."""
        d1 = self.curve(tau)[1]
        return d1 / np.linalg.norm(d1, axis=1)[:, None]

    def rotation(self, tau: np.ndarray) -> np.ndarray:
        """The frame's rotation matrices (n, 3, 3) at ``tau`` (n,) [m]: columns t, n1, n2 (local to world)."""
        tau = np.asarray(tau, dtype=np.float64)
        t = self.tangent(tau)
        j = np.clip(np.searchsorted(self.samples, tau, side="right") - 1, 0, len(self.samples) - 2)
        a = np.clip((tau - self.samples[j]) / (self.samples[j + 1] - self.samples[j]), 0.0, 1.0)[:, None]
        m = (1.0 - a) * self._normals[j] + a * self._normals[j + 1]
        n1 = m - np.sum(m * t, axis=1)[:, None] * t
        n1 /= np.linalg.norm(n1, axis=1)[:, None]
        return np.stack([t, n1, np.cross(t, n1)], axis=2)

    # --------------------------------------------------------------------------- the coordinates
    def local(self, x: np.ndarray) -> np.ndarray:
        """World points (n, 3) [m] -> curvilinear coordinates (n, 3): tau, u, w [m] (the closest
        centreline point, from the closest chord of the frame's samples refined by Newton's method)."""
        x = np.asarray(x, dtype=np.float64).reshape(-1, 3)
        if len(x) == 0:
            return np.zeros((0, 3))
        knots = self.samples[::COARSE] if (len(self.samples) - 1) % COARSE == 0 else self.samples
        j, _, t = closest_segments(self._points[::COARSE] if len(knots) < len(self.samples) else self._points, x)
        last = len(knots) - 2
        beyond = ((j == 0) & (t < 0)) | ((j == last) & (t > 1))
        tau = knots[j] + np.where(beyond, t, np.clip(t, 0.0, 1.0)) * (knots[j + 1] - knots[j])
        for _ in range(NEWTON_STEPS):
            c, d1, d2 = self.curve(tau)
            r = c - x
            slope = np.sum(d1 * d1, axis=1) + np.sum(r * d2, axis=1)
            slope = np.where(slope > 1e-3 * np.sum(d1 * d1, axis=1), slope, np.sum(d1 * d1, axis=1))
            step = np.sum(r * d1, axis=1) / slope
            tau = tau - step
            if np.all(np.abs(step) <= _TOL * (1.0 + self.end)):
                break
        c = self.curve(tau)[0]
        F = self.rotation(tau)
        off = np.einsum("nij,ni->nj", F, x - c)          # components along t (zero), n1, n2
        return np.stack([tau, off[:, 1], off[:, 2]], axis=1)

    def world(self, coords: np.ndarray) -> np.ndarray:
        """Curvilinear coordinates (n, 3) (tau, u, w) [m] -> world points (n, 3) [m]."""
        q = np.asarray(coords, dtype=np.float64).reshape(-1, 3)
        F = self.rotation(q[:, 0])
        return self.curve(q[:, 0])[0] + q[:, 1:2] * F[:, :, 1] + q[:, 2:3] * F[:, :, 2]

    def same(self, other: VesselFrame | None) -> bool:
        """Whether ``other`` is a frame of the same centreline (to 1e-12 m)."""
        return (other is not None and other.centreline.shape == self.centreline.shape
                and bool(np.allclose(other.centreline, self.centreline, rtol=0.0, atol=1e-12)))


def _transported_normals(points: np.ndarray, tangents: np.ndarray) -> np.ndarray:
    """Normals n1 (P, 3) of a rotation-minimising frame at the samples ``points`` (P, 3) with unit
    ``tangents`` (P, 3) (the double reflection method of Wang et al. 2008); the first: the world axis
    least aligned with the first tangent, made normal to it."""
    a = np.abs(tangents[0])
    axis = np.eye(3)[int(np.flatnonzero(a <= a.min() + 1e-3)[0])]     # the first of nearly equal ones
    n = axis - (axis @ tangents[0]) * tangents[0]
    out = np.empty_like(points)
    out[0] = n / np.linalg.norm(n)
    for i in range(len(points) - 1):
        v1 = points[i + 1] - points[i]
        c1 = v1 @ v1
        r = out[i] - (2.0 / c1) * (v1 @ out[i]) * v1
        tl = tangents[i] - (2.0 / c1) * (v1 @ tangents[i]) * v1
        v2 = tangents[i + 1] - tl
        c2 = v2 @ v2
        if c2 > 1e-300:
            r = r - (2.0 / c2) * (v2 @ r) * v2
        r = r - (r @ tangents[i + 1]) * tangents[i + 1]
        out[i + 1] = r / np.linalg.norm(r)
    return out


def vessel_frame(dataset) -> VesselFrame:
    """The ``VesselFrame`` of the one vessel a data set was simulated in (its ``contact`` record);
    a data set without obstacles, or without exactly one ``Vessel`` among them, is a one-line error."""
    record = getattr(dataset, "contact", None)
    vessels = [] if record is None else [o for o in contact_from_record(record).obstacles if type(o) is Vessel]
    if len(vessels) != 1:
        what = "no obstacles" if record is None else f"{len(vessels)} vessel obstacles"
        raise bad("frame", "vessel", f"training data recorded in one vessel (a contact obstacle of kind 'vessel'; "
                                     f"the first data set has {what}), or frame='world'")
    return VesselFrame(vessels[0].centreline)


def frame_to_dict(frame: VesselFrame) -> dict:
    """What model.json records of a frame: ``{"kind": "vessel", "centreline": [[x, y, z], ...]}``."""
    return {"kind": "vessel", "centreline": frame.centreline.tolist()}


def frame_from_dict(d) -> VesselFrame:
    """The frame ``frame_to_dict`` recorded (a one-line error for another record)."""
    if not isinstance(d, dict) or d.get("kind") != "vessel" or "centreline" not in d:
        raise bad("encoding.frame", str(d)[:80], "{'kind': 'vessel', 'centreline': [[x, y, z], ...]}")
    return VesselFrame(d["centreline"])


class LocalPose:
    """Poses in a frame: the reference's curvilinear coordinates and orientations in the frame, and
    the maps between world poses and states (``Encoding`` with a frame).

    Parameters
    ----------
    frame : VesselFrame
        the frame
    ref_positions : ndarray (N, 3)
        the reference positions [m]
    ref_rotation : scipy Rotation
        the N reference orientations (body to world)
    """

    def __init__(self, frame: VesselFrame, ref_positions: np.ndarray, ref_rotation: Rotation):
        self.frame = frame
        self.ref = frame.local(ref_positions)                                          # (N, 3)
        self.ref_in_frame = Rotation.from_matrix(frame.rotation(self.ref[:, 0])).inv() * ref_rotation

    def encode(self, p: np.ndarray, rot: Rotation, nodes: np.ndarray) -> np.ndarray:
        """World positions (T, K, 3) [m] and orientations (T K) of ``nodes`` (K,) -> states (T, K, 6)."""
        T, K = p.shape[:2]
        q = self.frame.local(p.reshape(-1, 3))
        in_frame = Rotation.from_matrix(self.frame.rotation(q[:, 0])).inv() * rot
        ref = self.ref_in_frame[np.tile(nodes, T)]
        theta = (ref.inv() * in_frame).as_rotvec().reshape(T, K, 3)
        return np.concatenate([q.reshape(T, K, 3) - self.ref[nodes], theta], axis=-1)

    def positions(self, full: np.ndarray) -> np.ndarray:
        """States of every node (T, N, >= 3) -> world positions (T, N, 3) [m]."""
        T, N = full.shape[:2]
        return self.frame.world((self.ref[None] + full[..., :3]).reshape(-1, 3)).reshape(T, N, 3)

    def rotations(self, full: np.ndarray) -> Rotation:
        """States of every node (T, N, 6) -> the orientations (T N) (body to world)."""
        T, N = full.shape[:2]
        tau = (self.ref[None, :, 0] + full[..., 0]).reshape(-1)
        ref = self.ref_in_frame[np.tile(np.arange(N), T)]
        return Rotation.from_matrix(self.frame.rotation(tau)) * ref * Rotation.from_rotvec(full[..., 3:].reshape(-1, 3))

    def world_states(self, states: np.ndarray, nodes: np.ndarray) -> np.ndarray:
        """States (..., K, 6) of ``nodes`` (K,) -> the same with columns 0-2 the world positions [m]."""
        x = np.array(states, dtype=np.float64)
        q = self.ref[nodes] + x[..., :3]
        x[..., :3] = self.frame.world(q.reshape(-1, 3)).reshape(q.shape)
        return x


class FramedProjection:
    """An ``ObstacleProjection`` (built with zero reference positions, so that it reads world
    positions) on the states of a model in a vessel frame: the kept nodes' positions are decoded,
    projected, and the moved ones encoded again (their rotation vectors stay)."""

    def __init__(self, projection, pose: LocalPose, kept: np.ndarray):
        self.inner, self.pose, self.kept = projection, pose, np.asarray(kept)

    @property
    def moved(self) -> int:
        """Node moves made so far (``ObstacleProjection.moved``)."""
        return self.inner.moved

    def __call__(self, state: np.ndarray) -> np.ndarray:
        """Project ``state`` (M, 6) in place and return it."""
        world = self.pose.world_states(state, self.kept)
        before = world[:, :3].copy()
        self.inner(world)
        moved = np.any(world[:, :3] != before, axis=1)
        if moved.any():
            q = self.pose.frame.local(world[moved, :3])
            state[moved, :3] = q - self.pose.ref[self.kept[moved]]
        return state

    def depth(self, state: np.ndarray) -> float:
        """The deepest a free kept node of ``state`` (M, 6) lies inside an obstacle [m]."""
        return self.inner.depth(self.pose.world_states(state, self.kept))


class FramedFeatures:
    """``ContactFeatures`` (built with zero reference positions) on the states of a model in a vessel
    frame: measured at the kept nodes' decoded positions."""

    def __init__(self, features, pose: LocalPose, kept: np.ndarray):
        self.inner, self.pose, self.kept = features, pose, np.asarray(kept)
        self.key = features.key

    def __call__(self, states: np.ndarray) -> np.ndarray:
        """States (..., M, 6) -> contact inputs (..., M, 4)."""
        return self.inner(self.pose.world_states(states, self.kept))
