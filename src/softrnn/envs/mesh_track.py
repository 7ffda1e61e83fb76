"""A vessel given as a surface mesh as the vessel of a navigation environment: ``MeshTrack`` adapts a
``softrnn.geometry.mesh.MeshVessel`` to the ``Track`` protocol (its obstacle, its centreline tree's
branches found from the mesh and named by their ends, where each forks, the lumen's radius at the
entry); ``arch_track`` is the shipped aortic arch with its three branches and ``arch_config`` a
task sized for it (docs/guide/envs.md, "A meshed vessel").
"""

import dataclasses
from importlib.resources import files

import numpy as np

from ..errors import bad, vec3
from ..geometry.mesh import ARCH_BRANCHES, ARCH_FILE, MeshVessel, arch_centrelines, load_mesh
from ..geometry.obstacles import closest_segments
from .config import NavigateConfig

ENTRY_FIT = 0.03
"""The length [m] of the centreline's first part that is straightened (its points projected on
their least-squares line): the entry's axis, along which the device starts, is then that of the
lumen, not of the first two points of a centreline found on voxels."""

ARCH_INLET = (0.0, 0.0, -0.2)
"""Where the shipped arch's centreline starts [m]: the lower end of its descending aorta (as the
``mesh-arch-guidewire`` scenario)."""


def _spaced(line: np.ndarray, spacing: float) -> np.ndarray:
    """The points (m, 3) [m] of ``line`` each at least ``spacing`` [m] from the last one kept (a
    centreline found on voxels may repeat a point); the last point kept."""
    kept = [0]
    for i in range(1, len(line)):
        if np.linalg.norm(line[i] - line[kept[-1]]) >= spacing:
            kept.append(i)
    if kept[-1] != len(line) - 1:
        kept[-1] = len(line) - 1
    return np.asarray(line, dtype=float)[kept]


def _straight_entry(lines: list[np.ndarray]) -> list[np.ndarray]:
    """The branches (m_b, 3) [m] with their points within ``ENTRY_FIT`` of the start projected on the
    least-squares line of the first branch's such points (the branches share their start: they stay
    equal where they were)."""
    first = lines[0]
    arc = np.concatenate([[0.0], np.cumsum(np.linalg.norm(np.diff(first, axis=0), axis=1))])
    part = first[: max(2, int(np.searchsorted(arc, ENTRY_FIT, side="right")))]
    centre = part.mean(axis=0)
    direction = np.linalg.svd(part - centre)[2][0]
    direction = direction if direction @ (part[-1] - part[0]) > 0 else -direction
    out = []
    for line in lines:
        line = np.array(line, dtype=float)
        k = min(len(part), len(line))
        near = np.flatnonzero(np.all(line[:k] == part[:k], axis=1))
        m = int(near[-1]) + 1 if len(near) and np.all(near == np.arange(len(near))) else 0
        line[:m] = centre + ((line[:m] - centre) @ direction)[:, None] * direction
        out.append(line)
    return out


def _fork(lines: list[np.ndarray], j: int, vessel: MeshVessel) -> float:
    """Where branch j leaves every other branch of the tree [m along it]: its first point, after the
    last one it shares with another, farther from every other branch's centreline than the lumen's
    radius where they part (out of the parent's lumen, past the ostium); 0 for a tree of one branch."""
    p = lines[j]
    arc = np.concatenate([[0.0], np.cumsum(np.linalg.norm(np.diff(p, axis=0), axis=1))])
    shared = 0
    for k, q in enumerate(lines):
        if k != j:
            m = min(len(p), len(q))
            same = np.all(p[:m] == q[:m], axis=1)
            shared = max(shared, m if same.all() else int(np.argmin(same)))
    if not shared:
        return 0.0
    radius = float(vessel.signed_distance(p[shared - 1:shared])[0][0])
    apart = np.min([closest_segments(q, p[shared:])[1] for k, q in enumerate(lines) if k != j], axis=0)
    out = np.flatnonzero(apart > radius)
    return float(arc[shared + out[0]] if len(out) else arc[-1])


