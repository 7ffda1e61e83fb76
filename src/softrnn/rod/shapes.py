"""Rod configurations: node positions and frames for straight rods, circular arcs, closed ellipses,
arbitrary polylines and straight rods pre-shaped by bends (``curved``, ``shaped_tip``: a J or angled
tip). A shape serves as the stress-free reference or as an initial condition.

Nodes are equally spaced in arc length; frames put d3 on the tangent (docs/lgvi.md §2.1) and, for
planar curves, d2 on the plane normal, so a planar reference has no twist.
"""

import math
from dataclasses import dataclass

import numpy as np

from ..errors import bad, finite, positive, store_frozen
from .so3 import frame_from_tangent


@dataclass(frozen=True, eq=False)
class RodShape:
    """A rod configuration.

    positions (n, 3) [m]; rotations (n, 3, 3), columns d1, d2, d3, world <- body.
    """

    positions: np.ndarray
    rotations: np.ndarray

    def __post_init__(self):
        r = np.array(self.positions, dtype=float)
        R = np.array(self.rotations, dtype=float)
        if r.ndim != 2 or r.shape[1] != 3 or r.shape[0] < 2:
            raise bad("positions.shape", r.shape, "(n, 3) with n >= 2")
        if R.shape != (r.shape[0], 3, 3):
            raise bad("rotations.shape", R.shape, f"({r.shape[0]}, 3, 3) to match positions")
        if not (np.all(np.isfinite(r)) and np.all(np.isfinite(R))):
            raise bad("positions/rotations", "non-finite values", "finite numbers")
        err = np.max(np.abs(R.transpose(0, 2, 1) @ R - np.eye(3)))
        if err > 1e-8 or np.any(np.linalg.det(R) < 0):
            raise bad("rotations", f"max |R^T R - I| = {err:.1e}", "proper rotation matrices")
        store_frozen(self, positions=r, rotations=R)

    @property
    def n_nodes(self) -> int:
        """Number of nodes n."""
        return self.positions.shape[0]

    def arc_length(self) -> float:
        """Length of the polyline through the nodes [m]."""
        return float(np.sum(np.linalg.norm(np.diff(self.positions, axis=0), axis=1)))


def _unit(name: str, x) -> np.ndarray:
    x = np.asarray(x, dtype=float)
    if x.shape != (3,) or not np.all(np.isfinite(x)) or np.linalg.norm(x) == 0:
        raise bad(name, x.tolist() if x.ndim else x, "a nonzero 3-vector")
    return x / np.linalg.norm(x)


def straight(n_nodes: int, length: float, *, origin=(0.0, 0.0, 0.0), direction=(0.0, 0.0, 1.0),
             normal=(1.0, 0.0, 0.0)) -> RodShape:
    """Straight rod from ``origin`` along ``direction``; d1 is ``normal`` made orthogonal."""
    d = _unit("direction", direction)
    s = np.linspace(0.0, length, n_nodes)
    pos = np.asarray(origin, dtype=float) + s[:, None] * d
    hint = _unit("normal", normal)
    if abs(np.dot(hint, d)) > 1 - 1e-9:
        raise bad("normal", normal, "a vector not parallel to direction")
    R = np.broadcast_to(frame_from_tangent(d, hint), (n_nodes, 3, 3))
    return RodShape(pos, R)


def arc(n_nodes: int, length: float, radius: float, *, origin=(0.0, 0.0, 0.0), tangent=(0.0, 1.0, 0.0),
        inward=(1.0, 0.0, 0.0)) -> RodShape:
    """Circular arc of ``length`` and ``radius`` starting at ``origin`` along ``tangent``, bending
    toward ``inward`` (the direction from the start to the centre). length = pi radius gives a
    semicircle."""
    t0 = _unit("tangent", tangent)
    n0 = _unit("inward", inward)
    if abs(np.dot(t0, n0)) > 1e-9:
        raise bad("inward", inward, "a direction orthogonal to tangent")
    if not radius > 0:
        raise bad("radius", radius, "a positive arc radius in m")
    phi = np.linspace(0.0, length / radius, n_nodes)
    pos = (np.asarray(origin, float) + radius * np.sin(phi)[:, None] * t0
           + radius * (1 - np.cos(phi))[:, None] * n0)
    tan = np.cos(phi)[:, None] * t0 + np.sin(phi)[:, None] * n0
    binormal = np.cross(t0, n0)
    return RodShape(pos, frame_from_tangent(tan, np.cross(binormal, tan)))


