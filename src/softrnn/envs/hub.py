"""``HubMotion``: the environments' former name of the hub's commanded motion, kept as a thin adapter
over the rod's hub (``softrnn.rod.hub.Hub.commanded`` with a ``travel``), which the environments
drive themselves (``RodBatch.hubs``).
"""

import numpy as np

from ..errors import bad, finite
from ..rod.hub import Hub


class HubMotion:
    """The hub's pose in time, driven by commanded insertion and rotation rates: a ``Hub.commanded``
    whose insertion stays in [0, travel] (``hub``), with the calls of the environments' former hub.

    ``motion(t)`` (the ``Clamp(0, motion=...)`` protocol of ``softrnn.rod.boundary``) gives the
    positions (K, 3) [m] and rotations (K, 3, 3) of node 0 at times t (K,) [s]: the start pose
    moved ``insertion(t)`` along ``axis`` and turned ``angle(t)`` about it.

    Attributes
    ----------
    hub : Hub
        the rod's hub that moves (its ``insertion`` and ``rotation`` are ``Commanded``)
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
        self.hub = Hub.commanded(origin, axis, rotation, travel=travel)
        self.origin = np.asarray(self.hub.entry, dtype=float)
        self.rotation, self.axis, self.travel = self.hub.rotation0, self.hub.axis, float(travel)

    def reset(self, insertion: float = 0.0, angle: float = 0.0, time: float = 0.0) -> None:
        """Hold still at ``insertion`` [m] and ``angle`` [rad] from ``time`` [s] on."""
        if not 0.0 <= insertion <= self.travel:
            raise bad("insertion", insertion, f"a hub position in [0, {self.travel:g}] m")
        self.hub.reset_commands()
        self.hub.insertion.set(float(time), float(insertion))
        self.hub.rotation.set(float(time), finite("angle", angle, "rad"))

    def command(self, time: float, insertion_rate: float, rotation_rate: float) -> None:
        """From ``time`` [s] on, insert at ``insertion_rate`` [m/s] and rotate at ``rotation_rate``
        [rad/s] (a new piece, continuous with the last)."""
        self.hub.command(time, insertion_rate=insertion_rate, rotation_rate=rotation_rate)

    def insertion(self, t: np.ndarray) -> np.ndarray:
        """The insertion (K,) [m] at times t (K,) [s]."""
        return self.hub.insertion(np.asarray(t, dtype=float))

    def angle(self, t: np.ndarray) -> np.ndarray:
        """The angle (K,) [rad] at times t (K,) [s]."""
        return self.hub.rotation(np.asarray(t, dtype=float))

    def __call__(self, t: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Positions (K, 3) [m] and rotations (K, 3, 3) of the hub at times t (K,) [s]."""
        return self.hub(t)
