"""Obstacles in a whole-manipulator model's free run: the poses it reports kept out of the
obstacles the data were simulated with (NumPy only).

A whole-manipulator model learns contact only as the motion the data show near an obstacle: nothing
in its step knows a table or a vessel wall, so a free run can sink the rod into the table or carry a
guidewire through the wall of its vessel. Where a data set records its obstacles (the ``contact``
attribute of a run simulated with contact, ``softrnn.geometry.contact.contact_record``) and the model's
``Encoding.obstacles`` is set (``DynamicConfig.obstacles``), the states a free run reports are
projected: each predicted kept node whose rod surface lies inside an obstacle (gap g < 0, as
``softrnn.geometry.obstacles`` measures it, with the rod's radius) is moved back to the surface, by -g
along the obstacle's normal (obstacles one after the other; fixed and prescribed nodes are not
moved; the nodes decoded between kept nodes are not projected themselves). For a convex obstacle
region and a true pose outside the obstacle, the projection can only bring a node closer to it.

The projection is applied to what a run reports, not fed back into the model's history: the model
steps on its own unprojected states. Fed back, it held the nodes lying on a table at the surface
while the model's rotations kept turning, and the free runs diverged (docs/guide/dynamic.md). It is
not part of the network, its training loss or an exported ONNX step: a control loop that steps the
model itself applies ``ObstacleProjection`` to a copy of each state it uses.

**Contact inputs** (``ContactFeatures``, ``Encoding.contact``): what the model itself can know of the
obstacles. Each kept node's signed gap to the nearest obstacle and that obstacle's unit normal there
(``CONTACT_CHANNELS`` = 4 load channels per node), measured on the model's own state at every step
as the simulator measures them on the rod's, so the network's correction can learn the wall's push
and the friction along it. The linear term never reads them (a gap is not linear in the state).
"""

from __future__ import annotations

import json

import numpy as np
from numba import njit

from ...geometry.contact import contact_from_record
from ...geometry.obstacles import Vessel
from .data import rod_value

CONTACT_CHANNELS = 4
"""Contact inputs per kept node (``ContactFeatures``): the signed gap [m] and the unit normal (3)."""


def rod_radius(dataset) -> float:
    """The rod's radius [m] from a data set's ``attrs["rod"]`` (a one-line error without it)."""
    return rod_value(dataset, "radius")


class ObstacleProjection:
    """Keep kept nodes out of a contact's obstacles (see the module docstring).

    Parameters
    ----------
    contact : Contact or dict
        the obstacles: a ``softrnn.geometry.Contact``, or a data set's ``contact`` record
    ref_positions : ndarray (M, 3)
        the kept nodes' reference positions [m] (a state's displacements are added to them)
    radius : float
        the rod's radius [m]
    free : ndarray (M,) bool
        the nodes that may be moved (the predicted ones: not fixed, not prescribed)
    """

    def __init__(self, contact, ref_positions: np.ndarray, radius: float, free: np.ndarray):
        contact = contact_from_record(contact) if isinstance(contact, dict) else contact
        self.obstacles = tuple(contact.obstacles)
        self.ref = np.asarray(ref_positions, dtype=np.float64)
        self.free = np.asarray(free, dtype=bool)
        self.radius = np.full(int(self.free.sum()), float(radius))
        self.moved = 0
        """Node moves made so far (a node moved by two obstacles counts twice)."""

    def __call__(self, state: np.ndarray) -> np.ndarray:
        """Project ``state`` (M, 6) in place (its displacement columns) and return it; ``moved``
        counts the node moves made."""
        p = self.ref[self.free] + state[self.free, :3]
        for obstacle in self.obstacles:
            gap, normal = obstacle.gap(p, self.radius)
            inside = gap < 0.0
            if inside.any():
                p[inside] -= gap[inside, None] * normal[inside]
                self.moved += int(inside.sum())
        state[self.free, :3] = p - self.ref[self.free]
        return state

    def depth(self, state: np.ndarray) -> float:
        """The deepest a free kept node of ``state`` (M, 6) lies inside an obstacle [m] (0 if none)."""
        p = self.ref[self.free] + state[self.free, :3]
        worst = 0.0
        for obstacle in self.obstacles:
            gap, _ = obstacle.gap(p, self.radius)
            worst = max(worst, float(-np.min(gap, initial=0.0)))
        return worst