def ellipse_perimeter(width: float, height: float) -> float:
    """Perimeter of an ellipse with full axes ``width`` and ``height`` [m] (numerical quadrature)."""
    a, b = width / 2.0, height / 2.0
    th = np.linspace(0.0, 2 * np.pi, 200001)
    ds = np.hypot(a * np.cos(th), b * np.sin(th))
    return float(np.trapezoid(ds, th))


def ellipse(n_nodes: int, width: float, height: float, *, origin=(0.0, 0.0, 0.0)) -> RodShape:
    """Closed ellipse in the xy-plane through ``origin`` at its top (x-extent ``width``, y-extent
    ``height``): nodes 0 and n - 1 both sit at ``origin`` with the same tangent (+x), the rod runs
    clockwise seen from +z, the middle node is at the bottom (origin - (0, height, 0))."""
    if not (width > 0 and height > 0):
        raise bad("ellipse width/height", (width, height), "positive sizes in m")
    a, b = width / 2.0, height / 2.0
    th = np.linspace(0.0, 2 * np.pi, 400001)
    ds = np.hypot(a * np.cos(th), b * np.sin(th))
    s = np.concatenate([[0.0], np.cumsum(0.5 * (ds[1:] + ds[:-1]) * np.diff(th))])
    th_n = np.interp(np.linspace(0.0, s[-1], n_nodes), s, th)
    th_n[-1] = 2 * np.pi
    pos = np.stack([a * np.sin(th_n), b * np.cos(th_n) - b, np.zeros(n_nodes)], -1)
    pos[-1] = pos[0]
    pos = pos + np.asarray(origin, float)
    tan = np.stack([a * np.cos(th_n), -b * np.sin(th_n), np.zeros(n_nodes)], -1)
    tan /= np.linalg.norm(tan, axis=1, keepdims=True)
    ez = np.array([0.0, 0.0, 1.0])
    return RodShape(pos, frame_from_tangent(tan, np.cross(ez, tan)))


def polyline(points, rotations=None, *, normal=(1.0, 0.0, 0.0)) -> RodShape:
    """A rod through the given node ``points`` (n, 3).

    ``rotations`` (n, 3, 3) gives the frames; without it, d3 follows the central-difference tangent
    and d1 is parallel-transported from ``normal`` (twist-free).
    """
    p = np.asarray(points, dtype=float)
    if p.ndim != 2 or p.shape[1] != 3 or p.shape[0] < 2:
        raise bad("points.shape", p.shape, "(n, 3) with n >= 2")
    if rotations is not None:
        return RodShape(p, rotations)
    tan = np.gradient(p, axis=0)
    tan /= np.linalg.norm(tan, axis=1, keepdims=True)
    frames = np.empty((p.shape[0], 3, 3))
    frames[0] = frame_from_tangent(tan[0], _unit("normal", normal))
    for i in range(1, p.shape[0]):
        d1 = frames[i - 1][:, 0]
        frames[i] = frame_from_tangent(tan[i], d1)
    return RodShape(p, frames)


@dataclass(frozen=True)
class Bend:
    """A constant rest curvature between arc lengths ``start`` and ``end`` [m] of a straight rod.

    Attributes
    ----------
    start, end : float
        Arc lengths from the first node [m], 0 <= start < end.
    curvature : float
        Curvature [1/m] (the bend turns the rod through curvature * (end - start) rad).
    toward_deg : float
        The direction the rod bends toward, in degrees from d1 toward d2 in the plane of the
        section (0: toward d1, the ``normal`` of the straight rod; 90: toward d2).
    """

    start: float
    end: float
    curvature: float
    toward_deg: float = 0.0

    def __post_init__(self):
        finite("bend.start", self.start, "m")
        finite("bend.end", self.end, "m")
        if self.start < 0 or self.end <= self.start:
            raise bad("bend [start, end]", [self.start, self.end], "0 <= start < end, arc lengths in m")
        positive("bend.curvature", self.curvature, "1/m")
        finite("bend.toward_deg", self.toward_deg, "degrees")

    @property
    def body_curvature(self) -> np.ndarray:
        """The curvature vector (3,) [1/m] in the body frame: d3' = curvature x d3 bends toward
        cos(toward) d1 + sin(toward) d2."""
        phi = math.radians(self.toward_deg)
        return self.curvature * np.array([-math.sin(phi), math.cos(phi), 0.0])


