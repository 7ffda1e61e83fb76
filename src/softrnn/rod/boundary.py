"""Boundary conditions (docs/lgvi.md §2.7): clamped (fixed or prescribed moving pose), pinned
(position fixed or prescribed, rotation free), free (the default for every other node).

Both ends of a closed loop clamped at one point (the ellipse case) are two ``Clamp`` entries whose
nodes share a position.
"""

from dataclasses import dataclass

from ..errors import bad


@dataclass(frozen=True)
class Clamp:
    """Node ``node`` keeps the pose of the initial shape, or follows ``motion``: a callable
    t (K,) -> (positions (K, 3) [m], rotations (K, 3, 3))."""

    node: int
    motion: object | None = None

    def __post_init__(self):
        if not isinstance(self.node, int) or isinstance(self.node, bool):
            raise bad("Clamp.node", self.node, "an integer node index (negative counts from the end)")


@dataclass(frozen=True)
class Pin:
    """Node ``node`` keeps its initial position, or follows ``path``: t (K,) -> positions (K, 3);
    its rotation is free."""

    node: int
    path: object | None = None

    def __post_init__(self):
        if not isinstance(self.node, int) or isinstance(self.node, bool):
            raise bad("Pin.node", self.node, "an integer node index (negative counts from the end)")
