"""The ``[contact]`` table of a scenario: the contact law's parameters and its ``[[contact.obstacles]]``
entries (plane, sphere, cylinder, vessel, bifurcation, mesh) read into a ``softrnn.rod.contact.Contact``."""

from __future__ import annotations

from functools import lru_cache
from importlib import resources
from pathlib import Path

import numpy as np

from ..errors import SoftrnnInputError
from ..rod.contact import Bifurcation, Contact, Cylinder, MeshVessel, Plane, Sphere, Vessel, load_mesh
from .reading import (
    ScenarioError,
    _Ctx,
    _is_number,
    _read_csv,
    _Table,
    boolean,
    number,
    rows3,
    string,
    table_list,
    vec3,
)

_CONTACT_KEYS = {
    "obstacles": "[[contact.obstacles]] entries (kind = plane, sphere, cylinder, vessel, bifurcation or mesh)",
    "friction": "the Coulomb friction coefficient of the obstacles that set none (>= 0, default 0)",
    "slip_velocity": "the slip velocity of the regularised friction in m/s (> 0, default 1e-4)",
    "stiffness": "the penalty stiffness per length of rod in N/m^2 (default: from penetration)",
    "damping": "the normal damping per length of rod in N s/m^2 (default: critical)",
    "penetration": "the default stiffness' penetration under the reference load, a fraction of the rod radius "
                   "in (0, 1) (default 0.005)",
    "reference_acceleration": "the reference acceleration of the default stiffness in m/s^2 (default: |gravity|)",
    "self_contact": "true: the rod's own segments touch too (frictionless; default false)",
    "implicit": "true: the implicit integrator takes the contact springs into its solve (larger steps; default "
                "false)",
}
_FRICTION = {"friction": "this obstacle's friction coefficient (>= 0; default: contact.friction)"}
_OBSTACLE_KEYS = {
    "plane": {"point": "a point of the plane [x, y, z] in m",
              "normal": "the normal [x, y, z], toward the rod's side"},
    "sphere": {"center": "the centre [x, y, z] in m", "radius": "the radius in m"},
    "cylinder": {"point": "a point of the axis [x, y, z] in m", "axis": "the axis direction [x, y, z]",
                 "radius": "the radius in m"},
    "vessel": {"centreline": "the centreline points [[x, y, z], ...] in m (at least 2)",
               "file": "a CSV file of x, y, z rows: the centreline (instead of centreline)",
               "radius": "the inner radius in m, or a list of radii, one per centreline point"},
    "bifurcation": {"trunk": "the trunk's centreline points [[x, y, z], ...] in m (at least 2; the last one is the "
                             "junction)",
                    "left": "the left branch's centreline points after the junction [[x, y, z], ...] in m",
                    "right": "the right branch's centreline points after the junction [[x, y, z], ...] in m",
                    "radius": "the trunk's inner radius in m, or a list of radii, one per trunk point",
                    "left_radius": "the left branch's inner radius in m, or a list, one per point (default: the "
                                   "trunk's at the junction)",
                    "right_radius": "the right branch's inner radius in m, or a list, one per point (default: the "
                                    "trunk's at the junction)"},
    "mesh": {"file": "a closed surface mesh (STL, OBJ, VTK/VTU, PLY), relative to the scenario file, or a shipped "
                     "mesh's name (mesh-arch.vtu)",
             "units": "the mesh's coordinates' unit, \"m\" or \"mm\"",
             "inlet": "a point [x, y, z] in m in the lumen where its centreline starts (default: on the axis "
                      "near an end of its longest path)",
             "cell": "the contact's seed-grid cell in m (default: 2 mean edge lengths)"},
}
KINDS = tuple(_OBSTACLE_KEYS)


def read_contact(ctx: _Ctx, raw) -> Contact:
    """The ``[contact]`` table as a ``Contact`` (every key checked; API errors name the table)."""
    t = _Table(ctx, raw, "contact", _CONTACT_KEYS)
    self_contact = t.get("self_contact", boolean, False)
    entries = t.get("obstacles", table_list, []) if self_contact else t.get("obstacles", table_list)
    if not entries and not self_contact:
        raise ctx.invalid("contact.obstacles", entries, "at least one [[contact.obstacles]] entry (or self_contact "
                                                        "= true)")
    obstacles = tuple(_obstacle(ctx, o, f"contact.obstacles.{i}") for i, o in enumerate(entries))
    kw = {"friction": t.get("friction", number(nonnegative=True), 0.0), "self_contact": self_contact}
    if t.has("implicit"):
        kw["implicit"] = t.get("implicit", boolean)
    for name, conv in (("slip_velocity", number("m/s", positive=True)),
                       ("stiffness", number("N/m^2", positive=True)),
                       ("damping", number("N s/m^2", nonnegative=True)),
                       ("reference_acceleration", number("m/s^2", positive=True))):
        if t.has(name):
            kw[name] = t.get(name, conv)
    if t.has("penetration"):
        p = t.get("penetration", number())
        if not 0 < p < 1:
            raise ctx.invalid("contact.penetration", p, "a fraction of the rod radius in (0, 1), e.g. 0.005")
        kw["penetration"] = p
    try:
        return Contact(obstacles=obstacles, **kw)
    except SoftrnnInputError as exc:
        raise ctx.wrap("contact", exc) from None


