"""Rigid, fixed obstacles of the rod's world and their geometry (docs/lgvi.md §2.11), shared by the
simulator (``softrnn.rod.contact`` packs them into the kernels' columns), the data files (their
record, ``to_record``/``obstacle_from_record``), the pictures and the learned models' projection.

* ``Plane(point, normal)``: a half space; the rod stays on the side ``normal`` points to;
* ``Sphere(center, radius)`` and ``Cylinder(point, axis, radius)`` (infinite): the rod stays outside;
* ``Vessel(centreline, radius)``: a tube, open at both ends, the rod inside it; the centreline is a
  cubic spline through the given points, sampled into a dense polyline for the kernels;
* ``Bifurcation(trunk, left, right, radius)``: a vessel that splits in two, the rod inside it; its
  lumen is the union of two vessels (trunk + left branch, trunk + right branch), so a node touches
  a wall only where it is outside both, and then the nearer one pushes it back.

Each obstacle has its ``kind`` (the record's name of it), ``gap`` (NumPy references of the gaps the
kernels compute) and ``to_record`` (a JSON-ready dict: ``kind``, its geometry in m and ``friction``;
``obstacle_from_record`` builds it back, docs/dataset-format.md).
"""

import math
from dataclasses import dataclass
from typing import ClassVar

import numpy as np
from scipy.interpolate import CubicSpline

from ..errors import bad, is_finite_number, nonnegative, positive, vec3

UNION_BLEND = 0.25
"""Where the two vessels' gaps of a ``Bifurcation`` differ by less than this fraction of the rod
radius, its normal blends theirs (the crease at the carina; the kernels use the same width)."""

VESSEL_SAGITTA = 1e-3
"""A vessel's polyline deviates from its spline centreline by at most this fraction of its smallest
radius (segment length sqrt(8 e / kappa_max))."""

VESSEL_MAX_SEGMENTS = 200_000
"""Most segments of a vessel's polyline."""


def _friction(value) -> float | None:
    """A per-obstacle friction coefficient: None (the Contact's) or a finite number >= 0."""
    return None if value is None else nonnegative("friction", value)


def _unit(name: str, value) -> np.ndarray:
    v = np.array(vec3(name, value, "(a direction, normalised here)", nonzero=True))
    return v / np.linalg.norm(v)


KINDS = {}
"""The obstacle classes by their record's ``kind`` (each subclass with a kind registers itself;
``geometry.mesh.MeshVessel`` among them)."""


class Obstacle:
    """The base of the obstacle types: their record's ``kind`` and ``to_record``."""

    kind: ClassVar[str] = ""

    def __init_subclass__(cls, **kwargs):
        super().__init_subclass__(**kwargs)
        if cls.kind:
            KINDS[cls.kind] = cls

    def to_record(self, friction: float | None = None) -> dict:
        """The record (JSON-ready): ``kind``, the geometry (``GEOMETRY[kind]``) in m, and ``friction``:
        ``friction`` where given (the mu that applies to it), else its own (None: the Contact's)."""
        entry = {"kind": self.kind}
        entry.update({key: _plain(getattr(self, key)) for key in GEOMETRY[self.kind]})
        entry["friction"] = self.friction if friction is None else float(friction)
        return entry

    @staticmethod
    def from_record(entry, where: str = "contact.obstacles") -> "Obstacle":
        """The obstacle of a record (``to_record``: its ``kind`` picks the type); a malformed one is
        a one-line ``SoftrnnInputError`` naming ``where``."""
        kind = entry.get("kind") if isinstance(entry, dict) else None
        if kind not in KINDS:
            raise bad(where, _short(entry), f"a dict with kind one of {', '.join(KINDS)}")
        if hasattr(KINDS[kind], "_from_entry"):      # a kind with a record of its own form (a mesh)
            return KINDS[kind]._from_entry(entry, where)
        keys = GEOMETRY[kind]
        missing = [k for k in keys if k not in entry]
        if missing:
            raise bad(where, _short(entry), f"the {kind}'s {', '.join(keys)} (missing: {', '.join(missing)})")
        return KINDS[kind](*(entry[k] for k in keys), friction=entry.get("friction"))


