"""The material table and the bends of a scenario: ``[[rod.sections]]`` (a device of several
materials, ``rod.materials.MaterialSection``) and ``[[reference.bends]]`` (a pre-shaped tip,
``rod.shapes.Bend``), read with their spans along the rod in m or as fractions of its length
(docs/scenario-format.md)."""

from __future__ import annotations

import math

from ..errors import SoftrnnInputError
from ..rod.materials import MaterialSection, check_cover
from ..rod.shapes import Bend
from .reading import _Ctx, _join, _Table, number

_SPAN_KEYS = {
    "from": "the arc length where it starts, in m from node 0 (or from_fraction)",
    "to": "the arc length where it ends, in m (or to_fraction)",
    "from_fraction": "where it starts, as a fraction of rod.length in [0, 1] (instead of from)",
    "to_fraction": "where it ends, as a fraction of rod.length in [0, 1] (instead of to)",
}
SECTION_KEYS = {
    **_SPAN_KEYS,
    "radius": "the outer radius in m (default: rod.radius)",
    "inner_radius": "the inner radius of a tube in m (default 0: solid)",
    "youngs_modulus": "Young's modulus in Pa (default: rod.youngs_modulus)",
    "poisson_ratio": "Poisson's ratio in (-1, 0.5] (default: rod.poisson_ratio)",
    "shear_modulus": "the shear modulus in Pa (default: from youngs_modulus and poisson_ratio)",
    "density": "the density in kg/m^3 (default: rod.density)",
}
BEND_KEYS = {
    **_SPAN_KEYS,
    "curvature": "the rest curvature in 1/m (or angle_deg)",
    "angle_deg": "the angle the bend turns through, in degrees (instead of curvature)",
    "toward_deg": "the direction it bends toward, in degrees from d1 (the shape's normal) toward d2 (default 0)",
}


def _span(ctx: _Ctx, t: _Table, length: float) -> tuple[float, float]:
    """(start, end) [m] of a section or bend table: from/to in m or from_fraction/to_fraction."""
    ends = []
    for name in ("from", "to"):
        frac = f"{name}_fraction"
        if t.has(name) == t.has(frac):
            raise ctx.error(t.key(name), f"{t.path}: give exactly one of {name} (m) or {frac} (a fraction of "
                                         f"rod.length = {length:g} m)")
        if t.has(name):
            ends.append(t.get(name, number("m", nonnegative=True)))
        else:
            f = t.get(frac, number(nonnegative=True))
            if f > 1.0:
                raise ctx.invalid(t.key(frac), f, "a fraction of rod.length in [0, 1]")
            ends.append(f * length)
    if ends[1] <= ends[0]:
        raise ctx.invalid(t.key("to" if t.has("to") else "to_fraction"), t.raw.get("to", t.raw.get("to_fraction")),
                          f"a point beyond where {t.path} starts ({ends[0]:g} m)")
    return ends[0], ends[1]


def read_sections(ctx: _Ctx, entries: list, length: float, radius: float) -> tuple[MaterialSection, ...]:
    """The ``[[rod.sections]]`` entries as ``MaterialSection`` of a rod of ``length`` and ``radius``
    [m]; they must tile [0, length] in order (a one-line error naming the section and the fix
    otherwise)."""
    out, spans = [], []
    for i, raw in enumerate(entries):
        path = _join("rod.sections", i)
        t = _Table(ctx, raw, path, SECTION_KEYS)
        start, end = _span(ctx, t, length)
        spans.append((start, end))
        kw = {name: t.get(name, number(unit, positive=True))
              for name, unit in (("radius", "m"), ("youngs_modulus", "Pa"), ("shear_modulus", "Pa"),
                                 ("density", "kg/m^3")) if t.has(name)}
        if t.has("inner_radius"):
            kw["inner_radius"] = t.get("inner_radius", number("m", nonnegative=True))
            outer = kw.get("radius", radius)
            if kw["inner_radius"] >= outer:
                raise ctx.invalid(t.key("inner_radius"), kw["inner_radius"], f"a radius below the outer radius "
                                                                             f"{outer:g} m (0: a solid section)")
        if t.has("poisson_ratio"):
            kw["poisson_ratio"] = t.get("poisson_ratio", number())
        try:
            out.append(MaterialSection(start=start, end=end, **kw))
        except SoftrnnInputError as exc:
            raise ctx.wrap(path, exc) from None

    def key(i: int, which: str) -> str:
        t = entries[i] if i < len(entries) else {}
        name = "from" if which == "start" else "to"
        return _join(_join("rod.sections", i), name if name in t else f"{name}_fraction * rod.length")

    try:
        check_cover(spans, length, key)
    except SoftrnnInputError as exc:
        where = str(exc).split("=", 1)[0].split(" ", 1)[0]
        raise ctx.error(where, str(exc)) from None
    return tuple(out)


def read_bends(ctx: _Ctx, entries: list, path: str, length: float) -> tuple[Bend, ...]:
    """The ``bends`` entries of the shape table ``path`` as ``Bend`` (curvature in 1/m or the
    angle in degrees) for a rod of ``length`` [m]."""
    out = []
    for i, raw in enumerate(entries):
        where = _join(_join(path, "bends"), i)
        t = _Table(ctx, raw, where, BEND_KEYS)
        start, end = _span(ctx, t, length)
        if t.has("curvature") == t.has("angle_deg"):
            raise ctx.error(t.key("curvature"), f"{where}: give exactly one of curvature (1/m) or angle_deg (degrees)")
        if t.has("curvature"):
            curvature = t.get("curvature", number("1/m", positive=True))
        else:
            curvature = math.radians(t.get("angle_deg", number("degrees", positive=True))) / (end - start)
        if out and start < out[-1].end:
            raise ctx.invalid(t.key("from" if t.has("from") else "from_fraction"), start,
                              f"an arc length >= {out[-1].end:g} m where the bend before it ends (bends in order "
                              "along the rod, not overlapping)")
        if end > length * (1.0 + 1e-9):
            raise ctx.invalid(t.key("to" if t.has("to") else "to_fraction"), end,
                              f"an arc length <= the shape's length {length:g} m")
        try:
            out.append(Bend(start, end, curvature, t.get("toward_deg", number("degrees"), 0.0)))
        except SoftrnnInputError as exc:
            raise ctx.wrap(where, exc) from None
    return tuple(out)
