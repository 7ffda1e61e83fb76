"""Controllers of the magnetic rod: each frame, from the camera's measurement and the reference,
the coil currents for the next frame.

A controller is an object with ``reset(reference)`` (before the first frame; returns the currents
the plant settles under) and ``__call__(k, measured, reference) -> currents (n_c,) [A]``: ``measured`` is the
camera's orientations (M, 3) [rad] of frame k (NaN where the camera lost the rod). It must never
return currents beyond the coils' limit; on a measurement it cannot use it holds its last currents
(``held`` counts those frames).

The controllers: ``static_inverse.StaticInverse`` (``static-inverse``), ``mpc.LearnedMPC``
(``mpc-learned``) and ``physics_mpc.PhysicsMPC`` (``mpc-physics``).
"""

from __future__ import annotations

from ..errors import bad
from ..magnetics.manipulator import ManipulatorSpec
from .static_inverse import DISTAL, StaticInverse

__all__ = ["CONTROLLERS", "DISTAL", "StaticInverse", "controller"]

CONTROLLERS = ("static-inverse", "mpc-learned", "mpc-physics")
"""Controllers ``controller(name)`` builds."""


def controller(name: str, spec: ManipulatorSpec | None = None, *, model=None, config=None):
    """A controller by name (``CONTROLLERS``); ``mpc-learned`` needs the trained ``model``
    (``softrnn.control.model.NarxModel``); ``mpc-physics`` plans on ``spec`` (None: the nominal
    model) with the rate and camera of ``config`` (a ``loop.LoopConfig``; None: the defaults)."""
    if name == "static-inverse":
        return StaticInverse(spec)
    if name == "mpc-learned":
        from .mpc import LearnedMPC

        if model is None:
            raise bad("model", None, "a trained control model (softrnn.control.identify.identified_model)")
        return LearnedMPC(model, spec)
    if name == "mpc-physics":
        from .physics_mpc import PhysicsMPC

        camera = {} if config is None else {"rate": config.rate, "camera_points": config.camera_points,
                                            "polynomial_degree": config.polynomial_degree,
                                            "settle": config.settle}
        return PhysicsMPC(spec, **camera)
    raise bad("--controller", name, f"one of {', '.join(CONTROLLERS)}")
