"""External loads: nodal forces and torques, and state-feedback (PD) forces.

Their time functions (``Constant``, ``Sinusoid``, ``Sampled``, ``Window``, ``Sum``, ``Scheduled``
and the target paths) live in ``softrnn.geometry.paths``, shared with the learned models; they are
imported here too, so ``softrnn.rod.loads.Constant`` and the rest keep working. All are vectorised
and evaluated chunk by chunk ahead of the numba kernel.
"""

from dataclasses import dataclass

import numpy as np

from ..errors import bad, finite, positive
from ..geometry.paths import SCHEDULE_SHAPES as SCHEDULE_SHAPES
from ..geometry.paths import AbstractTimeFunction as AbstractTimeFunction
from ..geometry.paths import CirclePath as CirclePath
from ..geometry.paths import Constant as Constant
from ..geometry.paths import Figure8Path as Figure8Path
from ..geometry.paths import Piecewise as Piecewise
from ..geometry.paths import RandomSmoothPath as RandomSmoothPath
from ..geometry.paths import Sampled as Sampled
from ..geometry.paths import Scheduled as Scheduled
from ..geometry.paths import Sinusoid as Sinusoid
from ..geometry.paths import SquarePath as SquarePath
from ..geometry.paths import Sum as Sum
from ..geometry.paths import Window as Window
from ..geometry.paths import smoothstep as smoothstep


def gravity_at(gravity, t: float) -> tuple:
    """A ``Setup.gravity`` at the time t [s] as a 3-vector (gx, gy, gz) [m/s^2]: a constant as it
    is, a time function evaluated at t (for a consumer that needs one gravity vector, such as a
    static solution at the start of a run)."""
    if not callable(gravity):
        return tuple(float(g) for g in gravity)
    g = np.asarray(gravity(np.array([float(t)])), dtype=float)
    if g.shape != (1, 3) or not np.all(np.isfinite(g)):
        raise bad("gravity", gravity, f"a time function t (K,) [s] -> (K, 3) finite m/s^2 (got shape {g.shape})")
    return tuple(float(c) for c in g[0])


@dataclass(frozen=True)
class NodalLoad:
    """A force [N] and/or torque [N m] on one node; ``frame`` 'world' (fixed directions) or 'body'
    (follower load, components in the node's frame d1, d2, d3)."""

    node: int
    force: object | None = None
    torque: object | None = None
    frame: str = "world"

    def __post_init__(self):
        if self.frame not in ("world", "body"):
            raise bad("NodalLoad.frame", self.frame, "'world' or 'body'")
        if self.force is None and self.torque is None:
            raise bad("NodalLoad", "no force and no torque", "a force and/or a torque time function")


@dataclass(frozen=True)
class PDTracking:
    """State feedback force on ``node``: f = stiffness (target(t) - r) - damping v [N], pulling
    the node toward a moving target (the square-tracking case)."""

    node: int
    target: object
    stiffness: float
    damping: float = 0.0

    def __post_init__(self):
        positive("PDTracking.stiffness", self.stiffness)
        finite("PDTracking.damping", self.damping)
        if self.damping < 0:
            raise bad("PDTracking.damping", self.damping, "a damping gain >= 0 in N s/m")
