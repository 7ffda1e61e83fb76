"""The ``[hub]`` table of a scenario: insertion and rotation at the hub (``softrnn.rod.hub.Hub``),
prescribed as profiles or driven by an axial force and a torque, read into the ``Clamp`` that the
hub holds; every value checked with its key (docs/scenario-format.md#hub)."""

from __future__ import annotations

import numpy as np

from ..errors import SoftrnnInputError
from ..rod.boundary import Clamp
from ..rod.hub import Hub, HubTable
from ..rod.integrators import Implicit
from ..rod.loads import Sinusoid
from ..rod.shapes import RodShape
from ..rod.tendons import Scalar
from ._sections import _SCHEDULE_KEY, _kind, _node, _scheduled
from .reading import ScenarioError, _Ctx, _Table, number, numbers, string, vec3

HUB_KEYS = {
    "node": "the node the hub holds (default 0)",
    "entry": "the held node's position [x, y, z] in m at zero insertion (default: its initial position)",
    "axis": "the insertion direction [x, y, z] (default: the held node's d3, the rod's tangent there)",
    "insertion": "the insertion along the axis in m: a number or a profile table (kind = constant, sinusoid, "
                 "sampled or piecewise)",
    "rotation": "the rotation about the axis in rad: a number or a profile table",
    "force": "instead of insertion: the axial force in N pushing the node along the axis (a number or a profile "
             "table)",
    "torque": "instead of rotation: the torque in N m twisting the node about the axis (a number or a profile table)",
    "mass": "with force: the hub's mass in kg moved with the node (default 0)",
    "inertia": "with torque: the hub's moment of inertia about the axis in kg m^2 (default 0)",
}

_PROFILE_KEYS = {
    "constant": {"value": "the value"},
    "sinusoid": {"amplitude": "the amplitude", "frequency": "the frequency in Hz", "phase": "the phase in rad "
                 "(default 0)", "offset": "the mean (default 0)"},
    "sampled": {"times": "strictly increasing times in s", "values": "one value per time, linear between them and "
                "held before the first and after the last", "interpolation": "'linear' (default) or 'hold'"},
    "piecewise": {"times": "strictly increasing times in s", "values": "one value per time, held to the next"},
}
_UNITS = {"insertion": "m", "rotation": "rad", "force": "N", "torque": "N m"}


def _profile(ctx: _Ctx, raw, path: str, unit: str):
    """A hub input t (K,) -> (K,) in ``unit``: a number (constant) or a profile table with its schedule."""
    if isinstance(raw, (int, float)) and not isinstance(raw, bool):
        return HubTable([0.0], [number(unit)(ctx, path, raw)])
    kinds = tuple(_PROFILE_KEYS)
    if not isinstance(raw, dict):
        raise ctx.invalid(path, raw, f"a number in {unit}, or a profile table with kind = " + ", ".join(kinds))
    kind = _kind(ctx, raw, path, kinds, "the profile kind: " + ", ".join(kinds))
    t = _Table(ctx, raw, path, {"kind": "the profile kind", **_PROFILE_KEYS[kind], **_SCHEDULE_KEY})
    if kind == "constant":
        function = HubTable([0.0], [t.get("value", number(unit))])
    elif kind == "sinusoid":
        function = Scalar(Sinusoid((t.get("amplitude", number(unit)), 0.0, 0.0), t.get("frequency", number("Hz")),
                                   phase=t.get("phase", number("rad"), 0.0),
                                   offset=(t.get("offset", number(unit), 0.0), 0.0, 0.0)))
    else:
        times = t.get("times", numbers("s"))
        values = t.get("values", numbers(unit))
        if values.size != times.size:
            raise ctx.invalid(t.key("values"), values.tolist(), f"{times.size} values in {unit}, one per time")
        if np.any(np.diff(times) <= 0):
            raise ctx.invalid(t.key("times"), times.tolist(), "strictly increasing times in s")
        interp = "hold" if kind == "piecewise" else t.get("interpolation", string(("linear", "hold")), "linear")
        function = HubTable(times, values, interp)
    return _scheduled(ctx, t, function)


def read_hub(ctx: _Ctx, raw, start: RodShape, n: int) -> Clamp:
    """The ``[hub]`` table as the ``Clamp`` its ``Hub`` holds; ``start``: the initial shape (the
    held node's default entry, axis and frame), ``n`` the rod's nodes."""
    t = _Table(ctx, raw, "hub", HUB_KEYS)
    node = t.get("node", _node(n), 0)
    frame = start.rotations[node]
    inputs = {name: _profile(ctx, t.raw[name], t.key(name), unit) for name, unit in _UNITS.items() if t.has(name)}
    for given, other in (("insertion", "force"), ("rotation", "torque")):
        if given in inputs and other in inputs:
            raise ctx.error(t.key(other), f"hub: give {given} or {other}, not both (the {given} is prescribed, or "
                                          f"driven by the {other})")
    for name, driver in (("mass", "force"), ("inertia", "torque")):
        if t.has(name) and driver not in inputs:
            raise ctx.error(t.key(name), f"{t.key(name)}: only a hub driven by a {driver} moves its {name} (give "
                                         f"{t.key(driver)}, or remove it)")
    try:
        hub = Hub(entry=t.get("entry", vec3("m"), tuple(start.positions[node])),
                  axis=t.get("axis", vec3(nonzero=True), tuple(frame[:, 2])), rotation0=frame,
                  mass=t.get("mass", number("kg", nonnegative=True), 0.0),
                  inertia=t.get("inertia", number("kg m^2", nonnegative=True), 0.0), **inputs)
    except SoftrnnInputError as exc:
        if isinstance(exc, ScenarioError):
            raise
        raise ctx.wrap("hub", exc) from None
    return hub.clamp(node)


def with_hub(ctx: _Ctx, boundary: tuple, hub: Clamp | None) -> tuple:
    """``boundary`` with the hub's clamp appended (a node the boundary already holds is refused)."""
    if hub is None:
        return boundary
    for i, bc in enumerate(boundary):
        if bc.node == hub.node:
            raise ctx.invalid("hub.node", hub.node, f"a node not already constrained by boundary.{i}")
    return tuple(boundary) + (hub,)


def check_hub_run(ctx: _Ctx, setup, config) -> None:
    """Refuse the implicit integrator for a hub driven by a force or a torque (its node is a dynamic
    one of the explicit step only)."""
    held = [bc.motion for bc in setup.boundary if isinstance(bc, Clamp) and isinstance(bc.motion, Hub)]
    if held and held[0].driven and isinstance(config.integrator, Implicit):
        raise ctx.invalid("run.integrator", "implicit", "'explicit' with a hub driven by a force or a torque "
                                                        "(hub.force, hub.torque)")