def _obstacles(contact) -> tuple:
    """The obstacles of a ``Contact`` or a data set's ``contact`` record."""
    return tuple((contact_from_record(contact) if isinstance(contact, dict) else contact).obstacles)


class ContactFeatures:
    """Each kept node's contact inputs from a state: the signed gap of the rod's surface to the
    nearest obstacle [m] (capped at ``far``) and that obstacle's unit normal there (zero beyond
    ``far``), as ``softrnn.geometry.obstacles`` measures them.

    Parameters
    ----------
    contact : Contact or dict or None
        the obstacles: a ``softrnn.geometry.Contact``, or a data set's ``contact`` record (None:
        none, every node out of reach)
    ref_positions : ndarray (M, 3)
        the kept nodes' reference positions [m] (a state's displacements are added to them)
    radius : float
        the rod's radius [m]
    far : float
        the gap [m] beyond which an obstacle is out of reach (the rod's length)
    """

    def __init__(self, contact, ref_positions: np.ndarray, radius: float, far: float):
        self.key = json.dumps(contact["obstacles"], sort_keys=True) if isinstance(contact, dict) else id(contact)
        """Equal for features of the same obstacles (a batch measures them in one call)."""
        self.obstacles = () if contact is None else _obstacles(contact)
        self.ref = np.asarray(ref_positions, dtype=np.float64)
        self.radius = float(radius)
        self.far = float(far)

    def __call__(self, states: np.ndarray) -> np.ndarray:
        """States (..., M, 6) -> contact inputs (..., M, 4): gap [m], then the normal (3)."""
        x = np.asarray(states, dtype=np.float64)
        p = (self.ref + x[..., :3]).reshape(-1, 3)
        gap, normal = np.full(len(p), np.inf), np.zeros((len(p), 3))
        for obstacle in self.obstacles:
            if type(obstacle) is Vessel:            # the brute-force search compiled: training measures often
                g, n = np.empty(len(p)), np.empty((len(p), 3))
                vessel_gap_into(obstacle.points, obstacle.radii, p, self.radius, g, n)
            else:
                g, n = obstacle.gap(p, np.full(len(p), self.radius))
            nearer = g < gap
            gap[nearer], normal[nearer] = g[nearer], n[nearer]
        reach = gap < self.far
        out = np.concatenate([np.where(reach, gap, self.far)[:, None], normal * reach[:, None]], axis=1)
        return out.reshape(x.shape[:-1] + (CONTACT_CHANNELS,))


@njit(cache=True, error_model="numpy")
def vessel_gap_into(points, radii, x, radius, gap, normal):
    """``Vessel.gap`` compiled: gaps ``gap`` (n,) [m] and inward unit normals ``normal`` (n, 3) of a rod
    of ``radius`` [m] at positions ``x`` (n, 3) [m] in the vessel of polyline ``points`` (P, 3) [m] and
    radii ``radii`` (P,) [m], from the closest segment (the first of equally close ones; inf beyond
    the open ends or on the polyline)."""
    last = points.shape[0] - 2
    for i in range(x.shape[0]):
        best, bj, bt = np.inf, 0, 0.0
        for j in range(last + 1):
            e0, e1 = points[j + 1, 0] - points[j, 0], points[j + 1, 1] - points[j, 1]
            e2 = points[j + 1, 2] - points[j, 2]
            a0, a1, a2 = x[i, 0] - points[j, 0], x[i, 1] - points[j, 1], x[i, 2] - points[j, 2]
            t = (a0 * e0 + a1 * e1 + a2 * e2) / (e0 * e0 + e1 * e1 + e2 * e2)
            tc = min(max(t, 0.0), 1.0)
            q0, q1, q2 = a0 - tc * e0, a1 - tc * e1, a2 - tc * e2
            d2 = q0 * q0 + q1 * q1 + q2 * q2
            if d2 < best:
                best, bj, bt = d2, j, t
        tc = min(max(bt, 0.0), 1.0)
        d = np.sqrt(best)
        for k in range(3):
            c = points[bj, k] + tc * (points[bj + 1, k] - points[bj, k])
            normal[i, k] = (c - x[i, k]) / d if d > 0 else 0.0
        beyond = (bj == 0 and bt < 0) or (bj == last and bt > 1)
        size = radii[bj] + tc * (radii[bj + 1] - radii[bj])
        gap[i] = np.inf if beyond or d <= 0 else size - radius - d
