"""Contact between the rod and rigid, fixed obstacles, with Coulomb friction (docs/lgvi.md §2.11).

``Setup(contact=Contact(obstacles=(...), friction=mu))`` puts obstacles in the rod's world:

* ``Plane(point, normal)``: a half space; the rod stays on the side ``normal`` points to;
* ``Sphere(center, radius)`` and ``Cylinder(point, axis, radius)`` (infinite): the rod stays outside;
* ``Vessel(centreline, radius)``: a tube, open at both ends, the rod inside it; the centreline is a
  cubic spline through the given points, sampled into a dense polyline for the kernels;
* ``Bifurcation(trunk, left, right, radius)``: a vessel that splits in two, the rod inside it; its
  lumen is the union of two vessels (trunk + left branch, trunk + right branch), so a node touches
  a wall only where it is outside both, and then the nearer one pushes it back.

The rod's surface is its centreline offset by the rod radius r (per node, overrides included). Per
node and obstacle, with gap g the signed distance from the node to the obstacle's surface minus r
and n the obstacle's unit normal at the node (pointing to the rod's side):

* normal force  f_n = max(0, -k g - c v_n) along n when g < 0 (penalty spring with damping, no
  adhesion), applied at the node;
* friction      f_t = -mu f_n v_t / max(|v_t|, v_s') at the contact point -r n, with v_t the
  tangential velocity of that point, and its moment (-r n) x f_t on the node.

Both are evaluated from the state at the start of each step, with the staggered velocities (like the
PD tracking force), and join the applied loads in both integrators. This module holds the obstacles,
their validation and the arrays the kernels read (``rod.kernels``, ``_contact_loads``), and NumPy
references of the gaps and of the vessels' closest segments.
"""

import math
from dataclasses import dataclass

import numpy as np
from scipy.interpolate import CubicSpline

from ..errors import bad, finite, is_finite_number, nonnegative, positive, vec3
from .kernels import BIFURCATION, BRANCH, CYLINDER, PLANE, SELF, SPHERE, UNION_BLEND, VESSEL

STANDARD_GRAVITY = 9.81
"""Reference acceleration [m/s^2] of the default stiffness when the setup has no constant gravity."""

DEFAULT_PENETRATION = 0.005
"""Default penetration at the reference load, as a fraction of the rod radius: half the 1 % the
contact is designed for, a margin of 2 for the share of the rod's weight that bending moves onto
one node."""

DEFAULT_SLIP_VELOCITY = 1e-4
"""Default slip velocity v_s [m/s] of the regularised Coulomb friction."""

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


@dataclass(frozen=True, eq=False)
class Plane:
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
class Sphere:
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
class Cylinder:
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
class Vessel:
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
class Bifurcation:
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
"""The obstacle types a ``Contact`` takes."""