class MeshTrack:
    """A ``MeshVessel`` as a navigation environment's ``Track``.

    Parameters
    ----------
    vessel : MeshVessel
        the lumen; its centreline tree (``MeshVessel.centreline``, from its ``inlet``) gives the
        branches
    ends : dict or None
        {name: point (3,) [m]}: each branch is the tree's path whose end lies nearest to its point;
        None: every path of the tree, named "branch 0", "branch 1", ...

    Attributes
    ----------
    obstacles : tuple
        the mesh
    branches : tuple of str
        the branches' names
    entry_radius : float
        the least distance [m] from the straightened entry's centreline (its first ``ENTRY_FIT``) to
        the wall: the lumen's radius there, a little less than the mesh's between its vertices
    """

    def __init__(self, vessel: MeshVessel, ends: dict | None = None):
        if not isinstance(vessel, MeshVessel):
            raise bad("vessel", type(vessel).__name__, "a softrnn.geometry.mesh.MeshVessel")
        tree = vessel.centreline
        if ends is None:
            ends = {f"branch {i}": line[-1] for i, line in enumerate(tree.branches)}
        if not isinstance(ends, dict) or not ends:
            raise bad("ends", ends, "{name: point [x, y, z] in m} naming the branches by their ends")
        chosen = {}
        for name, point in ends.items():
            i = tree.nearest_branch(vec3(f"ends[{name!r}]", point, "in m"))
            if i in chosen.values():
                raise bad(f"ends[{name!r}]", point, "a point nearest to an end of the centreline tree no other "
                                                    "name has")
            chosen[str(name)] = i
        lines = _straight_entry([_spaced(line, 0.5 * tree.voxel) for line in tree.branches])
        self.obstacles = (vessel,)
        self.branches = tuple(chosen)
        self._lines = {name: lines[i] for name, i in chosen.items()}
        self._forks = {name: _fork(lines, i, vessel) for name, i in chosen.items()}
        start = lines[0]
        arc = np.concatenate([[0.0], np.cumsum(np.linalg.norm(np.diff(start, axis=0), axis=1))])
        probe = start[: max(2, int(np.searchsorted(arc, ENTRY_FIT, side="right")))]
        self.entry_radius = float(vessel.signed_distance(probe)[0].min())
        if self.entry_radius <= 0.0:
            raise bad("vessel.inlet", vessel.inlet, "a point in the lumen where its centreline starts (the entry)")

    def centreline(self, branch: str) -> np.ndarray:
        """The centreline (P, 3) [m] from the entry to ``branch``'s end, its first ``ENTRY_FIT``
        straightened."""
        if branch not in self._lines:
            raise bad("branch", branch, f"one of {', '.join(self.branches)}")
        return self._lines[branch]

    def fork(self, branch: str) -> float:
        """Where ``branch`` leaves the rest of the tree [m along its centreline]: past the ostium, out
        of the parent's lumen (every path of the tree counts, also one that is not a named branch)."""
        if branch not in self._forks:
            raise bad("branch", branch, f"one of {', '.join(self.branches)}")
        return self._forks[branch]


def arch_track(mesh: MeshVessel | None = None) -> MeshTrack:
    """The aortic arch of ``softrnn.geometry.mesh.arch_tree`` as a ``MeshTrack``, its branches
    ``ARCH_BRANCHES`` (brachiocephalic, left carotid, left subclavian) named by their ends; ``mesh``:
    one of ``arch_tree``'s meshes with its defaults' centrelines (e.g. a coarser one), None: the
    shipped ``mesh-arch.vtu``, its centreline from ``ARCH_INLET``."""
    if mesh is None:
        mesh = load_mesh(files("softrnn.scenarios") / ARCH_FILE, "m", inlet=ARCH_INLET)
    ends = {name: line[-1] for name, (line, _) in zip(ARCH_BRANCHES, arch_centrelines()[1:])}
    return MeshTrack(mesh, ends)


def arch_config(**changes) -> NavigateConfig:
    """The navigation task in the arch: the patient supine (gravity -y), the hub's travel sized from
    the arch (``travel=None``), the wall's normal force implicit (``implicit_contact``); ``changes``:
    any other ``NavigateConfig`` field."""
    base = dict(gravity=(0.0, -9.81, 0.0), travel=None, implicit_contact=True)
    try:
        return NavigateConfig(**{**base, **changes})
    except TypeError:
        fields = {f.name for f in dataclasses.fields(NavigateConfig)}
        unknown = sorted(set(changes) - fields)
        raise bad("arch_config", unknown, f"NavigateConfig fields ({', '.join(sorted(fields))})") from None