def _obstacle(ctx: _Ctx, raw, path: str):
    """One ``[[contact.obstacles]]`` entry as a ``Plane``, ``Sphere``, ``Cylinder``, ``Vessel``,
    ``Bifurcation`` or ``MeshVessel``."""
    if not isinstance(raw, dict):
        raise ctx.invalid(path, raw, "a table with kind = " + ", ".join(KINDS))
    kind = _Table(ctx, {"kind": raw["kind"]} if "kind" in raw else {}, path,
                  {"kind": "the obstacle kind: " + ", ".join(KINDS)}).get("kind", string(KINDS))
    t = _Table(ctx, raw, path, {"kind": "the obstacle kind", **_OBSTACLE_KEYS[kind], **_FRICTION})
    friction = t.get("friction", number(nonnegative=True), None)
    try:
        if kind == "plane":
            return Plane(t.get("point", vec3("m")), t.get("normal", vec3(nonzero=True)), friction=friction)
        if kind == "sphere":
            return Sphere(t.get("center", vec3("m")), t.get("radius", number("m", positive=True)), friction=friction)
        if kind == "cylinder":
            return Cylinder(t.get("point", vec3("m")), t.get("axis", vec3(nonzero=True)),
                            t.get("radius", number("m", positive=True)), friction=friction)
        if kind == "bifurcation":
            return _bifurcation(ctx, t, friction)
        if kind == "mesh":
            return _mesh(ctx, t, friction)
        points, radius = _vessel(ctx, t)
        return Vessel(points, radius, friction=friction)
    except ScenarioError:
        raise
    except (SoftrnnInputError, ArithmeticError) as exc:
        raise ctx.wrap(path, exc) from None


def _vessel(ctx: _Ctx, t: _Table) -> tuple[np.ndarray, float | np.ndarray]:
    """A vessel's centreline points (m, 3) [m] (inline or from a CSV file) and its radius [m] (a
    number or (m,) radii)."""
    if t.has("centreline") == t.has("file"):
        raise ctx.error(t.key("centreline"), f"{t.path}: give exactly one of centreline (inline points) or file "
                                             "(a CSV file of x, y, z rows) for a vessel")
    key = t.key("centreline") if t.has("centreline") else t.key("file")
    points = t.get("centreline", rows3("m")) if t.has("centreline") else _read_csv(ctx, key, t.raw["file"], 3)
    m = len(points)
    if m < 2:
        raise ctx.invalid(key, f"{m} point", "at least 2 centreline points [[x, y, z], ...] in m")
    steps = np.linalg.norm(np.diff(points, axis=0), axis=1)
    if np.any(steps <= 0):
        i = int(np.argmin(steps))
        raise ctx.invalid(key, f"points {i} and {i + 1} at the same place", "distinct consecutive points")
    return points, _radius(ctx, t, "radius", m, "centreline point")


def _radius(ctx: _Ctx, t: _Table, name: str, m: int, per: str) -> float | np.ndarray:
    """The radius key ``name``: a number [m] or a list of m radii [m], one per ``per``."""
    raw = t.get(name, lambda c, k, x: x)
    if _is_number(raw):
        return number("m", positive=True)(ctx, t.key(name), raw)
    what = f"a radius in m (> 0), or a list of {m} radii in m (> 0), one per {per}"
    if not isinstance(raw, list) or len(raw) != m or not all(_is_number(x) and np.isfinite(x) and x > 0 for x in raw):
        raise ctx.invalid(t.key(name), raw, what)
    return np.array(raw, dtype=float)


def _bifurcation(ctx: _Ctx, t: _Table, friction) -> Bifurcation:
    """A bifurcation entry: the trunk's and branches' centreline points (inline) and radii."""
    lines = {}
    for name, least in (("trunk", 2), ("left", 1), ("right", 1)):
        points = t.get(name, rows3("m"))
        if len(points) < least:
            raise ctx.invalid(t.key(name), f"{len(points)} point", f"at least {least} points [[x, y, z], ...] in m")
        steps = np.linalg.norm(np.diff(points, axis=0), axis=1)
        if np.any(steps <= 0):
            i = int(np.argmin(steps))
            raise ctx.invalid(t.key(name), f"points {i} and {i + 1} at the same place", "distinct consecutive points")
        lines[name] = points
    radius = _radius(ctx, t, "radius", len(lines["trunk"]), "trunk point")
    branch = {f"{side}_radius": _radius(ctx, t, f"{side}_radius", len(lines[side]), f"{side} branch point")
              for side in ("left", "right") if t.has(f"{side}_radius")}
    return Bifurcation(lines["trunk"], lines["left"], lines["right"], radius, friction=friction, **branch)


