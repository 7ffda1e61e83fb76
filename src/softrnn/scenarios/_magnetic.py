"""The ``[magnetic]`` table of a scenario: the magnetic manipulator instead of a plain rod, read into
a ``MagneticScenario`` (``softrnn.scenarios.magnetic``); the rod tables it cannot use are refused."""

from __future__ import annotations

import numpy as np

from ..errors import SoftrnnInputError
from ..magnetics.manipulator import DEFAULT_DAMPING, BaseAdvance, ManipulatorSpec, currents_for_field
from ._contact import read_contact
from ._sections import read_damping
from .magnetic import MagneticScenario
from .reading import _Ctx, _Table, number, numbers, vec3

MAGNETIC_KEYS = {
    "field_mT": "the field [Bx, By, Bz] in mT at the workspace centre, made by the minimum-norm coil currents "
                "(or give currents)",
    "currents": "the coil currents in A, one per coil (or give field_mT)",
    "start": "the time in s at which the currents start to rise (>= 0, default 0)",
    "ramp": "the rise time in s from zero to the currents, then held (> 0, default 0.5)",
    "settle": "settling in s at zero current before t = 0 (>= 0, default 0.3)",
    "length": "the rod's free length in m (default 0.05)",
    "diameter": "the rod's diameter in m (default 0.003)",
    "youngs_modulus": "the rod's Young's modulus in Pa (default 2.5e6, PMC-770)",
    "density": "the rod's density in kg/m^3 (default 1000)",
    "base": "the clamped base [x, y, z] in m (default [-length/2, 0, 0]); the rod points along +x",
    "advance": "the base's insertion { distance = m, start = s, ramp = s, rotation = rad } along and about +x "
               "(default: none, a fixed base)",
}

ADVANCE_KEYS = {
    "distance": "how far the base advances along +x in m (> 0)",
    "start": "when the advance begins in s (>= 0, default 0)",
    "ramp": "how long the advance takes in s, a smoothstep (> 0, default 1)",
    "rotation": "how far the base turns about its axis meanwhile in rad, as a hub twists a device (default 0)",
}

FORBIDDEN = {
    "rod": "the manipulator builds its own rod with its magnets (set length, diameter, youngs_modulus or density "
           "in [magnetic])",
    "reference": "the manipulator's rod is straight from its base along +x (set magnetic.base)",
    "initial": "the manipulator starts straight at rest and settles for magnetic.settle s",
    "boundary": "the manipulator's base is clamped (set magnetic.base, and magnetic.advance to insert it)",
    "hub": "the manipulator's base is its hub (set magnetic.advance: distance, rotation)",
    "loads": "the coils drive the manipulator (set magnetic.field_mT or magnetic.currents)",
    "tendons": "the manipulator has no tendons; the coils drive it (set magnetic.field_mT or magnetic.currents)",
    "calibrate": "softrnn calibrate fits plain rod scenarios only",
}
"""Top-level keys a magnetic scenario refuses, with the reason."""


def _refuse_rod_tables(ctx: _Ctx, doc: dict) -> None:
    """A one-line error for the first key of ``FORBIDDEN`` in the document."""
    for key, why in FORBIDDEN.items():
        if key in doc:
            raise ctx.error(key, f"{key}: not allowed in a magnetic scenario (one with [magnetic]): {why}")


def check_magnetic_run(ctx: _Ctx, raw) -> None:
    """Refuse the ``[run]`` key a magnetic scenario does not honour (``save_nodes``); the rest
    (the integrator too) is read as for any scenario."""
    if isinstance(raw, dict) and "save_nodes" in raw:
        raise ctx.error("run.save_nodes", "run.save_nodes: not allowed in a magnetic scenario: the manipulator's "
                                          "run saves every node")


