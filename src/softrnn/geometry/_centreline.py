"""The centreline tree of a mesh vessel's lumen (``MeshVessel.centreline``): the lumen voxelised
(a voxel is inside where a ray along z crosses the surface an odd number of times below it), the
geodesic distance from the inlet through the inside voxels (Dijkstra), and the level-set skeleton:
the voxels binned by that distance, each bin's connected pieces one node at their centroid, each
piece linked to the piece of the bin before it that it touches. A branch is the path of nodes from
the inlet to an end (a piece with no successor); spurs shorter than ``MIN_BINS`` bins are dropped."""

from dataclasses import dataclass

import numpy as np
from scipy.ndimage import distance_transform_edt
from scipy.sparse import coo_matrix
from scipy.sparse.csgraph import connected_components, dijkstra

from ..errors import bad
from .obstacles import closest_segments

BIN = 2.0
"""The level sets' width, in voxels."""

MIN_BINS = 4
"""A branch's spur beyond its last fork shorter than this many bins is dropped (a bump, not a branch)."""

MAX_VOXELS = 4_000_000
"""Most voxels of the lumen's grid (the voxel grows to keep to this)."""


@dataclass(frozen=True, eq=False)
class Centreline:
    """A lumen's centreline tree.

    Attributes
    ----------
    branches : tuple of (m_b, 3)
        one polyline [m] per end of the tree, from the inlet to that end (branches share their
        path up to where they fork)
    voxel : float
        the voxel it was found on [m] (its points lie within about a voxel of the lumen's axis)
    """

    branches: tuple
    voxel: float

    def lengths(self) -> np.ndarray:
        """Each branch's length (b,) [m]."""
        return np.array([np.sum(np.linalg.norm(np.diff(b, axis=0), axis=1)) for b in self.branches])

    def nearest_branch(self, point) -> int:
        """The branch whose end lies nearest to ``point`` (3,) [m]."""
        ends = np.array([b[-1] for b in self.branches])
        return int(np.argmin(np.linalg.norm(ends - np.asarray(point, dtype=float), axis=1)))

    def progress(self, points, branch: int) -> np.ndarray:
        """Arc length (n,) [m] from the inlet along branch ``branch`` of each point (n, 3) [m]
        projected on it (its closest point on the polyline)."""
        if not isinstance(branch, (int, np.integer)) or not 0 <= branch < len(self.branches):
            raise bad("branch", branch, f"a branch index in 0..{len(self.branches) - 1}")
        line = self.branches[branch]
        x = np.atleast_2d(np.asarray(points, dtype=float))
        index, _, t = closest_segments(line, x)
        steps = np.linalg.norm(np.diff(line, axis=0), axis=1)
        start = np.concatenate([[0.0], np.cumsum(steps)])
        return start[index] + np.clip(t, 0.0, 1.0) * steps[index]


def inside_voxels(vertices: np.ndarray, faces: np.ndarray, voxel: float):
    """The lumen's voxels: origin (3,) [m] of the grid, its shape (3,) and the inside mask
    (nz, ny, nx) bool, by ray parity along z at each voxel centre's (x, y)."""
    low, high = vertices.min(axis=0), vertices.max(axis=0)
    origin = low - voxel
    shape = np.ceil((high - low) / voxel).astype(np.int64) + 2
    jitter = voxel * np.array([1.234567e-4, 2.345678e-4])        # no ray through an edge or vertex
    x = vertices[faces]
    lo = np.ceil((x[:, :, :2].min(axis=1) - origin[:2] - jitter) / voxel - 0.5).astype(np.int64)
    hi = np.floor((x[:, :, :2].max(axis=1) - origin[:2] - jitter) / voxel - 0.5).astype(np.int64)
    span = np.maximum(hi - lo + 1, 0)
    count = span[:, 0] * span[:, 1]
    tri = np.repeat(np.arange(len(faces)), count)
    local = np.arange(count.sum()) - np.repeat(np.cumsum(count) - count, count)
    ix = lo[tri, 0] + local % np.maximum(span[tri, 0], 1)
    iy = lo[tri, 1] + local // np.maximum(span[tri, 0], 1)
    px = origin[0] + (ix + 0.5) * voxel + jitter[0]
    py = origin[1] + (iy + 0.5) * voxel + jitter[1]
    a, b, c = x[tri, 0], x[tri, 1], x[tri, 2]
    det = (b[:, 0] - a[:, 0]) * (c[:, 1] - a[:, 1]) - (c[:, 0] - a[:, 0]) * (b[:, 1] - a[:, 1])
    ok = det != 0
    safe = np.where(ok, det, 1.0)
    u = ((px - a[:, 0]) * (c[:, 1] - a[:, 1]) - (c[:, 0] - a[:, 0]) * (py - a[:, 1])) / safe
    v = ((b[:, 0] - a[:, 0]) * (py - a[:, 1]) - (px - a[:, 0]) * (b[:, 1] - a[:, 1])) / safe
    hit = ok & (u >= 0) & (v >= 0) & (u + v <= 1)
    z = (a[:, 2] + u * (b[:, 2] - a[:, 2]) + v * (c[:, 2] - a[:, 2]))[hit]
    k = np.clip(np.ceil((z - origin[2]) / voxel - 0.5).astype(np.int64), 0, shape[2])
    delta = np.zeros((shape[2] + 1, shape[1], shape[0]), dtype=np.int64)
    np.add.at(delta, (k, iy[hit], ix[hit]), 1)
    return origin, shape, (np.cumsum(delta, axis=0)[:-1] & 1).astype(bool)


