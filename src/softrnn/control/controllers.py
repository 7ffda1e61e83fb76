"""Controllers of the magnetic rod: each frame, from the camera's measurement and the reference,
the coil currents for the next frame.

A controller is an object with ``reset(reference)`` (before the first frame; returns the currents
the plant settles under) and ``__call__(k, measured, reference) -> currents (n_c,) [A]``: ``measured`` is the
camera's orientations (M, 3) [rad] of frame k (NaN where the camera lost the rod). It must never
return currents beyond the coils' limit; on a measurement it cannot use it holds its last currents
(``held`` counts those frames).

The controllers: ``static_inverse.StaticInverse`` (``static-inverse``) and ``mpc.BlockMPC`` planning
with ``model.NarxPredictor`` (``mpc-learned``) or with ``physics_mpc.PhysicsPredictor`` (``mpc-physics``).
"""

from __future__ import annotations

from ..errors import bad
from ..magnetics.manipulator import ManipulatorSpec
from .loop import LoopConfig
from .model import NarxModel, NarxPredictor
from .mpc import BlockMPC
from .physics_mpc import PHYSICS_OPTIONS, PhysicsPredictor
from .static_inverse import StaticInverse

__all__ = ["CONTROLLERS", "controller"]

CONTROLLERS = ("static-inverse", "mpc-learned", "mpc-physics")
"""Controllers ``controller(name)`` builds."""


def controller(name: str, spec: ManipulatorSpec | None = None, *, model: NarxModel | None = None,
               config: LoopConfig | None = None):
    """A controller by name (``CONTROLLERS``); ``mpc-learned`` needs the trained ``model``
    (``softrnn.control.model.NarxModel``); ``mpc-physics`` plans on ``spec`` (None: the nominal
    model) with the rate and camera of ``config`` (a ``loop.LoopConfig``; None: the defaults)."""
    if name == "static-inverse":
        return StaticInverse(spec)
    if name == "mpc-learned":
        if model is None:
            raise bad("model", None, "a trained control model (softrnn.control.identify.identified_model)")
        return BlockMPC(NarxPredictor(model), spec)
    if name == "mpc-physics":
        return BlockMPC(PhysicsPredictor(spec, config), spec, options=PHYSICS_OPTIONS)
    raise bad("--controller", name, f"one of {', '.join(CONTROLLERS)}")
