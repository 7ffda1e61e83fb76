"""The arrays of a surface mesh that the contact kernels walk (``geometry.mesh.MeshVessel``), its
checks, and the exact NumPy reference of the closest point on it (docs/guide/navigation.md, "Vessels
from meshes").

A mesh is ``vertices`` (V, 3) [m] and ``faces`` (F, 3) int64, counter-clockwise seen from outside
(outward normals). Face f's edge k runs from vertex ``faces[f, k]`` to ``faces[f, (k + 1) % 3]``;
``neighbours[f, k]`` is the face across it. The closest-point features are coded 0 (the face's
inside), 1 + k (its vertex k) and 4 + k (its edge k), in the kernels too (``rod.contact_kernels``).
"""

import numpy as np
from scipy.spatial import cKDTree

from ..errors import bad

MAX_CELLS = 2_000_000
"""Most cells of a mesh's seed grid (its cell grows to keep to this)."""

SEED_CELL = 2.0
"""The seed grid's default cell, in mean edge lengths."""

SEED_REACH = 6.0
"""Cells farther than this many cells from every vertex have no seed (deep in a wide lumen)."""

FLAT = 1e-10
"""A face whose area is below this fraction of its longest edge squared is degenerate."""


def _dot(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    return np.einsum("ij,ij->i", a, b)


def merged(vertices: np.ndarray, faces: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Vertices (V', 3) with exact duplicates merged (STL stores each triangle's corners apart) and
    the faces (F, 3) renumbered; vertices no face uses are dropped."""
    used, faces = np.unique(faces, return_inverse=True)
    points, inverse = np.unique(vertices[used], axis=0, return_inverse=True)
    return points, inverse.reshape(-1)[faces.reshape(-1)].reshape(-1, 3).astype(np.int64)


def check_surface(vertices: np.ndarray, faces: np.ndarray, where: str, name: str) -> np.ndarray:
    """Check a closed, consistently and outwardly oriented 2-manifold with no degenerate face, and
    return its face neighbours (F, 3) int64; else a one-line error naming ``where`` = ``name``."""
    n_v = len(vertices)
    a, b, c = (vertices[faces[:, k]] for k in range(3))
    area2 = np.linalg.norm(np.cross(b - a, c - a), axis=1)
    longest = np.max(np.stack([_dot(b - a, b - a), _dot(c - b, c - b), _dot(a - c, a - c)]), axis=0)
    flat = np.flatnonzero((faces[:, 0] == faces[:, 1]) | (faces[:, 1] == faces[:, 2]) | (faces[:, 2] == faces[:, 0])
                          | ~(area2 > FLAT * longest))
    if flat.size:
        raise bad(where, name, f"a mesh without degenerate faces ({flat.size} of zero area, e.g. face {flat[0]}); "
                               "remove them (merge close vertices / decimate in your mesher)")
    start, end = faces.reshape(-1), faces[:, [1, 2, 0]].reshape(-1)
    undirected = np.minimum(start, end) * n_v + np.maximum(start, end)
    _, counts = np.unique(undirected, return_counts=True)
    if np.any(counts != 2):
        open_edges, extra = int(np.sum(counts == 1)), int(np.sum(counts > 2))
        raise bad(where, name, f"a closed surface, every edge shared by exactly two faces ({open_edges} edges on one "
                               f"face only, {extra} on three or more); cap the vessel's open ends and remove "
                               "the extra faces in your mesher")
    directed = start * n_v + end
    order = np.argsort(directed, kind="stable")
    keys = directed[order]
    if np.any(keys[1:] == keys[:-1]):
        raise bad(where, name, "faces oriented consistently (two faces run an edge the same way); make the "
                               "normals consistent in your mesher")
    twin = order[np.searchsorted(keys, end * n_v + start)]
    volume = float(np.sum(_dot(a, np.cross(b, c)))) / 6.0
    if not volume > 0:
        raise bad(where, name, f"outward-facing normals (the enclosed volume is {volume:.3g} m^3, not positive: the "
                               "faces are inverted); flip the faces' orientation (reverse each face's vertices)")
    return (twin // 3).reshape(-1, 3).astype(np.int64)


def normals(vertices: np.ndarray, faces: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Unit face normals (F, 3) and the vertices' angle-weighted pseudonormals (V, 3) (unit): with
    the edges' (the sum of their two faces' normals) they give the sign of the distance exactly."""
    a, b, c = (vertices[faces[:, k]] for k in range(3))
    n = np.cross(b - a, c - a)
    n /= np.linalg.norm(n, axis=1)[:, None]
    vn = np.zeros_like(vertices)
    corners = (a, b, c)
    for k in range(3):
        u, w = corners[(k + 1) % 3] - corners[k], corners[(k + 2) % 3] - corners[k]
        cos = _dot(u, w) / (np.linalg.norm(u, axis=1) * np.linalg.norm(w, axis=1))
        np.add.at(vn, faces[:, k], np.arccos(np.clip(cos, -1.0, 1.0))[:, None] * n)
    vn /= np.linalg.norm(vn, axis=1)[:, None]
    return n, vn


def vertex_rings(faces: np.ndarray, n_vertices: int) -> tuple[np.ndarray, np.ndarray]:
    """The faces around each vertex: offsets (V + 1,) int64 into ring (3F,) int64."""
    flat = faces.reshape(-1)
    ring = (np.argsort(flat, kind="stable") // 3).astype(np.int64)
    offsets = np.concatenate([[0], np.cumsum(np.bincount(flat, minlength=n_vertices))]).astype(np.int64)
    return offsets, ring


def closest_on_triangles(p: np.ndarray, a: np.ndarray, b: np.ndarray, c: np.ndarray):
    """Closest points q (m, 3) [m] of triangles (a, b, c) (m, 3 each) to points p (m, 3) and their
    features (m,) int64 (0 inside, 1 + k vertex k, 4 + k edge k; Ericson, Real-Time Collision
    Detection, 5.1.5)."""
    ab, ac = b - a, c - a
    d1, d2 = _dot(ab, p - a), _dot(ac, p - a)
    d3, d4 = _dot(ab, p - b), _dot(ac, p - b)
    d5, d6 = _dot(ab, p - c), _dot(ac, p - c)
    va, vb, vc = d3 * d6 - d5 * d4, d5 * d2 - d1 * d6, d1 * d4 - d3 * d2
    regions = [(d1 <= 0) & (d2 <= 0), (d3 >= 0) & (d4 <= d3), (d6 >= 0) & (d5 <= d6),
               (vc <= 0) & (d1 >= 0) & (d3 <= 0), (va <= 0) & (d4 - d3 >= 0) & (d5 - d6 >= 0),
               (vb <= 0) & (d2 >= 0) & (d6 <= 0)]
    with np.errstate(invalid="ignore", divide="ignore"):
        v_ab = d1 / (d1 - d3)
        w_bc = (d4 - d3) / ((d4 - d3) + (d5 - d6))
        w_ca = d2 / (d2 - d6)
        total = va + vb + vc
        v_in, w_in = vb / total, vc / total
    # barycentric weights (of b, of c) per region, in the order of ``regions``, then the inside
    v = np.select(regions, [0.0, 1.0, 0.0, v_ab, 1.0 - w_bc, 0.0], v_in)
    w = np.select(regions, [0.0, 0.0, 1.0, 0.0, w_bc, w_ca], w_in)
    feature = np.select(regions, [1, 2, 3, 4, 5, 6], 0).astype(np.int64)
    return a + v[:, None] * ab + w[:, None] * ac, feature


class Closest:
    """Exact closest points of a mesh (the reference of the kernels' walk): a k-d tree over the face
    centroids, each face's reach (its farthest vertex from its centroid) bounding the candidates.

    Parameters
    ----------
    vertices : (V, 3)
        the mesh's vertices [m]
    faces : (F, 3) int64
        its faces
    """

    def __init__(self, vertices: np.ndarray, faces: np.ndarray):
        self.vertices, self.faces = vertices, faces
        corners = vertices[faces]
        self.centroids = corners.mean(axis=1)
        self.reach = float(np.max(np.linalg.norm(corners - self.centroids[:, None], axis=2)))
        self.tree = cKDTree(self.centroids)

    def _pairs(self, points: np.ndarray, faces: np.ndarray):
        x = self.vertices[self.faces[faces]]
        q, feature = closest_on_triangles(points, x[:, 0], x[:, 1], x[:, 2])
        return q, feature, np.sum((points - q) ** 2, axis=1)

    def query(self, points: np.ndarray, chunk: int = 20_000):
        """The closest face (n,) int64, point q (n, 3) [m], feature (n,) int64 and distance (n,) [m]
        of each point (n, 3) [m]."""
        parts = [self._query(points[i:i + chunk]) for i in range(0, len(points), chunk)]
        return tuple(np.concatenate([p[j] for p in parts]) for j in range(4)) if parts else (
            np.zeros(0, np.int64), np.zeros((0, 3)), np.zeros(0, np.int64), np.zeros(0))

    def _query(self, points: np.ndarray):
        n, k = len(points), min(4, len(self.faces))
        _, near = self.tree.query(points, k)
        near = near.reshape(n, k)
        _, _, d2 = self._pairs(np.repeat(points, k, axis=0), near.reshape(-1))
        upper = np.sqrt(np.min(d2.reshape(n, k), axis=1))
        lists = self.tree.query_ball_point(points, upper + self.reach + 1e-12)
        counts = np.array([len(items) for items in lists])
        rows = np.repeat(np.arange(n), counts)
        faces = np.concatenate([np.asarray(items, dtype=np.int64) for items in lists])
        q, feature, d2 = self._pairs(points[rows], faces)
        order = np.lexsort((faces, d2, rows))          # per row, the nearest (the lowest face of ties)
        first = order[np.searchsorted(rows[order], np.arange(n))]
        return faces[first], q[first], feature[first], np.sqrt(d2[first])


def pseudonormal(face: np.ndarray, feature: np.ndarray, faces: np.ndarray, neighbours: np.ndarray,
                 face_normals: np.ndarray, vertex_normals: np.ndarray) -> np.ndarray:
    """The outward pseudonormals (n, 3) (not unit) at closest features (face (n,), feature (n,))."""
    k = np.clip(feature - 4, 0, 2)
    edge = face_normals[face] + face_normals[neighbours[face, k]]
    vertex = vertex_normals[faces[face, np.clip(feature - 1, 0, 2)]]
    return np.where((feature == 0)[:, None], face_normals[face], np.where((feature >= 4)[:, None], edge, vertex))


def seed_grid(vertices: np.ndarray, faces: np.ndarray, rings: tuple[np.ndarray, np.ndarray], cell: float | None):
    """The kernels' seed grid: origin (3,) [m], cell size [m], shape (3,) int64 and per cell (C,) int64
    (x fastest) a face at a vertex near the cell's centre (within twice the distance of the nearest:
    a start, the walks find the closest face), -1 where no vertex lies within ``SEED_REACH`` cells.
    ``cell`` None: ``SEED_CELL`` mean edge lengths, grown to keep within ``MAX_CELLS``."""
    low, high = vertices.min(axis=0), vertices.max(axis=0)
    if cell is None:
        edges = np.linalg.norm(vertices[faces] - vertices[np.roll(faces, 1, axis=1)], axis=2)
        cell = max(SEED_CELL * float(np.mean(edges)), float(np.prod(high - low + 1e-9) / MAX_CELLS) ** (1 / 3))
    shape = np.ceil((high - low) / cell).astype(np.int64) + 3
    while np.prod(shape) > MAX_CELLS:
        cell *= 1.25
        shape = np.ceil((high - low) / cell).astype(np.int64) + 3
    origin = low - cell
    axes = [origin[i] + (np.arange(shape[i]) + 0.5) * cell for i in range(3)]
    zz, yy, xx = np.meshgrid(axes[2], axes[1], axes[0], indexing="ij")
    centres = np.stack([xx.reshape(-1), yy.reshape(-1), zz.reshape(-1)], axis=1)
    _, nearest = cKDTree(vertices).query(centres, eps=1.0, distance_upper_bound=SEED_REACH * cell)
    offsets, ring = rings
    found = nearest < len(vertices)
    return origin, float(cell), shape, np.where(found, ring[offsets[np.where(found, nearest, 0)]], -1)
