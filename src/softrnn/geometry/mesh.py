"""Vessels from surface meshes: ``MeshVessel``, a closed triangle surface (STL, OBJ, VTK/VTP, PLY,
read with meshio) with the rod inside its lumen, and ``arch_tree``, a procedurally made aortic arch
with three branches (docs/guide/navigation.md, "Vessels from meshes").

The mesh must be a closed 2-manifold (every edge shared by exactly two faces), with no degenerate
face and outward normals (a positive enclosed volume); its ``units`` ("m" or "mm") must give it a
plausible size. The gap of a node is its exact distance to the surface, signed by the angle-weighted
pseudonormals (positive inside the lumen), minus the rod radius; the normal points into the lumen.
The kernels (``rod.contact_kernels``) find the closest face by a walk over the face adjacency from
the node's tracked face and from a seed grid's face, both O(1) per node and step; ``gap`` here is
the exact reference (a k-d tree over the faces).
"""

import os
from dataclasses import InitVar, dataclass
from pathlib import Path
from typing import ClassVar

import numpy as np

from ..errors import bad, positive
from ..files import file_sha256
from ..progress import Progress
from . import _mesh_build as build
from ._centreline import Centreline, centreline_of
from ._marching import tube_tree_surface
from .obstacles import Obstacle, _friction, _short

UNITS = {"m": 1.0, "mm": 1e-3}
"""The mesh units and their size in m."""

PLAUSIBLE_SIZE = (1e-3, 3.0)
"""The extent [m] (bounding-box diagonal) of a plausible vessel mesh."""

MAX_FACES = 5_000_000
"""Most faces of a mesh."""

BYTES_PER_FACE = 800
"""Bytes a mesh holds per face once built (arrays, k-d tree, the kernels' copy), for the memory check."""

EXTENSIONS = (".stl", ".obj", ".vtk", ".vtp", ".vtu", ".ply", ".off")
"""The mesh files read (by meshio)."""


def _memory_limit() -> int:
    """Bytes a mesh may hold: half the machine's memory (8 GiB where it cannot be read)."""
    try:
        return os.sysconf("SC_PAGE_SIZE") * os.sysconf("SC_PHYS_PAGES") // 2
    except (AttributeError, OSError, ValueError):
        return 8 * 2**30


def read_surface(path, where: str = "mesh.file") -> tuple[np.ndarray, np.ndarray]:
    """The points (V, 3) (in the file's units) and triangles (F, 3) int64 of a surface mesh file
    (quads and polygons split into triangles); a one-line error naming ``where`` otherwise."""
    import meshio  # heavy: read a mesh file only where a scenario has one

    name = str(path)
    if Path(name).suffix.lower() not in EXTENSIONS:
        raise bad(where, name, f"a surface mesh file ({', '.join(EXTENSIONS)})")
    try:
        with np.errstate(all="ignore"):      # meshio's format sniffing overflows on purpose (STL's size check)
            data = meshio.read(name)
    except (OSError, ValueError, KeyError, IndexError, meshio.ReadError) as exc:
        raise bad(where, name, f"a readable surface mesh ({type(exc).__name__}: {str(exc)[:80]})") from None
    triangles = []
    for block in data.cells:
        cells = np.asarray(block.data, dtype=np.int64)
        if block.type in ("triangle", "quad", "polygon") and cells.ndim == 2 and cells.shape[1] >= 3:
            triangles += [cells[:, [0, k, k + 1]] for k in range(1, cells.shape[1] - 1)]
        elif block.type not in ("vertex", "line"):
            raise bad(where, name, f"a surface mesh of triangles (it holds {block.type} cells)")
    if not triangles:
        raise bad(where, name, "a surface mesh with triangles (none found)")
    return np.asarray(data.points, dtype=float)[:, :3], np.concatenate(triangles)


def write_surface(path, vertices: np.ndarray, faces: np.ndarray) -> None:
    """Write a surface mesh, vertices (V, 3) [m] (stored as float32) and faces (F, 3), with meshio
    (the format by the file's extension, e.g. ``.vtu``: compressed VTK XML)."""
    import meshio  # heavy: write a mesh file only where asked

    meshio.write(str(path), meshio.Mesh(np.asarray(vertices, dtype=np.float32),
                                        [("triangle", np.asarray(faces, dtype=np.int32))]))