@dataclass(frozen=True, eq=False)
class Plane(Obstacle):
    """A half space: the rod stays on the side its ``normal`` points to.

    Attributes
    ----------
    point : (3,)
        a point of the plane [m]
    normal : (3,)
        its normal, toward the rod's side (normalised here) [-]
    friction : float or None
        friction coefficient mu [-] of this obstacle; None: the ``Contact``'s
    """

    kind: ClassVar[str] = "plane"

    point: tuple
    normal: tuple
    friction: float | None = None

    def __post_init__(self):
        object.__setattr__(self, "point", vec3("plane.point", self.point, "in m"))
        object.__setattr__(self, "normal", tuple(_unit("plane.normal", self.normal)))
        object.__setattr__(self, "friction", _friction(self.friction))

    def gap(self, positions: np.ndarray, radius: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Gaps (n,) [m] of the rod's surface and unit normals (n, 3) at node positions (n, 3) [m]
        with rod radii (n,) [m]."""
        n = np.asarray(self.normal)
        x = np.asarray(positions, dtype=float)
        return (x - np.asarray(self.point)) @ n - radius, np.broadcast_to(n, x.shape).copy()


def _radial_gap(q: np.ndarray, size: float, radius: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Gaps and normals from the radial vectors q (n, 3) [m] of a sphere or cylinder of radius size."""
    d = np.linalg.norm(q, axis=1)
    with np.errstate(invalid="ignore", divide="ignore"):
        normal = np.where(d[:, None] > 0, q / d[:, None], 0.0)
    return np.where(d > 0, d - size - radius, np.inf), normal


@dataclass(frozen=True, eq=False)
class Sphere(Obstacle):
    """A solid ball; the rod stays outside.

    Attributes
    ----------
    center : (3,)
        centre [m]
    radius : float
        radius [m], > 0
    friction : float or None
        friction coefficient mu [-]; None: the ``Contact``'s
    """

    kind: ClassVar[str] = "sphere"

    center: tuple
    radius: float
    friction: float | None = None

    def __post_init__(self):
        object.__setattr__(self, "center", vec3("sphere.center", self.center, "in m"))
        object.__setattr__(self, "radius", positive("sphere.radius", self.radius, "m"))
        object.__setattr__(self, "friction", _friction(self.friction))

    def gap(self, positions: np.ndarray, radius: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Gaps (n,) [m] and outward unit normals (n, 3) at node positions (n, 3) [m] with rod radii
        (n,) [m]; inf at the centre."""
        return _radial_gap(np.asarray(positions, dtype=float) - np.asarray(self.center), self.radius, radius)


@dataclass(frozen=True, eq=False)
class Cylinder(Obstacle):
    """A solid, infinitely long circular cylinder; the rod stays outside.

    Attributes
    ----------
    point : (3,)
        a point of its axis [m]
    axis : (3,)
        the axis direction (normalised here) [-]
    radius : float
        radius [m], > 0
    friction : float or None
        friction coefficient mu [-]; None: the ``Contact``'s
    """

    kind: ClassVar[str] = "cylinder"

    point: tuple
    axis: tuple
    radius: float
    friction: float | None = None

    def __post_init__(self):
        object.__setattr__(self, "point", vec3("cylinder.point", self.point, "in m"))
        object.__setattr__(self, "axis", tuple(_unit("cylinder.axis", self.axis)))
        object.__setattr__(self, "radius", positive("cylinder.radius", self.radius, "m"))
        object.__setattr__(self, "friction", _friction(self.friction))

    def gap(self, positions: np.ndarray, radius: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Gaps (n,) [m] and outward unit normals (n, 3) at node positions (n, 3) [m] with rod radii
        (n,) [m]; inf on the axis."""
        q = np.asarray(positions, dtype=float) - np.asarray(self.point)
        e = np.asarray(self.axis)
        return _radial_gap(q - np.outer(q @ e, e), self.radius, radius)


def _centreline(points, radius, line: str = "vessel.centreline", size: str = "vessel.radius",
                least: int = 2) -> tuple[np.ndarray, np.ndarray]:
    """Validated centreline points (m, 3) [m], m >= least, and radii (m,) [m]; errors name the
    arguments ``line`` and ``size``."""
    try:
        p = np.array(points, dtype=float)
    except (TypeError, ValueError):
        raise bad(line, points, f"an (m, 3) array of points in m, m >= {least}") from None
    if p.ndim != 2 or p.shape[1] != 3 or p.shape[0] < least or not np.all(np.isfinite(p)):
        raise bad(line, f"an array of shape {p.shape}", f"(m, 3) finite points in m, m >= {least}")
    if np.any(np.linalg.norm(np.diff(p, axis=0), axis=1) <= 0):
        raise bad(line, "repeated consecutive points", "distinct consecutive points")
    if is_finite_number(radius):
        rad = np.full(len(p), positive(size, radius, "m"))
    else:
        rad = np.array(radius, dtype=float) if np.ndim(radius) == 1 else np.zeros(0)
        if rad.shape != (len(p),) or not np.all(np.isfinite(rad)) or np.any(rad <= 0):
            raise bad(size, radius, f"a positive radius in m, or ({len(p)},) positive radii, one per point")
    return p, rad


def _sample(points: np.ndarray, radius: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The dense polyline (P, 3) [m] and radii (P,) [m] of a centreline: a cubic spline over the
    chord length through the points, sampled so that the chords stay within VESSEL_SAGITTA of the
    smallest radius of it; the radius interpolated linearly."""
    s = np.concatenate([[0.0], np.cumsum(np.linalg.norm(np.diff(points, axis=0), axis=1))])
    if len(points) == 2:
        return points.copy(), radius.copy()
    spline = CubicSpline(s, points, axis=0)
    fine = np.linspace(0.0, s[-1], 64 * len(points))
    d1, d2 = spline(fine, 1), spline(fine, 2)
    kappa = float(np.max(np.linalg.norm(np.cross(d1, d2), axis=1) / np.linalg.norm(d1, axis=1) ** 3))
    ds = math.sqrt(8.0 * VESSEL_SAGITTA * float(np.min(radius)) / kappa) if kappa > 0 else s[-1]
    count = min(max(math.ceil(s[-1] / ds), len(points) - 1), VESSEL_MAX_SEGMENTS)
    t = np.linspace(0.0, s[-1], count + 1)
    return spline(t), np.interp(t, s, radius)


def closest_segments(points: np.ndarray, positions: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Brute-force closest segments of a polyline (the reference of the kernels' local search).

    Parameters
    ----------
    points : (P, 3)
        the polyline [m], P >= 2
    positions : (n, 3)
        query points [m]

    Returns
    -------
    index : (n,) int64
        the closest segment (the first of equally close ones)
    distance : (n,)
        the distance to it [m]
    t : (n,)
        the projection parameter on its line, not clipped (< 0 or > 1: beyond its ends) [-]
    """
    x = np.asarray(positions, dtype=float)[:, None, :]
    a, e = points[None, :-1], np.diff(points, axis=0)[None]
    t = np.sum((x - a) * e, axis=2) / np.sum(e * e, axis=2)
    q = x - a - np.clip(t, 0.0, 1.0)[..., None] * e
    d2 = np.sum(q * q, axis=2)
    index = np.argmin(d2, axis=1)
    rows = np.arange(len(index))
    return index.astype(np.int64), np.sqrt(d2[rows, index]), t[rows, index]


@dataclass(frozen=True, eq=False)
class Vessel(Obstacle):
    """A tube, open at both ends, with the rod inside it.

    Attributes
    ----------
    centreline : (m, 3)
        points of its centreline [m], m >= 2, interpolated by a cubic spline over the chord length
        (``scipy.interpolate.CubicSpline``; two points: a straight tube)
    radius : float or (m,)
        its inner radius [m], or one per point, interpolated linearly
    friction : float or None
        friction coefficient mu [-]; None: the ``Contact``'s
    points : (P, 3)
        the dense polyline the kernels search [m] (computed: the spline sampled so that it stays
        within ``VESSEL_SAGITTA`` times the smallest radius of the curve)
    radii : (P,)
        the radius at those points [m] (computed)
    """

    kind: ClassVar[str] = "vessel"

    centreline: np.ndarray
    radius: float | np.ndarray
    friction: float | None = None

    def __post_init__(self):
        p, rad = _centreline(self.centreline, self.radius)
        p.setflags(write=False)
        object.__setattr__(self, "centreline", p)
        object.__setattr__(self, "friction", _friction(self.friction))
        points, radii = _sample(p, rad)
        for a in (points, radii):
            a.setflags(write=False)
        object.__setattr__(self, "points", points)
        object.__setattr__(self, "radii", radii)

    def gap(self, positions: np.ndarray, radius: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Gaps (n,) [m] and inward unit normals (n, 3) at node positions (n, 3) [m] with rod radii
        (n,) [m], from the closest polyline segment (brute force); inf beyond the open ends."""
        x = np.asarray(positions, dtype=float)
        index, d, t = closest_segments(self.points, x)
        last = len(self.points) - 2
        beyond = ((index == 0) & (t < 0)) | ((index == last) & (t > 1))
        tc = np.clip(t, 0.0, 1.0)
        c = self.points[index] + tc[:, None] * (self.points[index + 1] - self.points[index])
        size = self.radii[index] + tc * (self.radii[index + 1] - self.radii[index])
        with np.errstate(invalid="ignore", divide="ignore"):
            normal = np.where(d[:, None] > 0, (c - x) / d[:, None], 0.0)
        return np.where(beyond | (d <= 0), np.inf, size - radius - d), normal


def _branch(side: str, points, radius, trunk: np.ndarray, trunk_radii: np.ndarray):
    """A bifurcation branch's validated points (k, 3) [m] after the junction (a first point on the
    junction dropped) and its radius: a number [m] (None: the trunk's at the junction) or (k,) [m]."""
    line, size = f"bifurcation.{side}", f"bifurcation.{side}_radius"
    if radius is None:
        radius = float(trunk_radii[-1])
    p, rad = _centreline(points, radius, line, size, least=1)
    if np.array_equal(p[0], trunk[-1]):
        p, rad = p[1:], rad[1:]
        if len(p) == 0:
            raise bad(line, "only the junction", "at least one point after the junction (the trunk's last point)")
    value = float(radius) if is_finite_number(radius) else rad
    return p, value, rad


@dataclass(frozen=True, eq=False)
class Bifurcation(Obstacle):
    """A vessel that splits in two: a trunk, then a left and a right branch, the rod inside it.

    The lumen is the union of two ``Vessel`` tubes, trunk + left branch and trunk + right branch:
    a node touches a wall only where it is outside both tubes, and the nearer wall (the larger gap)
    pushes it back (docs/lgvi.md §2.11); where the two gaps differ by less than ``UNION_BLEND``
    times the rod radius (the crease where the walls meet, at the carina), the normal blends theirs.
    The trunk and each branch are cubic splines of their own (``Vessel``'s, over the chord length),
    a branch's from the junction through its points, so the tubes meet at the junction with a
    corner; the kernels track the closest segment of each tube per node.

    Attributes
    ----------
    trunk : (m, 3)
        centreline points of the trunk [m], m >= 2; its last point is the junction
    left, right : (k, 3)
        centreline points of each branch after the junction [m], k >= 1 (a first point equal to
        the junction is dropped here)
    radius : float or (m,)
        the trunk's inner radius [m], or one per trunk point
    left_radius, right_radius : float, (k,) or None
        each branch's inner radius [m], or one per branch point; None: the trunk's radius at the
        junction (resolved here)
    friction : float or None
        friction coefficient mu [-]; None: the ``Contact``'s
    vessels : tuple of Vessel
        (trunk + left, trunk + right), computed, with this friction: each one's ``centreline`` and
        ``radius`` are the trunk's points and radii followed by the branch's, its ``points`` and
        ``radii`` the trunk's polyline followed by the branch's (the radius at the junction the
        trunk's)
    trunk_rows : int
        the rows of each vessel's ``points`` that are the trunk's (computed; the last one is the
        junction)
    """

    kind: ClassVar[str] = "bifurcation"

    trunk: np.ndarray
    left: np.ndarray
    right: np.ndarray
    radius: float | np.ndarray
    left_radius: float | np.ndarray | None = None
    right_radius: float | np.ndarray | None = None
    friction: float | None = None

    def __post_init__(self):
        trunk, trunk_radii = _centreline(self.trunk, self.radius, "bifurcation.trunk", "bifurcation.radius")
        trunk.setflags(write=False)
        object.__setattr__(self, "trunk", trunk)
        object.__setattr__(self, "radius", float(self.radius) if is_finite_number(self.radius) else trunk_radii)
        object.__setattr__(self, "friction", _friction(self.friction))
        trunk_points, trunk_sampled = _sample(trunk, trunk_radii)
        vessels = []
        for side in ("left", "right"):
            p, value, rad = _branch(side, getattr(self, side), getattr(self, f"{side}_radius"), trunk, trunk_radii)
            p.setflags(write=False)
            object.__setattr__(self, side, p)
            object.__setattr__(self, f"{side}_radius", value)
            vessel = Vessel(np.concatenate([trunk, p]), np.concatenate([trunk_radii, rad]), friction=self.friction)
            # the trunk's own spline, then the branch's from the junction (a corner there)
            points, radii = _sample(np.concatenate([trunk[-1:], p]), np.concatenate([rad[:1], rad]))
            points = np.concatenate([trunk_points, points[1:]])
            radii = np.concatenate([trunk_sampled, radii[1:]])
            for name, a in (("points", points), ("radii", radii)):
                a.setflags(write=False)
                object.__setattr__(vessel, name, a)
            vessels.append(vessel)
        object.__setattr__(self, "vessels", tuple(vessels))
        object.__setattr__(self, "trunk_rows", len(trunk_points))

    def gap(self, positions: np.ndarray, radius: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Gaps (n,) [m] and inward unit normals (n, 3) at node positions (n, 3) [m] with rod radii
        (n,) [m], brute force: the larger gap of the two vessels, with its normal, blended with the
        other's where their gaps differ by less than ``UNION_BLEND`` r (as the kernels do; the
        normal is only used where the gap is negative)."""
        (g, n), (h, m) = (v.gap(positions, radius) for v in self.vessels)
        best = np.maximum(g, h)
        width = UNION_BLEND * np.asarray(radius, dtype=float)
        with np.errstate(invalid="ignore"):  # inf - inf beyond both open ends
            u = np.clip(1.0 - (best - g) / width, 0.0, None)
            w = np.clip(1.0 - (best - h) / width, 0.0, None)
        b = np.nan_to_num(u)[:, None] * n + np.nan_to_num(w)[:, None] * m
        size = np.linalg.norm(b, axis=1)
        with np.errstate(invalid="ignore", divide="ignore"):
            normal = np.where(size[:, None] > 0, b / size[:, None], 0.0)
        return np.where((best < 0) & ~(size > 0), np.inf, best), normal

    def inside(self, positions: np.ndarray, radius=0.0) -> np.ndarray:
        """Which tubes hold each point, (n, 2) bool (left, right): the surface of a rod of radius
        ``radius`` [m] (a number or (n,)) around the points (n, 3) [m] clear of that tube's wall
        (gap >= 0, open ends included). Inside both: the trunk or the junction; one: that branch."""
        x = np.atleast_2d(np.asarray(positions, dtype=float))
        r = np.broadcast_to(np.asarray(radius, dtype=float), (len(x),))
        return np.stack([v.gap(x, r)[0] >= 0 for v in self.vessels], axis=1)


OBSTACLES = (Plane, Sphere, Cylinder, Vessel, Bifurcation)
"""The obstacle types of this module (a ``Contact`` takes any ``Obstacle``: these and
``geometry.mesh.MeshVessel``)."""


def _plain(value):
    """A geometry value as JSON: a number, or nested lists of numbers."""
    if is_finite_number(value):
        return float(value)
    return np.asarray(value, dtype=float).tolist()


GEOMETRY = {"plane": ("point", "normal"), "sphere": ("center", "radius"), "cylinder": ("point", "axis", "radius"),
            "vessel": ("centreline", "radius"),
            "bifurcation": ("trunk", "left", "right", "radius", "left_radius", "right_radius")}
"""Each kind's geometry in its record, in the order its class takes them."""


def _short(value):
    """``value``, or the start of its text where that is long (for error messages)."""
    text = repr(value)
    return value if len(text) <= 80 else text[:70] + " ..."
