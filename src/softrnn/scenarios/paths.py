"""Prescribed boundary motions built from profiles: a clamped node's pose and a pinned node's
position over time.

Like the time functions in ``softrnn.rod.loads`` (the target paths among them) they are frozen,
validated dataclasses and vectorised callables of the times t (K,) [s].
"""

from dataclasses import dataclass

import numpy as np

from ..errors import bad, vec3
from ..rod.so3 import hat


def rotation_vector_to_matrix(x: np.ndarray) -> np.ndarray:
    """Rodrigues: rotation vectors (..., 3) (axis times angle [rad]) -> matrices (..., 3, 3)."""
    x = np.asarray(x, dtype=float)
    th = np.linalg.norm(x, axis=-1)[..., None, None]
    X = hat(x)
    a = np.sinc(th / np.pi)  # sin(th)/th, 1 at 0
    b = 0.5 * np.sinc(th / (2 * np.pi)) ** 2  # (1 - cos th)/th^2, 1/2 at 0
    return np.eye(3) + a * X + b * (X @ X)


@dataclass(frozen=True, eq=False)
class PoseMotion:
    """Prescribed pose of a clamped node: position = ``position`` + displacement(t) [m], rotation =
    exp(rotation(t)^) ``rotation0``, with ``rotation(t)`` a rotation vector [rad] in the world frame.
    Either time function may be None (no displacement / no rotation). Returns (K, 3), (K, 3, 3)."""

    position: tuple
    rotation0: np.ndarray
    displacement: object | None = None
    rotation: object | None = None

    def __post_init__(self):
        object.__setattr__(self, "position", vec3("PoseMotion.position", self.position))
        R = np.array(self.rotation0, dtype=float)
        if R.shape != (3, 3) or not np.allclose(R.T @ R, np.eye(3), atol=1e-8):
            raise bad("PoseMotion.rotation0", R.shape, "a 3x3 rotation matrix")
        R.setflags(write=False)
        object.__setattr__(self, "rotation0", R)

    def __call__(self, t):
        t = np.asarray(t, dtype=float)
        pos = np.broadcast_to(np.asarray(self.position), (t.size, 3)).copy()
        if self.displacement is not None:
            pos = pos + self.displacement(t)
        if self.rotation is None:
            rot = np.broadcast_to(self.rotation0, (t.size, 3, 3)).copy()
        else:
            rot = rotation_vector_to_matrix(self.rotation(t)) @ self.rotation0
        return pos, rot


@dataclass(frozen=True, eq=False)
class PositionPath:
    """Prescribed position of a pinned node: ``position`` + displacement(t) [m], (K, 3)."""

    position: tuple
    displacement: object

    def __post_init__(self):
        object.__setattr__(self, "position", vec3("PositionPath.position", self.position))
        if not callable(self.displacement):
            raise bad("PositionPath.displacement", self.displacement, "a time function t (K,) -> (K, 3)")

    def __call__(self, t):
        t = np.asarray(t, dtype=float)
        return np.asarray(self.position) + self.displacement(t)