ARCH_FILE = "mesh-arch.vtu"
"""The shipped mesh of ``arch_tree()`` (its defaults) in ``softrnn/scenarios``, in m."""
ARCH_LONG_FILE = "mesh-arch-long.vtu"
"""The shipped mesh of ``arch_tree(descending=ARCH_LONG_DESCENDING)`` in ``softrnn/scenarios``, in m
(``write_surface``): a descending aorta long enough for a 1 m guidewire."""
ARCH_LONG_DESCENDING = 1.05
"""The length [m] of ``ARCH_LONG_FILE``'s descending aorta."""


@dataclass(frozen=True, eq=False)
class MeshVessel(Obstacle):
    """A vessel lumen bounded by a closed triangle mesh, the rod inside it.

    Attributes
    ----------
    vertices : (V, 3)
        the mesh's vertices in ``units`` (stored in m after the build, duplicates merged)
    faces : (F, 3) int
        its triangles, counter-clockwise seen from outside
    units : str
        "m" or "mm": the vertices' unit; the mesh must then measure 1 mm to 3 m across
    friction : float or None
        friction coefficient mu [-]; None: the ``Contact``'s
    cell : float or None
        the kernels' seed-grid cell [m]; None: ``build.SEED_CELL`` mean edge lengths (grown to
        ``build.MAX_CELLS``)
    inlet : (3,) or None
        a point in the lumen [m] where the centreline starts (the access); None: on the axis near an
        end of the lumen's longest path
    file : str or None
        the file it was read from (recorded with its ``sha256``; ``load_mesh``), or None
    sha256 : str or None
        the file's hash (None without a file)
    neighbours : (F, 3) int64
        the face across each edge k (from vertex k to k + 1) (computed, as the rest below)
    face_normals, vertex_normals : (F, 3), (V, 3)
        unit outward normals and angle-weighted pseudonormals
    ring_offsets, ring : (V + 1,), (3F,) int64
        the faces around each vertex
    grid_origin, grid_cell, grid_shape, grid_faces : (3,) [m], float [m], (3,) int64, (C,) int64
        the seed grid: per cell a face near its centre (-1: none within ``build.SEED_REACH`` cells)
    """

    kind: ClassVar[str] = "mesh"

    vertices: np.ndarray
    faces: np.ndarray
    units: str = "m"
    friction: float | None = None
    cell: float | None = None
    inlet: tuple | None = None
    file: str | None = None
    sha256: str | None = None
    progress: InitVar[Progress | None] = None

    def __post_init__(self, progress):
        name = self.file or "the mesh"
        where = "mesh.file" if self.file else "mesh.vertices"
        if self.units not in UNITS:
            raise bad("mesh.units", self.units, "the mesh's unit, \"m\" or \"mm\"")
        object.__setattr__(self, "friction", _friction(self.friction))
        if self.cell is not None:
            object.__setattr__(self, "cell", positive("mesh.cell", self.cell, "m"))
        if self.inlet is not None:
            object.__setattr__(self, "inlet", tuple(float(x) for x in np.asarray(self.inlet, dtype=float)[:3]))
        vertices, faces = _arrays(self.vertices, self.faces, where, name)
        extent = float(np.linalg.norm(vertices.max(axis=0) - vertices.min(axis=0))) * UNITS[self.units]
        if not PLAUSIBLE_SIZE[0] <= extent <= PLAUSIBLE_SIZE[1]:
            other = "mm" if self.units == "m" else "m"
            raise bad("mesh.units", self.units, f"the unit of {name}'s coordinates: in {self.units!r} it measures "
                                                f"{extent:.3g} m across, not a vessel ({PLAUSIBLE_SIZE[0]:g} to "
                                                f"{PLAUSIBLE_SIZE[1]:g} m); units = \"{other}\"?")
        _report(progress, 1, "check")
        vertices, faces = build.merged(vertices * UNITS[self.units], faces)
        neighbours = build.check_surface(vertices, faces, where, name)
        _report(progress, 2, "adjacency")
        face_normals, vertex_normals = build.normals(vertices, faces)
        offsets, ring = build.vertex_rings(faces, len(vertices))
        _report(progress, 3, "grid")
        origin, cell, shape, seeds = build.seed_grid(vertices, faces, (offsets, ring), self.cell)
        arrays = dict(vertices=vertices, faces=faces, neighbours=neighbours, face_normals=face_normals,
                      vertex_normals=vertex_normals, ring_offsets=offsets, ring=ring, grid_origin=origin,
                      grid_shape=shape, grid_faces=seeds)
        for key, value in arrays.items():
            value.setflags(write=False)
            object.__setattr__(self, key, value)
        object.__setattr__(self, "grid_cell", cell)
        object.__setattr__(self, "_cache", {})
        _report(progress, 4, "done")

    @property
    def closest(self) -> build.Closest:
        """The exact closest-point search (``_mesh_build.Closest``), built on first use."""
        if "closest" not in self._cache:
            self._cache["closest"] = build.Closest(self.vertices, self.faces)
        return self._cache["closest"]

    def signed_distance(self, positions: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Exact signed distances (n,) [m] of points (n, 3) [m] to the surface (positive inside the
        lumen), the closest points (n, 3) [m] and faces (n,) int64."""
        x = np.asarray(positions, dtype=float).reshape(-1, 3)
        face, q, feature, d = self.closest.query(x)
        n = build.pseudonormal(face, feature, self.faces, self.neighbours, self.face_normals, self.vertex_normals)
        inside = np.einsum("ij,ij->i", x - q, n) < 0
        return np.where(inside, d, -d), q, face

    def gap(self, positions: np.ndarray, radius: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Gaps (n,) [m] and unit normals into the lumen (n, 3) at node positions (n, 3) [m] with rod
        radii (n,) [m] (exact: the reference of the kernels' walk)."""
        x = np.asarray(positions, dtype=float).reshape(-1, 3)
        s, q, face = self.signed_distance(x)
        d = np.abs(s)
        with np.errstate(invalid="ignore", divide="ignore"):
            normal = np.where((d > 0)[:, None], np.sign(s)[:, None] * (x - q) / d[:, None], -self.face_normals[face])
        return s - radius, normal

    def closest_faces(self, positions: np.ndarray) -> np.ndarray:
        """The closest face (n,) int64 of each point (n, 3) [m] (the kernels' start)."""
        return self.closest.query(np.asarray(positions, dtype=float).reshape(-1, 3))[0]

    @property
    def centreline(self) -> Centreline:
        """The lumen's centreline tree from ``inlet`` (``_centreline.Centreline``: ``branches``, a
        list of polylines (m_b, 3) [m] from the inlet to each end, and ``progress``), found from the
        mesh on first use."""
        if "centreline" not in self._cache:
            self._cache["centreline"] = centreline_of(self, self.inlet)
        return self._cache["centreline"]

    def centreline_progress(self, points: np.ndarray, branch: int) -> np.ndarray:
        """Arc length [m] along centreline branch ``branch`` (from the inlet) of the points (n, 3)
        [m] projected on it (``Centreline.progress``)."""
        return self.centreline.progress(points, branch)

    def to_record(self, friction: float | None = None) -> dict:
        """The record: ``kind`` "mesh", ``units``, ``cell``, ``inlet`` and ``friction``, with ``file``
        (the path read) and its ``sha256`` where it came from a file, else ``vertices`` [m] and
        ``faces``."""
        entry = {"kind": self.kind, "units": "m" if self.file is None else self.units,
                 "cell": self.grid_cell, "inlet": None if self.inlet is None else list(self.inlet)}
        if self.file is not None:
            entry.update(file=self.file, sha256=self.sha256)
        else:
            entry.update(vertices=self.vertices.tolist(), faces=self.faces.tolist())
        entry["friction"] = self.friction if friction is None else float(friction)
        return entry

    @classmethod
    def _from_entry(cls, entry: dict, where: str) -> "MeshVessel":
        """The mesh vessel of a record (``to_record``); its file must still hold the same bytes."""
        options = dict(units=entry.get("units", "m"), friction=entry.get("friction"), cell=entry.get("cell"),
                       inlet=entry.get("inlet"))
        if entry.get("file") is not None:
            return load_mesh(entry["file"], sha256=entry.get("sha256"), where=f"{where}.file", **options)
        if "vertices" not in entry or "faces" not in entry:
            raise bad(where, _short(entry), "a mesh record with file (and sha256), or vertices and faces")
        return cls(entry["vertices"], entry["faces"], **options)


def _arrays(vertices, faces, where: str, name: str) -> tuple[np.ndarray, np.ndarray]:
    """Validated vertices (V, 3) float and faces (F, 3) int64 (indices in range)."""
    try:
        v = np.array(vertices, dtype=float)
        f = np.array(faces)
    except (TypeError, ValueError):
        raise bad(where, name, "vertices (V, 3) of finite numbers and faces (F, 3) of vertex indices") from None
    if v.ndim != 2 or v.shape[1] != 3 or len(v) < 4 or not np.all(np.isfinite(v)):
        raise bad(where, name, f"(V, 3) finite vertices, V >= 4 (got shape {v.shape})")
    if f.ndim != 2 or f.shape[1] != 3 or len(f) < 4 or not np.issubdtype(f.dtype, np.integer):
        raise bad(where, name, f"(F, 3) integer faces, F >= 4 (got shape {f.shape})")
    if f.min() < 0 or f.max() >= len(v):
        raise bad(where, name, f"faces indexing its {len(v)} vertices (found index {int(f.max())})")
    if len(f) > MAX_FACES or len(f) * BYTES_PER_FACE > _memory_limit():
        raise bad(where, name, f"a mesh that fits this machine ({len(f)} faces; at most {MAX_FACES} and "
                               f"{_memory_limit() // BYTES_PER_FACE} here): decimate it in your mesher")
    return v, f.astype(np.int64)


def _report(progress, done: int, stage: str) -> None:
    if progress is not None:
        progress(done, 4, {"stage": stage})


def load_mesh(path, units: str = "m", *, friction: float | None = None, cell: float | None = None,
              inlet=None, sha256: str | None = None, where: str = "mesh.file",
              progress: Progress | None = None) -> MeshVessel:
    """A ``MeshVessel`` read from a surface mesh file (``EXTENSIONS``) in ``units``; ``sha256``: the
    hash the file must have (a record's), else a one-line error naming the file. ``progress``
    (``softrnn.progress``) hears the stages (read, check, adjacency, grid) as 0..4 of 4."""
    name = str(path)
    if not Path(name).is_file():
        raise bad(where, name, "an existing surface mesh file")
    digest = file_sha256(name)
    if sha256 is not None and digest != sha256:
        raise bad(where, name, f"the mesh file this record was made with (sha256 {sha256[:12]}..., the file has "
                               f"{digest[:12]}...); restore that file")
    if progress is not None:
        progress(0, 4, {"stage": "read"})
    points, triangles = read_surface(name, where)
    return MeshVessel(points, triangles, units=units, friction=friction, cell=cell, inlet=inlet,
                      file=str(Path(name).resolve()), sha256=digest, progress=progress)


ARCH_BRANCHES = ("brachiocephalic", "left carotid", "left subclavian")
"""``arch_tree``'s branches, from the ascending side of the arch."""


def arch_centrelines(descending: float = 0.2, aorta_radius: float = 0.006,
                     branch_radii=(0.0035, 0.003, 0.003)) -> list[tuple[np.ndarray, float]]:
    """The tubes of ``arch_tree``: centreline polylines (m_i, 3) [m] and radii [m]: the aorta (from
    the descending end at z = -``descending`` up over the arch and down the ascending aorta), then
    the three branches (``ARCH_BRANCHES``) up from the arch's top. The arch (bend radius 30 mm) lies
    near the xz-plane, z up, the descending aorta along x = y = 0, z < 0; the ascending at x = -60 mm."""
    bend = 0.03
    angles = np.linspace(0.0, np.pi, 25)
    arch = np.stack([bend * (np.cos(angles) - 1.0), 0.004 * np.sin(angles), bend * np.sin(angles)], axis=1)
    down = np.linspace(0.0, descending, max(2, int(descending / 0.05) + 1))[::-1]
    aorta = np.concatenate([np.stack([0 * down, 0 * down, -down], axis=1)[:-1], arch,
                            [[-2 * bend, 0.0, -0.02], [-2 * bend, 0.0, -0.05]]])
    tubes = [(aorta, aorta_radius)]
    for angle, radius, tilt in zip((2.3, 1.55, 0.8), branch_radii, (-0.25, 0.0, 0.25)):
        root = np.array([bend * (np.cos(angle) - 1.0), 0.004 * np.sin(angle), bend * np.sin(angle)])
        up = np.array([np.sin(tilt), 0.0, np.cos(tilt)])
        tubes.append((np.stack([root, root + 0.04 * up, root + 0.08 * up + [0.0, 0.01, 0.0]]), radius))
    return tubes


def arch_tree(descending: float = 0.2, aorta_radius: float = 0.006, branch_radii=(0.0035, 0.003, 0.003),
              spacing: float = 0.0016) -> tuple[np.ndarray, np.ndarray]:
    """A procedurally made aortic arch with three branches as a closed surface: vertices (V, 3) [m]
    and faces (F, 3) int64 (outward).

    The lumen is the smooth union of round-ended tubes around ``arch_centrelines`` (a descending
    aorta ``descending`` [m] long, the arch, a short ascending aorta, three branches of
    ``branch_radii`` [m] up from the arch's top), meshed by marching tetrahedra on a grid of
    ``spacing`` [m] and projected onto the implicit surface (``_marching.tube_tree_surface``)."""
    return tube_tree_surface(arch_centrelines(descending, aorta_radius, branch_radii), spacing)
