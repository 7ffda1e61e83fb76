"""The geometry of a rod picture: the view (a flat plane or 3-D), the bounds of the fixed axes, the
force arrows' scale and their 3-D strokes, the nodes that never move, and the obstacles' meshes and
outlines (a plane's patch, a sphere, a cylinder's segment, a vessel's wall)."""

from __future__ import annotations

import math

import numpy as np

from ..errors import SoftrnnInputError

VIEWS = ("auto", "xy", "xz", "yz", "3d")
_PLANES = {"xy": (0, 1), "xz": (0, 2), "yz": (1, 2)}
_FLAT = 0.01  # an axis whose range is below 1 % of the largest range counts as flat
_ARROW = 0.2  # the largest force is drawn about this fraction of the motion's extent


def _nice(x: float) -> float:
    """The largest 1, 2 or 5 x 10^k not above x (x > 0)."""
    k = math.floor(math.log10(x))
    for m in (5, 2, 1):
        if m * 10.0**k <= x * (1 + 1e-9):
            return m * 10.0**k
    return 10.0**k


def _fmt(x: float) -> str:
    """``x`` to 3 significant digits."""
    return f"{x:.3g}"


def force_scale(fmax: float, extent: float) -> tuple[float, float, float]:
    """(metres per newton, reference force [N], its arrow length [m]) for forces up to ``fmax``
    drawn on a picture ``extent`` metres across: the largest force gets about 20 % of the extent,
    rounded down to a 1-2-5 scale so the legend reads e.g. "1 N = 0.1 m"."""
    fmax = max(fmax, 1e-300)
    k = _nice(_ARROW * extent / fmax)
    ref = _nice(fmax)
    return k, ref, ref * k


def choose_view(positions: np.ndarray) -> str:
    """'xy', 'xz' or 'yz' when the motion stays in such a plane (one axis' range below 1 % of the
    largest), '3d' otherwise."""
    pts = positions.reshape(-1, 3)
    ranges = pts.max(0) - pts.min(0)
    big = float(ranges.max())
    if big <= 0:
        return "xy"
    for plane, flat in (("xy", 2), ("xz", 1), ("yz", 0)):
        if ranges[flat] <= _FLAT * big:
            return plane
    return "3d"


def vessel_plane(obstacles) -> str | None:
    """'xy', 'xz' or 'yz' when the vessels among ``obstacles`` (``figures.obstacles.obstacles_of``:
    dicts with ``kind`` and a vessel's centreline ``points`` (P, 3) [m]) span such a plane (one
    axis' range below 1 % of the largest, the other two above), else None (no vessel, a straight one,
    or a vessel bending in 3-D). A rod inside a flat vessel is seen inside it along the plane's normal."""
    points = [np.asarray(o["points"], dtype=float).reshape(-1, 3) for o in obstacles
              if o.get("kind") == "vessel" and o.get("points") is not None]
    if not points:
        return None
    pts = np.concatenate(points)
    ranges = pts.max(0) - pts.min(0)
    big = float(ranges.max())
    flat = ranges <= _FLAT * big
    if big <= 0 or int(flat.sum()) != 1:
        return None
    return {2: "xy", 1: "xz", 0: "yz"}[int(np.argmax(flat))]


def _bounds(points: np.ndarray, pad: float = 0.06, min_fraction: float = 0.15):
    """Per-axis (lo, hi) covering points (k, 3) with a margin, every axis at least ``min_fraction`` of
    the largest range (centred), so equal-aspect boxes never collapse."""
    lo, hi = points.min(0), points.max(0)
    size = max(float((hi - lo).max()), 1e-3)
    half = np.maximum((hi - lo) / 2, min_fraction * size / 2) + pad * size
    mid = (lo + hi) / 2
    return mid - half, mid + half


def _max_norm(vectors: np.ndarray, chunk: int = 4096) -> float:
    """Largest |v| of (T, N, 3) vectors, in chunks of samples (no full-size temporaries); NaN -> error."""
    best = 0.0
    for k in range(0, vectors.shape[0], chunk):
        v = np.asarray(vectors[k:k + chunk], dtype=float)
        if v.size:
            m = float(np.sqrt((v * v).sum(-1)).max())
            if not math.isfinite(m):
                raise SoftrnnInputError("forces contain NaN or inf: the data is broken; re-create it")
            best = max(best, m)
    return best


def _fixed_nodes(positions: np.ndarray, extent: float) -> np.ndarray:
    """Columns whose position never changes (clamped or pinned ends)."""
    if positions.shape[0] < 2:
        return np.zeros(0, dtype=int)
    moved = np.abs(positions - positions[:1]).max(axis=(0, 2))
    return np.flatnonzero(moved <= 1e-9 * max(extent, 1e-12))


def _arrow_segments(tails: np.ndarray, vectors: np.ndarray, view_dir: np.ndarray, extent: float):
    """3-D arrows as line segments: a shaft and two head strokes in the plane facing the camera."""
    segs = []
    for p, v in zip(tails, vectors):
        length = float(np.linalg.norm(v))
        if length <= 0:
            continue
        u = v / length
        w = np.cross(u, view_dir)
        if np.linalg.norm(w) < 1e-6:
            w = np.cross(u, [1.0, 0.0, 0.0] if abs(u[0]) < 0.9 else [0.0, 1.0, 0.0])
        w /= np.linalg.norm(w)
        tip = p + v
        head = min(0.3 * length, 0.04 * extent)
        back = tip - head * 0.9 * u
        segs += [(p, tip), (tip, back + 0.45 * head * w), (tip, back - 0.45 * head * w)]
    return segs


