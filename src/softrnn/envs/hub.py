"""The hub of a navigation environment: the clamped base of the device (node 0) inserted along the
vessel's entry and rotated about it at commanded rates (``HubMotion``, a ``Clamp``'s motion).

The motion is continuous and piecewise linear in time: each ``command`` starts a new piece at the
current time with new rates, from where the hub is. The insertion stays within its travel (it stops
at either end); the angle is free.
"""

import numpy as np

from ..errors import bad, finite
from ..rod.hub import axis_rotation


class HubMotion:
    """The hub's pose in time, driven by commanded insertion and rotation rates.

    ``motion(t)`` (the ``Clamp(0, motion=...)`` protocol of ``softrnn.rod.boundary``) gives the
    positions (K, 3) [m] and rotations (K, 3, 3) of node 0 at times t (K,) [s]: the start pose
    moved ``insertion(t)`` along ``axis`` and turned ``angle(t)`` about it.

    Attributes
    ----------
    origin : (3,)
        the hub's position at insertion 0 [m]
    rotation : (3, 3)
        its rotation at angle 0
    axis : (3,)
        the insertion direction (unit) [-]
    travel : float
        the largest insertion [m]; insertions stay in [0, travel]
    """

    def __init__(self, origin, rotation, axis, travel: float):
        self.origin = np.asarray(origin, dtype=float).copy()
        self.rotation = np.asarray(rotation, dtype=float).copy()
        a = np.asarray(axis, dtype=float)
        self.axis = a / np.linalg.norm(a)
        self.travel = float(travel)
        self.reset()

    def reset(self, insertion: float = 0.0, angle: float = 0.0, time: float = 0.0) -> None:
        """Hold still at ``insertion`` [m] and ``angle`` [rad] from ``time`` [s] on."""
        if not 0.0 <= insertion <= self.travel:
            raise bad("insertion", insertion, f"a hub position in [0, {self.travel:g}] m")
        self._t0, self._s0, self._a0 = float(time), float(insertion), float(finite("angle", angle, "rad"))
        self._v = self._w = 0.0

    def command(self, time: float, insertion_rate: float, rotation_rate: float) -> None:
        """From ``time`` [s] on, insert at ``insertion_rate`` [m/s] and rotate at ``rotation_rate``
        [rad/s] (a new piece, continuous with the last)."""
        s, a = float(self.insertion(np.array([time]))[0]), float(self.angle(np.array([time]))[0])
        self._t0, self._s0, self._a0 = float(time), s, a
        self._v, self._w = float(insertion_rate), float(rotation_rate)

    def insertion(self, t: np.ndarray) -> np.ndarray:
        """The insertion (K,) [m] at times t (K,) [s]."""
        return np.clip(self._s0 + self._v * (np.asarray(t, dtype=float) - self._t0), 0.0, self.travel)

    def angle(self, t: np.ndarray) -> np.ndarray:
        """The angle (K,) [rad] at times t (K,) [s]."""
        return self._a0 + self._w * (np.asarray(t, dtype=float) - self._t0)

    def __call__(self, t: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Positions (K, 3) [m] and rotations (K, 3, 3) of the hub at times t (K,) [s]."""
        t = np.atleast_1d(np.asarray(t, dtype=float))
        positions = self.origin + self.insertion(t)[:, None] * self.axis
        return positions, axis_rotation(self.axis, self.angle(t)) @ self.rotation
