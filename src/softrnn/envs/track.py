"""The vessel of a navigation environment, as the environment needs it: its contact obstacles, its
branches and their centrelines (``Track``, a small protocol), and the progress of points along a
centreline.

``BifurcationTrack`` adapts a ``softrnn.geometry.Bifurcation`` (or a ``Vessel``: one branch);
another vessel, e.g. one from a surface mesh, plugs in through an object with the same four
members. ``default_vessel`` is the environment's vessel.
"""

import math
from typing import Protocol, runtime_checkable

import numpy as np

from ..errors import bad
from ..geometry.obstacles import Bifurcation, Vessel, closest_segments


@runtime_checkable
class Track(Protocol):
    """What a navigation environment needs of a vessel.

    Attributes
    ----------
    obstacles : tuple
        the contact obstacles of the lumen (``softrnn.geometry.Contact``'s ``obstacles``: any whose
        ``gap`` the simulator knows)
    branches : tuple of str
        the names of the paths a device may take, from the entry to each branch's end
    entry_radius : float
        the lumen's radius at the entry [m], where the device starts on the floor
    """

    obstacles: tuple
    branches: tuple
    entry_radius: float

    def centreline(self, branch: str) -> np.ndarray:
        """The centreline (P, 3) [m] from the entry to ``branch``'s end (P >= 2). A track may also
        have ``fork(branch)``: the arc length [m] along it where the branch leaves the others
        (``Paths`` finds it from the shared points of the centrelines otherwise)."""


class BifurcationTrack:
    """A ``Bifurcation`` (branches "left" and "right") or a ``Vessel`` (one branch, "vessel") as a
    ``Track``.

    Attributes
    ----------
    obstacles : tuple
        the one obstacle
    branches : tuple of str
        ("left", "right"), or ("vessel",)
    entry_radius : float
        the radius at its first centreline point [m]
    """

    def __init__(self, vessel: Bifurcation | Vessel):
        if isinstance(vessel, Bifurcation):
            self._paths = {"left": vessel.vessels[0], "right": vessel.vessels[1]}
        elif isinstance(vessel, Vessel):
            self._paths = {"vessel": vessel}
        else:
            raise bad("vessel", type(vessel).__name__, "a softrnn.geometry Bifurcation or Vessel")
        self.obstacles = (vessel,)
        self.branches = tuple(self._paths)
        self.entry_radius = float(next(iter(self._paths.values())).radii[0])

    def centreline(self, branch: str) -> np.ndarray:
        """The dense centreline polyline (P, 3) [m] of ``branch`` (the vessel's ``points``)."""
        if branch not in self._paths:
            raise bad("branch", branch, f"one of {', '.join(self.branches)}")
        return np.asarray(self._paths[branch].points)


def default_vessel() -> Bifurcation:
    """The environment's vessel: an 8 mm lumen (a carotid's or an iliac artery's size), a straight
    trunk along +x from x = -0.2 m (its first part stands for the introducer sheath) to the junction at
    the origin, two 80 mm branches at +-30 degrees in the horizontal plane, left toward +y."""
    branch = 0.08 * np.array([math.cos(math.radians(30.0)), math.sin(math.radians(30.0)), 0.0])
    half = np.array([1.0, -1.0, 1.0])
    return Bifurcation(trunk=[[-0.2, 0.0, 0.0], [0.0, 0.0, 0.0]], left=[branch / 2, branch],
                       right=[half * branch / 2, half * branch], radius=0.004)


class Paths:
    """The branches' centrelines of a ``Track`` with their arc lengths and forks, and the progress
    of points along them.

    Attributes
    ----------
    branches : tuple of str
        the track's branches, in its order
    lines : list of (P_j, 3)
        each branch's centreline [m]
    arc : list of (P_j,)
        the arc length at each centreline point [m]
    fork : (J,)
        where each branch leaves the others [m]: the track's ``fork(branch)`` where it has one (an
        optional member of ``Track``), else the arc length of the last point the branch's centreline
        shares with another branch's (0 for a track of one branch)
    """

    def __init__(self, track: Track):
        self.branches = tuple(track.branches)
        if not self.branches:
            raise bad("vessel.branches", self.branches, "at least one branch")
        self.lines = [np.asarray(track.centreline(b), dtype=float) for b in self.branches]
        self.arc = [np.concatenate([[0.0], np.cumsum(np.linalg.norm(np.diff(p, axis=0), axis=1))])
                    for p in self.lines]
        self.fork = np.zeros(len(self.lines))
        for j, p in enumerate(self.lines):
            shared = 0
            for k, q in enumerate(self.lines):
                if k != j:
                    m = min(len(p), len(q))
                    same = np.all(p[:m] == q[:m], axis=1)
                    shared = max(shared, m if same.all() else int(np.argmin(same)))
            self.fork[j] = self.arc[j][shared - 1] if shared else 0.0
        if callable(getattr(track, "fork", None)):
            self.fork = np.array([float(track.fork(b)) for b in self.branches])

    def index(self, branch: str) -> int:
        """The index of ``branch``; a one-line error naming the branches otherwise."""
        if branch not in self.branches:
            raise bad("target", branch, f"one of the vessel's branches {', '.join(self.branches)}")
        return self.branches.index(branch)

    def progress(self, points: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """The arc length (B, J) [m] of the projection of each point (B, 3) [m] on each branch's
        centreline (clipped to its ends), and the distance (B, J) [m] to it."""
        x = np.atleast_2d(np.asarray(points, dtype=float))
        s = np.empty((len(x), len(self.lines)))
        d = np.empty_like(s)
        for j, (p, arc) in enumerate(zip(self.lines, self.arc)):
            index, d[:, j], t = closest_segments(p, x)
            s[:, j] = arc[index] + np.clip(t, 0.0, 1.0) * (arc[index + 1] - arc[index])
        return s, d

    def standing(self, points: np.ndarray, target: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Where points (B, 3) [m] stand toward the target branches (B,) int64: the progress (B,)
        [m] along the target's centreline, and the branch each point is in (B,) int64, -1 before
        every fork. A point in another branch counts as that far behind the target's fork."""
        s, d = self.progress(points)
        rows = np.arange(len(s))
        nearest = np.argmin(d, axis=1)
        inside = np.where(s[rows, nearest] > self.fork[nearest], nearest, -1)
        wrong = (inside >= 0) & (inside != target)
        behind = self.fork[target] - (s[rows, nearest] - self.fork[nearest])
        return np.where(wrong, behind, s[rows, target]), inside