def _advance(R: np.ndarray, r: np.ndarray, k: np.ndarray, t: float) -> tuple[np.ndarray, np.ndarray]:
    """Frame (3, 3) and position (3,) [m] after arc length ``t`` [m] of constant body curvature
    ``k`` (3,) [1/m] normal to d3 (exact: a circular arc, or a straight piece for k = 0)."""
    kappa = float(np.linalg.norm(k))
    if kappa == 0.0:
        return R, r + t * R[:, 2]
    a = k / kappa
    th = kappa * t
    A = np.array([[0.0, -a[2], a[1]], [a[2], 0.0, -a[0]], [-a[1], a[0], 0.0]])
    E = np.eye(3) + math.sin(th) * A + (1.0 - math.cos(th)) * (A @ A)
    offset = np.array([0.0, 0.0, math.sin(th) / kappa]) + (1.0 - math.cos(th)) / kappa * np.cross(a, [0.0, 0.0, 1.0])
    return R @ E, r + R @ offset


def _checked_bends(bends, length: float) -> tuple:
    """``bends`` as a tuple of ``Bend``, in order along the rod, disjoint and inside [0, length]."""
    bends = tuple(bends)
    for i, b in enumerate(bends):
        if not isinstance(b, Bend):
            raise bad(f"bends[{i}]", b, "Bend entries")
        if i and b.start < bends[i - 1].end:
            raise bad(f"bends[{i}].start", b.start, f"an arc length >= {bends[i - 1].end:g} m where bends[{i - 1}] "
                                                     "ends (bends in order along the rod, not overlapping)")
        if b.end > length * (1.0 + 1e-9):
            raise bad(f"bends[{i}].end", b.end, f"an arc length <= the rod's length {length:g} m")
    return bends


def curved(n_nodes: int, length: float, bends=(), *, origin=(0.0, 0.0, 0.0), direction=(0.0, 0.0, 1.0),
           normal=(1.0, 0.0, 0.0)) -> RodShape:
    """A rod from ``origin`` along ``direction`` (d1 = ``normal`` made orthogonal), straight but for
    its ``bends`` (``Bend`` entries, in order along it): the nodes lie on the exact curve at equal
    arc lengths and carry its twist-free frames. As a reference it is a pre-shaped device; without
    bends it is ``straight``."""
    bends = _checked_bends(bends, length)
    R = straight(2, length, origin=origin, direction=direction, normal=normal).rotations[0].copy()
    r = np.asarray(origin, dtype=float).copy()
    s_nodes = np.linspace(0.0, length, n_nodes)
    cuts = sorted({x for b in bends for x in (b.start, b.end) if 0.0 < x < length})
    pos, rot = [r], [R]
    s, j = 0.0, 0
    for target in s_nodes[1:]:
        while s < target:
            while j < len(cuts) and cuts[j] <= s:
                j += 1
            nxt = min(target, cuts[j]) if j < len(cuts) else target
            mid = 0.5 * (s + nxt)
            k = next((b.body_curvature for b in bends if b.start <= mid < b.end), np.zeros(3))
            R, r = _advance(R, r, k, nxt - s)
            s = nxt
        pos.append(r)
        rot.append(R)
    return RodShape(np.array(pos), np.array(rot))


def shaped_tip(n_nodes: int, length: float, *, angle_deg: float, bend_length: float, tip_length: float = 0.0,
               toward_deg: float = 0.0, origin=(0.0, 0.0, 0.0), direction=(0.0, 0.0, 1.0),
               normal=(1.0, 0.0, 0.0)) -> RodShape:
    """A straight rod with a pre-shaped tip: one bend through ``angle_deg`` degrees over
    ``bend_length`` [m] that ends ``tip_length`` [m] before the distal end (a straight tip beyond
    it), bending toward ``toward_deg`` (``Bend``). A J tip: angle_deg = 180 (bend_length = pi times
    the J's radius); an angled tip: 30-45 degrees over a few mm."""
    positive("angle_deg", angle_deg, "degrees")
    positive("bend_length", bend_length, "m")
    if not (isinstance(tip_length, (int, float)) and 0.0 <= tip_length < math.inf):
        raise bad("tip_length", tip_length, "a length >= 0 in m")
    start = length - tip_length - bend_length
    if start < 0:
        raise bad("bend_length + tip_length", bend_length + tip_length, f"at most the rod's length {length:g} m")
    bend = Bend(start, length - tip_length, math.radians(angle_deg) / bend_length, toward_deg)
    return curved(n_nodes, length, (bend,), origin=origin, direction=direction, normal=normal)