def _mesh(ctx: _Ctx, t: _Table, friction) -> MeshVessel:
    """A mesh entry: the surface file (relative to the scenario file) read in its stated units."""
    name = t.get("file", string())
    if ctx.base is None and not Path(name).is_absolute():
        raise ctx.invalid(t.key("file"), name, "an absolute path (a scenario given as text has no folder for files)")
    target = Path(name) if Path(name).is_absolute() else Path(str(ctx.base.joinpath(name)))
    shipped = Path(str(resources.files("softrnn").joinpath("scenarios", name)))
    if not target.exists() and Path(name).name == name and shipped.is_file():
        target = shipped                  # a shipped mesh by its name (a copied scenario keeps working)
    units = t.get("units", string(("m", "mm")))
    options = {"inlet": t.get("inlet", vec3("m")) if t.has("inlet") else None,
               "cell": t.get("cell", number("m", positive=True)) if t.has("cell") else None}
    try:
        stat = target.stat()
    except OSError:
        return load_mesh(target, units, friction=friction, where=t.key("file"), **options)
    return _cached_mesh(str(target), stat.st_mtime_ns, stat.st_size, units, friction, options["inlet"],
                        options["cell"], t.key("file"))


@lru_cache(maxsize=4)
def _cached_mesh(path: str, mtime_ns: int, size: int, units: str, friction, inlet, cell, where: str) -> MeshVessel:
    """``load_mesh``, kept for a file read again unchanged (a scenario's variants each read it; the
    ``MeshVessel`` is immutable)."""
    return load_mesh(path, units, friction=friction, inlet=inlet, cell=cell, where=where)


def describe(contact: Contact) -> list[str]:
    """Lines for a scenario summary: the law's parameters and one line per obstacle."""
    law = f"friction {contact.friction:g}, slip velocity {contact.slip_velocity:g} m/s"
    law += (f", stiffness {contact.stiffness:g} N/m^2" if contact.stiffness is not None
            else f", stiffness from penetration {contact.penetration:g} r")
    if contact.damping is not None:
        law += f", damping {contact.damping:g} N s/m^2"
    if contact.reference_acceleration is not None:
        law += f" at {contact.reference_acceleration:g} m/s^2"
    if contact.self_contact:
        law += "; the rod's own segments touch too (frictionless)"
    lines = [f"  contact: {len(contact.obstacles)} obstacle{'s' if len(contact.obstacles) != 1 else ''}; {law}"]
    for i, ob in enumerate(contact.obstacles):
        lines.append(f"    {i}: {_obstacle_text(ob)}" + ("" if ob.friction is None else f", friction {ob.friction:g}"))
    return lines


def _obstacle_text(ob) -> str:
    """One obstacle in words, with its geometry."""
    def v(x):
        return "[" + ", ".join(f"{c:.4g}" for c in x) + "]"
    if isinstance(ob, Plane):
        return f"plane through {v(ob.point)} m, normal {v(ob.normal)}"
    if isinstance(ob, Sphere):
        return f"sphere at {v(ob.center)} m, radius {ob.radius:.4g} m"
    if isinstance(ob, Cylinder):
        return f"cylinder through {v(ob.point)} m, axis {v(ob.axis)}, radius {ob.radius:.4g} m"
    if isinstance(ob, MeshVessel):
        low, high = ob.vertices.min(axis=0), ob.vertices.max(axis=0)
        return (f"mesh {Path(ob.file).name if ob.file else '(arrays)'}: {len(ob.faces)} faces, from {v(low)} to "
                f"{v(high)} m")
    if isinstance(ob, Bifurcation):
        k = ob.trunk_rows - 1
        trunk, (left, right) = ob.trunk, (vessel.points[k:] for vessel in ob.vessels)
        return (f"bifurcation: trunk from {v(trunk[0])} to the junction {v(trunk[-1])} m, length "
                f"{_length(ob.vessels[0].points[:k + 1]):.4g} m, radius {_size(ob.radius)}; left branch to "
                f"{v(ob.left[-1])} m, length {_length(left):.4g} m, radius {_size(ob.left_radius)}; right branch to "
                f"{v(ob.right[-1])} m, length {_length(right):.4g} m, radius {_size(ob.right_radius)}")
    return (f"vessel of {len(ob.centreline)} centreline points from {v(ob.centreline[0])} to "
            f"{v(ob.centreline[-1])} m, length {_length(ob.points):.4g} m, radius {_size(ob.radii)}")


def _length(points: np.ndarray) -> float:
    """Length [m] of a polyline (P, 3) [m]."""
    return float(np.sum(np.linalg.norm(np.diff(points, axis=0), axis=1)))


def _size(radius) -> str:
    """A radius [m] or radii in words: one value, or their range."""
    rad = np.unique(np.atleast_1d(np.asarray(radius, dtype=float)))
    return f"{rad[0]:.4g} m" if rad.size == 1 else f"{rad.min():.4g}-{rad.max():.4g} m"