@dataclass(frozen=True, kw_only=True, eq=False)
class Contact:
    """Contact of the rod with rigid, fixed obstacles (docs/lgvi.md §2.11).

    Attributes
    ----------
    obstacles : tuple
        ``Plane``, ``Sphere``, ``Cylinder``, ``Vessel`` and ``Bifurcation`` entries (one obstacle
        alone is accepted)
    friction : float
        Coulomb friction coefficient mu [-] of the obstacles that set none (0: frictionless)
    slip_velocity : float
        v_s [m/s] > 0: friction grows linearly with the slip velocity below it (regularised
        Coulomb); the kernels raise it, where needed, to h mu f_n / m_eff for a stable step
    stiffness : float or None
        penalty stiffness per length of rod [N/m^2] (node a gets k w_a l); None: per node
        k_a = m_a a_ref / (penetration r_a), the node's weight under a_ref penetrates by
        ``penetration`` times its radius
    damping : float or None
        normal damping per length of rod [N s/m^2] (node a gets c w_a l); None: critical,
        c_a = 2 sqrt(k_a m_a)
    penetration : float
        the default stiffness' penetration at the reference load, a fraction of the rod radius in
        (0, 1)
    reference_acceleration : float or None
        a_ref [m/s^2] > 0 of the default stiffness; None: |g| of the setup's constant gravity, or
        ``STANDARD_GRAVITY`` without one
    self_contact : bool
        also contact between the rod's own segments (frictionless, with the same stiffness and
        damping per node, in series; ``self_contact_gap``); the obstacles may then be empty
    """

    obstacles: tuple = ()
    friction: float = 0.0
    slip_velocity: float = DEFAULT_SLIP_VELOCITY
    stiffness: float | None = None
    damping: float | None = None
    penetration: float = DEFAULT_PENETRATION
    reference_acceleration: float | None = None
    self_contact: bool = False

    def __post_init__(self):
        obstacles = (self.obstacles,) if isinstance(self.obstacles, OBSTACLES) else self.obstacles
        try:
            obstacles = tuple(obstacles)
        except TypeError:
            raise bad("contact.obstacles", self.obstacles,
                      "a tuple of Plane, Sphere, Cylinder, Vessel or Bifurcation") from None
        if not isinstance(self.self_contact, bool):
            raise bad("contact.self_contact", self.self_contact, "true or false")
        if not (obstacles or self.self_contact) or not all(isinstance(o, OBSTACLES) for o in obstacles):
            raise bad("contact.obstacles", self.obstacles,
                      "one or more Plane, Sphere, Cylinder, Vessel or Bifurcation entries (or none, with "
                      "self_contact = true)")
        object.__setattr__(self, "obstacles", obstacles)
        object.__setattr__(self, "friction", nonnegative("contact.friction", self.friction))
        object.__setattr__(self, "slip_velocity", positive("contact.slip_velocity", self.slip_velocity, "m/s"))
        for name, unit in (("stiffness", "N/m^2"), ("damping", "N s/m^2")):
            if getattr(self, name) is not None:
                check = positive if name == "stiffness" else nonnegative
                object.__setattr__(self, name, check(f"contact.{name}", getattr(self, name), unit))
        p = finite("contact.penetration", self.penetration)
        if not 0 < p < 1:
            raise bad("contact.penetration", self.penetration, "a fraction of the rod radius in (0, 1), e.g. 0.005")
        if self.reference_acceleration is not None:
            positive("contact.reference_acceleration", self.reference_acceleration, "m/s^2")

    def friction_of(self, obstacle) -> float:
        """The friction coefficient [-] of one of the obstacles (its own, or the Contact's)."""
        return self.friction if obstacle.friction is None else obstacle.friction

    def gaps(self, positions: np.ndarray, radius: np.ndarray) -> np.ndarray:
        """Gaps (n, o) [m] of the rod's surface to each obstacle at node positions (n, 3) [m] with
        rod radii (n,) [m] (NumPy, brute force; inf where no contact is possible; o = 0 without
        obstacles)."""
        x = np.asarray(positions, dtype=float)
        return np.stack([o.gap(x, radius)[0] for o in self.obstacles] or [np.zeros((0, len(x)))], axis=-1
                        ).reshape(len(x), len(self.obstacles))


def self_contact_gap(rod) -> int:
    """The least index gap j - i of two segments i < j of ``rod`` (a ``RodSpec``) that may touch:
    2 + ceil(2 r_max / l), l the segment length, so that neighbouring segments of a straight or
    gently bent rod, whose surfaces overlap near their shared nodes, are never in contact."""
    return 2 + math.ceil(2.0 * float(np.max(rod.node_properties()["radius"])) / rod.segment_length - 1e-12)


def node_parameters(contact: Contact, rod, gravity) -> np.ndarray:
    """Per node (n, 3): rod radius r_a [m], stiffness k_a [N/m], damping c_a [N s/m] of a
    ``Contact`` on the rod ``rod`` (a ``RodSpec``) under ``gravity`` (a setup's constant (3,)
    [m/s^2], or a time function: no constant gravity)."""
    radius = rod.node_properties()["radius"]
    lumped = rod.lumped()
    mass, wl = lumped["mass"], lumped["weight"] * rod.segment_length
    if contact.stiffness is not None:
        k = contact.stiffness * wl
    else:
        a_ref = contact.reference_acceleration
        if a_ref is None:
            g = 0.0 if callable(gravity) else float(np.linalg.norm(gravity))
            a_ref = g if g > 0 else STANDARD_GRAVITY
        k = mass * a_ref / (contact.penetration * radius)
    c = 2.0 * np.sqrt(k * mass) if contact.damping is None else contact.damping * wl
    return np.ascontiguousarray(np.stack([radius, k, c], axis=1))


def _columns(contact: Contact) -> list:
    """The kernels' obstacle columns: (obstacle index, kind, vessel or None) per column, a
    bifurcation as a BIFURCATION column (its left vessel) and a BRANCH column (its right one)."""
    columns = []
    for j, ob in enumerate(contact.obstacles):
        if isinstance(ob, Bifurcation):
            columns += [(j, BIFURCATION, ob.vessels[0]), (j, BRANCH, ob.vessels[1])]
        else:
            columns.append((j, VESSEL, ob) if isinstance(ob, Vessel) else (j, None, None))
    return columns