# -- obstacles (``softrnn.rod.contact``): meshes and outlines in the rod's world [m]
def _frame(direction) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """A right-handed orthonormal frame (e, u, v) whose first vector is ``direction`` (3,) normalised."""
    e = np.asarray(direction, dtype=float)
    e = e / np.linalg.norm(e)
    u = np.cross(e, [1.0, 0.0, 0.0] if abs(e[0]) < 0.9 else [0.0, 1.0, 0.0])
    u /= np.linalg.norm(u)
    return e, u, np.cross(e, u)


def _box_corners(lo, hi) -> np.ndarray:
    """The 8 corners (8, 3) of the axis-aligned box [lo, hi]."""
    lo, hi = np.asarray(lo, dtype=float), np.asarray(hi, dtype=float)
    pick = np.array([[i >> k & 1 for k in range(3)] for i in range(8)], dtype=bool)
    return np.where(pick, hi, lo)


def plane_patch(point, normal, lo, hi) -> np.ndarray:
    """The rectangle (4, 3) [m] of the plane through ``point`` with ``normal`` that covers the
    projection of the box [lo, hi] (the rod's extent) onto the plane, corners in order."""
    n, u, v = _frame(normal)
    p = np.asarray(point, dtype=float)
    q = _box_corners(lo, hi) - p
    a, b = q @ u, q @ v
    corners = np.array([[a.min(), b.min()], [a.max(), b.min()], [a.max(), b.max()], [a.min(), b.max()]])
    return p + corners @ np.stack([u, v])


def sphere_mesh(center, radius: float, count: int = 24) -> np.ndarray:
    """Points (count, count, 3) [m] of a sphere's surface on a latitude-longitude grid."""
    theta = np.linspace(0.0, np.pi, count)[:, None]
    phi = np.linspace(0.0, 2 * np.pi, count)[None, :]
    unit = np.stack(np.broadcast_arrays(np.sin(theta) * np.cos(phi), np.sin(theta) * np.sin(phi), np.cos(theta)), -1)
    return np.asarray(center, dtype=float) + radius * unit


def cylinder_mesh(point, axis, radius: float, lo, hi, count: int = 24) -> np.ndarray:
    """Points (2, count, 3) [m] of the segment of an infinite cylinder (axis through ``point``
    along ``axis``) whose axial span is that of the box [lo, hi] (the rod's extent) on the axis."""
    e, u, v = _frame(axis)
    p = np.asarray(point, dtype=float)
    t = (_box_corners(lo, hi) - p) @ e
    phi = np.linspace(0.0, 2 * np.pi, count)
    ring = radius * (np.cos(phi)[:, None] * u + np.sin(phi)[:, None] * v)
    return p + np.array([t.min(), t.max()])[:, None, None] * e + ring[None]


def tube_mesh(points, radii, count: int = 16, max_rings: int = 120) -> np.ndarray:
    """Points (k, count, 3) [m] of a vessel's wall: rings of radius ``radii`` (P,) [m] about the
    centreline ``points`` (P, 3) [m] in the planes normal to it, at most ``max_rings`` of them
    (evenly picked, both ends kept), framed by parallel transport so the rings do not twist."""
    points, radii = np.asarray(points, dtype=float), np.asarray(radii, dtype=float)
    keep = np.unique(np.round(np.linspace(0, len(points) - 1, min(len(points), max_rings))).astype(int))
    c, r = points[keep], radii[keep]
    tangent = np.gradient(c, axis=0)
    tangent /= np.linalg.norm(tangent, axis=1, keepdims=True)
    _, u, _ = _frame(tangent[0])
    phi = np.linspace(0.0, 2 * np.pi, count)
    rings = []
    for k in range(len(c)):
        u = u - (u @ tangent[k]) * tangent[k]
        u /= np.linalg.norm(u)
        v = np.cross(tangent[k], u)
        rings.append(c[k] + r[k] * (np.cos(phi)[:, None] * u + np.sin(phi)[:, None] * v))
    return np.array(rings)


def tube_walls_2d(points, radii, plane: str, max_points: int = 400) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """A vessel in the flat view ``plane`` ('xy', 'xz', 'yz'): its centreline (k, 2) and the two
    wall lines (k, 2) at ``radii`` [m] on either side, normal to the projected centreline."""
    a, b = _PLANES[plane]
    points, radii = np.asarray(points, dtype=float), np.asarray(radii, dtype=float)
    keep = np.unique(np.round(np.linspace(0, len(points) - 1, min(len(points), max_points))).astype(int))
    c, r = points[keep][:, [a, b]], radii[keep]
    t = np.gradient(c, axis=0)
    length = np.linalg.norm(t, axis=1, keepdims=True)
    t = np.where(length > 1e-12 * max(float(np.ptp(c)), 1e-12), t / np.maximum(length, 1e-300), 0.0)
    n = np.stack([-t[:, 1], t[:, 0]], axis=1)
    return c, c + r[:, None] * n, c - r[:, None] * n


def widen_to_aspect(x0: float, x1: float, y0: float, y1: float, aspect: float) -> tuple[float, float, float, float]:
    """The box [x0, x1] x [y0, y1] widened, about its centre, along its narrower side so that its
    width over its height is ``aspect`` (one metre as long on both axes of a frame of that shape):
    (x0, x1, y0, y1)."""
    if (x1 - x0) / (y1 - y0) < aspect:
        grow = ((y1 - y0) * aspect - (x1 - x0)) / 2
        x0, x1 = x0 - grow, x1 + grow
    else:
        grow = ((x1 - x0) / aspect - (y1 - y0)) / 2
        y0, y1 = y0 - grow, y1 + grow
    return x0, x1, y0, y1