def _graph(mask: np.ndarray, voxel: float):
    """The inside voxels' flat indices (N,) and their 26-neighbour graph (N, N), edges in m."""
    flat = np.flatnonzero(mask.reshape(-1))
    ids = np.full(mask.size, -1, dtype=np.int64)
    ids[flat] = np.arange(len(flat))
    nz, ny, nx = mask.shape
    rows, cols, lengths = [], [], []
    for dz in (0, 1):
        for dy in (-1, 0, 1):
            for dx in (-1, 0, 1):
                if (dz, dy, dx) <= (0, 0, 0):
                    continue
                z, rest = np.divmod(flat, ny * nx)
                y, x = np.divmod(rest, nx)
                ok = (z + dz < nz) & (y + dy >= 0) & (y + dy < ny) & (x + dx >= 0) & (x + dx < nx)
                other = np.where(ok, flat + dz * ny * nx + dy * nx + dx, 0)
                ok &= ids[other] >= 0
                rows.append(np.flatnonzero(ok))
                cols.append(ids[other[ok]])
                lengths.append(np.full(int(ok.sum()), voxel * np.sqrt(dx * dx + dy * dy + dz * dz)))
    r, c, w = (np.concatenate(p) for p in (rows, cols, lengths))
    return flat, coo_matrix((w, (r, c)), shape=(len(flat), len(flat))).tocsr(), (r, c)


def centreline_of(vessel, inlet=None, voxel: float | None = None) -> Centreline:
    """The centreline tree of a ``MeshVessel``'s lumen from ``inlet`` (3,) [m] (None: the deepest
    voxel within twice the lumen's largest depth of an end of its longest path); ``voxel`` [m]
    (None: the mean edge length, grown to ``MAX_VOXELS``)."""
    v, f = vessel.vertices, vessel.faces
    if voxel is None:
        voxel = float(np.mean(np.linalg.norm(v[f] - v[np.roll(f, 1, axis=1)], axis=2)))
        voxel = max(voxel, float(np.prod(v.max(axis=0) - v.min(axis=0)) / MAX_VOXELS) ** (1 / 3))
    origin, shape, mask = inside_voxels(v, f, voxel)
    flat, graph, (r, c) = _graph(mask, voxel)
    if len(flat) < 2:
        raise bad("mesh.centreline", f"{len(flat)} inside voxels", "a lumen several voxels wide (a finer voxel)")
    z, rest = np.divmod(flat, shape[1] * shape[0])
    y, x = np.divmod(rest, shape[0])
    centres = origin + (np.stack([x, y, z], axis=1) + 0.5) * voxel
    if inlet is None:        # the deepest voxel near an end of the lumen's longest path (on its axis)
        far = dijkstra(graph, directed=False, indices=0)
        end = int(np.argmax(np.where(np.isfinite(far), far, -1)))
        depth = distance_transform_edt(mask).reshape(-1)[flat] * voxel
        near = dijkstra(graph, directed=False, indices=end, limit=2.0 * float(depth.max()))
        start = int(np.argmax(np.where(np.isfinite(near), depth, -1.0)))
    else:
        start = int(np.argmin(np.linalg.norm(centres - np.asarray(inlet, dtype=float), axis=1)))
    dist = dijkstra(graph, directed=False, indices=start)
    reached = np.isfinite(dist)
    level = np.where(reached, np.floor(dist / (BIN * voxel)), -1).astype(np.int64)
    same = (level[r] == level[c]) & (level[r] >= 0)
    n = len(flat)
    _, piece = connected_components(coo_matrix((np.ones(int(same.sum())), (r[same], c[same])), shape=(n, n)),
                                    directed=False)
    pieces = int(piece.max()) + 1
    sizes = np.bincount(piece, minlength=pieces)
    centroid = np.stack([np.bincount(piece, weights=centres[:, i], minlength=pieces) for i in range(3)], axis=1)
    centroid /= np.maximum(sizes, 1)[:, None]
    parent = np.full(pieces, -1, dtype=np.int64)
    up = (level[c] == level[r] + 1) & (level[r] >= 0)
    parent[piece[c[up]]] = piece[r[up]]
    down = (level[r] == level[c] + 1) & (level[c] >= 0)
    parent[piece[r[down]]] = piece[c[down]]
    return Centreline(branches=_branches(parent, centroid, piece[start]), voxel=voxel)


def _branches(parent: np.ndarray, centroid: np.ndarray, root: int) -> tuple:
    """The paths (m_b, 3) [m] from the root piece to each end of the piece tree (``parent``: each
    piece's predecessor, -1 for the root and unreached pieces), spurs under ``MIN_BINS`` pruned
    until none is left (a split cap's two short ends go, their trunk stays)."""
    parent = parent.copy()
    while True:
        alive = (parent >= 0) | (np.arange(len(parent)) == root)
        children = np.bincount(parent[alive & (parent >= 0)], minlength=len(parent))
        ends = [int(p) for p in np.flatnonzero(alive & (children == 0))]
        paths, pruned = [], False
        for end in ends:
            path = [end]
            while path[-1] != root and children[path[-1]] <= 1:
                path.append(int(parent[path[-1]]))
            if len(path) - 1 < MIN_BINS and path[-1] != root and len(ends) > 1:
                parent[path[:-1]] = -2                   # a short spur: drop it
                pruned = True
        if not pruned:
            break
    for end in ends:
        path = [end]
        while path[-1] != root:
            path.append(int(parent[path[-1]]))
        paths.append(centroid[path[::-1]])
    return tuple(paths)