def kernel_arrays(contact: Contact, rod, gravity) -> dict:
    """The static contact fields of ``kernels.StepInputs`` (contact_kind, contact_geom,
    contact_range, contact_friction, contact_points, contact_radii, contact_node) for a
    ``Contact`` on the rod ``rod`` (a ``RodSpec``) under ``gravity`` (see ``node_parameters``):
    one column per obstacle, a ``Bifurcation`` one per vessel, and a last SELF column with
    ``self_contact`` (its geom[0]: ``self_contact_gap``)."""
    columns = _columns(contact)
    o = len(columns)
    kind = np.zeros(o, dtype=np.int64)
    geom = np.zeros((o, 7))
    rng = np.zeros((o, 2), dtype=np.int64)
    points, radii, start = [], [], 0
    for c, (j, kd, vessel) in enumerate(columns):
        ob = contact.obstacles[j]
        if isinstance(ob, Plane):
            kind[c], geom[c, :6] = PLANE, (*ob.point, *ob.normal)
        elif isinstance(ob, Sphere):
            kind[c], geom[c, :3], geom[c, 6] = SPHERE, ob.center, ob.radius
        elif isinstance(ob, Cylinder):
            kind[c], geom[c] = CYLINDER, (*ob.point, *ob.axis, ob.radius)
        else:
            kind[c], rng[c] = kd, (start, len(vessel.points))
            points.append(vessel.points)
            radii.append(vessel.radii)
            start += len(vessel.points)
    friction = np.array([[contact.friction_of(contact.obstacles[j]), contact.slip_velocity] for j, *_ in columns]
                        ).reshape(o, 2)
    if contact.self_contact:                 # the last column: between the rod's own segments
        kind = np.append(kind, SELF)
        geom = np.vstack([geom, [[self_contact_gap(rod), 0, 0, 0, 0, 0, 0]]])
        rng = np.vstack([rng, np.zeros((1, 2), dtype=np.int64)])
        friction = np.vstack([friction, [[0.0, contact.slip_velocity]]])
    return dict(contact_kind=kind, contact_geom=geom, contact_range=rng, contact_friction=friction,
                contact_points=np.ascontiguousarray(np.concatenate(points) if points else np.zeros((0, 3))),
                contact_radii=np.ascontiguousarray(np.concatenate(radii) if radii else np.zeros(0)),
                contact_node=node_parameters(contact, rod, gravity))


def initial_segments(contact: Contact, positions: np.ndarray) -> np.ndarray:
    """The tracked vessel segments (n, o) int64 at node positions (n, 3) [m], one column per
    kernel column (``kernel_arrays``): the closest segment of each vessel, a bifurcation's included,
    by brute force (0 in the columns of other obstacles)."""
    columns = _columns(contact)
    seg = np.zeros((len(positions), len(columns) + int(contact.self_contact)), dtype=np.int64)
    for c, (_, _, vessel) in enumerate(columns):
        if vessel is not None:
            seg[:, c] = closest_segments(vessel.points, positions)[0]
    return seg


def check_initial(contact: Contact, positions: np.ndarray, radius: np.ndarray) -> None:
    """Refuse rod radii (n,) [m] wider than a vessel, and node positions (n, 3) [m] that start deeper
    in an obstacle than the rod's radius, with a one-line error naming the node and obstacle."""
    for j, ob in enumerate(contact.obstacles):
        for vessel in ob.vessels if isinstance(ob, Bifurcation) else (ob,) if isinstance(ob, Vessel) else ():
            if np.max(radius) >= np.min(vessel.radii):
                raise bad(f"contact.obstacles[{j}].radius", float(np.min(vessel.radii)),
                          f"a vessel wider than the rod (rod radius up to {np.max(radius):.4g} m)")
    gaps = contact.gaps(positions, radius)
    deep = gaps < -radius[:, None]
    if np.any(deep):
        a, j = np.argwhere(deep)[0]
        name = type(contact.obstacles[j]).__name__
        raise bad("initial", f"node {a} {-gaps[a, j]:.3g} m inside obstacle {j} ({name})",
                  "an initial shape on the rod's side of every obstacle (at most the rod radius inside)")


def step_limit(nodes: np.ndarray, mass: np.ndarray, omega: float = 0.0) -> float:
    """Largest stable step [s] of the explicit contact spring and damper of every node (before a
    safety factor): the scalar leapfrog with explicit damping is stable for h^2 w^2 + 2 h g < 4,
    with w^2 = omega^2 + max k_a/m_a (the node's elastic frequency omega [rad/s] plus the spring)
    and g = max c_a/m_a; ``nodes`` (n, 3) from ``node_parameters``, ``mass`` (n,) [kg]."""
    w2 = omega**2 + float(np.max(nodes[:, 1] / mass))
    g = float(np.max(nodes[:, 2] / mass))
    return (-g + math.sqrt(g * g + 4.0 * w2)) / w2