def _spec(ctx: _Ctx, t: _Table, doc: dict, gravity) -> ManipulatorSpec:
    """The ``ManipulatorSpec`` of the table's overrides, the scenario's gravity, damping and contact."""
    if not isinstance(gravity, tuple):
        raise ctx.invalid("gravity", "a profile table",
                          "a constant [gx, gy, gz] in m/s^2 in a magnetic scenario (the manipulator's gravity is "
                          "constant)")
    kw = {name: t.get(name, number(unit, positive=True)) for name, unit in
          (("length", "m"), ("diameter", "m"), ("youngs_modulus", "Pa"), ("density", "kg/m^3")) if t.has(name)}
    if t.has("base"):
        kw["base"] = t.get("base", vec3("m"))
    if t.has("advance"):
        kw["advance"] = _advance(ctx, t.raw["advance"])
    damping = read_damping(ctx, doc["damping"]) if "damping" in doc else DEFAULT_DAMPING
    contact = read_contact(ctx, doc["contact"]) if "contact" in doc else None
    try:
        return ManipulatorSpec(gravity=gravity, damping=damping, contact=contact, **kw)
    except SoftrnnInputError as exc:
        text = str(exc)
        key = "magnetic.advance" if text.startswith("advance") else "magnetic"
        raise ctx.wrap("contact" if contact is not None and ("contact" in text or "obstacle" in text)
                       else key, exc) from None


def _advance(ctx: _Ctx, raw) -> BaseAdvance:
    """The ``magnetic.advance`` table as a ``BaseAdvance``, every value checked."""
    a = _Table(ctx, raw, "magnetic.advance", ADVANCE_KEYS)
    return BaseAdvance(distance=a.get("distance", number("m", positive=True)),
                       start=a.get("start", number("s", nonnegative=True), 0.0),
                       ramp=a.get("ramp", number("s", positive=True), 1.0),
                       rotation=a.get("rotation", number("rad"), 0.0))


def _currents(ctx: _Ctx, t: _Table, spec: ManipulatorSpec) -> tuple[np.ndarray, np.ndarray | None]:
    """(the held currents (n_c,) [A], the field (3,) [T] or None) from ``field_mT`` or ``currents``."""
    if t.has("field_mT") == t.has("currents"):
        given = "both field_mT and currents given" if t.has("field_mT") else "neither given"
        raise ctx.error("magnetic.field_mT", f"magnetic.field_mT: {given}: give field_mT (the field in mT) or "
                                             "currents (one per coil in A), exactly one of them")
    coils = spec.coils
    if t.has("field_mT"):
        field = np.array(t.get("field_mT", vec3("mT")), dtype=float) / 1000.0
        try:
            return currents_for_field(coils, (0.0, 0.0, 0.0), field), field
        except SoftrnnInputError as exc:
            raise ctx.wrap("magnetic.field_mT", exc) from None
    currents = t.get("currents", numbers("A"))
    if currents.shape != (coils.n_coils,) or np.max(np.abs(currents)) > coils.current_limit:
        raise ctx.invalid("magnetic.currents", t.raw["currents"],
                          f"{coils.n_coils} currents in A, one per coil, within +/-{coils.current_limit:g} A")
    return currents, None


def read_magnetic(ctx: _Ctx, doc: dict, gravity) -> MagneticScenario:
    """The ``[magnetic]`` table of the document ``doc`` (with its gravity, ``[damping]`` and
    ``[contact]``) as a ``MagneticScenario``; every value checked, the rod tables refused."""
    _refuse_rod_tables(ctx, doc)
    t = _Table(ctx, doc["magnetic"], "magnetic", MAGNETIC_KEYS)
    spec = _spec(ctx, t, doc, gravity)
    currents, field = _currents(ctx, t, spec)
    timing = {"start": t.get("start", number("s", nonnegative=True), 0.0),
              "ramp": t.get("ramp", number("s", positive=True), 0.5),
              "settle": t.get("settle", number("s", nonnegative=True), 0.3)}
    try:
        return MagneticScenario(spec=spec, currents=currents, field=field, **timing)
    except SoftrnnInputError as exc:
        raise ctx.wrap("magnetic", exc) from None
