"""A closed surface around a tree of tubes: the smooth union of round-ended tubes about centreline
polylines, meshed by marching tetrahedra (each grid cube cut into the six Kuhn tetrahedra, so that
neighbouring cubes share their face diagonals and the surface is a closed 2-manifold), the vertices
then projected onto the implicit surface (``geometry.mesh.arch_tree``)."""

import numpy as np

BLEND = 0.002
"""Width [m] of the smooth union where tubes meet (the fillet at a branch's root)."""

SLIVER = 1e-4
"""A face the projection leaves with twice its area below this fraction of the grid spacing squared
keeps its unprojected corners."""

_CUBE = np.array([[0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0], [0, 0, 1], [1, 0, 1], [1, 1, 1], [0, 1, 1]])
_TETS = np.array([[0, 5, 1, 6], [0, 1, 2, 6], [0, 2, 3, 6], [0, 3, 7, 6], [0, 7, 4, 6], [0, 4, 5, 6]])


def _polyline_distance(p: np.ndarray, line: np.ndarray) -> np.ndarray:
    """Distances (n,) [m] of points (n, 3) to a polyline (m, 3)."""
    best = np.full(len(p), np.inf)
    for a, b in zip(line[:-1], line[1:]):
        e = b - a
        t = np.clip((p - a) @ e / (e @ e), 0.0, 1.0)
        best = np.minimum(best, np.linalg.norm(p - a - t[:, None] * e, axis=1))
    return best


def implicit(p: np.ndarray, tubes) -> np.ndarray:
    """The union's implicit function (n,) [m] at points (n, 3): negative inside, about the distance
    to the surface (a polynomial smooth minimum of the tubes' distances, width ``BLEND``)."""
    f = None
    for line, radius in tubes:
        g = _polyline_distance(p, np.asarray(line, dtype=float)) - radius
        if f is None:
            f = g
            continue
        h = np.clip(0.5 + 0.5 * (g - f) / BLEND, 0.0, 1.0)
        f = g * (1 - h) + f * h - BLEND * h * (1 - h)
    return f


def _field(tubes, spacing: float):
    """Grid origin (3,), shape (3,) and the implicit function at its points (flat, x fastest)."""
    points = np.concatenate([np.asarray(line, dtype=float) for line, _ in tubes])
    reach = max(r for _, r in tubes) + 3 * spacing + BLEND
    origin = points.min(axis=0) - reach
    shape = np.ceil((points.max(axis=0) + reach - origin) / spacing).astype(np.int64) + 1
    axes = [origin[i] + spacing * np.arange(shape[i]) for i in range(3)]
    zz, yy, xx = np.meshgrid(axes[2], axes[1], axes[0], indexing="ij")
    grid = np.stack([xx.reshape(-1), yy.reshape(-1), zz.reshape(-1)], axis=1)
    values = np.concatenate([implicit(grid[i:i + 200_000], tubes) for i in range(0, len(grid), 200_000)])
    values[values == 0.0] = 1e-12                  # no grid point on the surface: no degenerate triangle
    return origin, shape, grid, values


def _tetrahedra(shape: np.ndarray, values: np.ndarray) -> np.ndarray:
    """The grid points (T, 4) int64 of the tetrahedra of the cubes the surface crosses."""
    nx, ny, nz = (int(s) for s in shape)
    i, j, k = np.meshgrid(np.arange(nx - 1), np.arange(ny - 1), np.arange(nz - 1), indexing="ij")
    base = (i + nx * (j + ny * k)).reshape(-1)
    corners = base[:, None] + (_CUBE[:, 0] + nx * (_CUBE[:, 1] + ny * _CUBE[:, 2]))[None, :]
    inside = values[corners] < 0
    crossed = inside.any(axis=1) & ~inside.all(axis=1)
    return corners[crossed][:, _TETS].reshape(-1, 4)


def _triangles(tets: np.ndarray, values: np.ndarray):
    """Triangles (m, 3, 2): per corner the grid-point pair (inside, outside) of the edge it lies on."""
    inside = values[tets] < 0
    count = inside.sum(axis=1)
    order = np.argsort(~inside, axis=1, kind="stable")       # inside corners first
    t = np.take_along_axis(tets, order, axis=1)
    tris = []
    one = t[count == 1]
    tris.append(np.stack([np.stack([one[:, 0], one[:, m]], axis=1) for m in (1, 2, 3)], axis=1))
    three = t[count == 3]
    tris.append(np.stack([np.stack([three[:, m], three[:, 3]], axis=1) for m in (0, 1, 2)], axis=1))
    two = t[count == 2]
    quad = [np.stack([two[:, a], two[:, b]], axis=1) for a, b in ((0, 2), (0, 3), (1, 3), (1, 2))]
    tris.append(np.stack([quad[0], quad[1], quad[2]], axis=1))
    tris.append(np.stack([quad[0], quad[2], quad[3]], axis=1))
    return np.concatenate(tris)


def _project(p: np.ndarray, tubes, spacing: float, steps: int = 4) -> np.ndarray:
    """Points (n, 3) moved onto the implicit surface by Newton steps along its gradient."""
    eps = 1e-3 * spacing
    for _ in range(steps):
        f = implicit(p, tubes)
        grad = np.stack([(implicit(p + eps * e, tubes) - implicit(p - eps * e, tubes)) / (2 * eps)
                         for e in np.eye(3)], axis=1)
        step = f / np.maximum(np.sum(grad * grad, axis=1), 1e-12)
        p = p - np.clip(step, -0.5 * spacing, 0.5 * spacing)[:, None] * grad
    return p


def tube_tree_surface(tubes, spacing: float) -> tuple[np.ndarray, np.ndarray]:
    """Vertices (V, 3) [m] and outward faces (F, 3) int64 of the union of round-ended tubes
    (``tubes``: (centreline (m_i, 3) [m], radius [m]) pairs) on a grid of ``spacing`` [m]."""
    origin, shape, grid, values = _field(tubes, spacing)
    tris = _triangles(_tetrahedra(shape, values), values)
    pairs = np.sort(tris.reshape(-1, 2), axis=1)
    key = pairs[:, 0] * len(grid) + pairs[:, 1]
    _, first, inverse = np.unique(key, return_index=True, return_inverse=True)
    a, b = pairs[first, 0], pairs[first, 1]
    t = np.clip(values[a] / (values[a] - values[b]), 0.05, 0.95)
    vertices = grid[a] + t[:, None] * (grid[b] - grid[a])
    faces = inverse.reshape(-1, 3).astype(np.int64)
    # orient outward (before the projection): the inside end of a corner's grid edge lies strictly on
    # the inside of the face's plane (the plane cuts that edge between its ends)
    x = vertices[faces]
    normal = np.cross(x[:, 1] - x[:, 0], x[:, 2] - x[:, 0])
    flip = np.einsum("ij,ij->i", normal, grid[tris[:, 0, 0]] - x[:, 0]) > 0
    faces[flip] = faces[flip][:, ::-1]
    projected = _project(vertices, tubes, spacing)
    for _ in range(3):            # a face the projection flattened keeps its corners on the grid edges
        x = projected[faces]
        area2 = np.linalg.norm(np.cross(x[:, 1] - x[:, 0], x[:, 2] - x[:, 0]), axis=1)
        flat = faces[~(area2 > SLIVER * spacing**2)].reshape(-1)
        if not flat.size:
            break
        projected[flat] = vertices[flat]
    return projected, faces
