"""The sections of a scenario file read into the simulator's configuration classes: ``[rod]``, the
reference and initial shapes, the load and motion profiles, ``[[boundary]]``, ``[[loads]]``,
``[damping]`` and ``[run]``."""

from __future__ import annotations

import math

import numpy as np

from ..errors import SoftrnnInputError
from ..rod.boundary import Clamp, Pin
from ..rod.loads import (
    SCHEDULE_SHAPES,
    CirclePath,
    Constant,
    Figure8Path,
    NodalLoad,
    PDTracking,
    RandomSmoothPath,
    Sampled,
    Scheduled,
    Sinusoid,
    SquarePath,
    Sum,
    Window,
)
from ..rod.shapes import RodShape, arc, curved, ellipse, ellipse_perimeter, polyline, straight
from ..rod.simulation import INTEGRATORS, Damping, RunConfig
from ..rod.spec import NodeOverride, RodSpec
from ..rod.stability import DEFAULT_SAFETY, stable_step
from ._materials import read_bends, read_sections
from .paths import PoseMotion, PositionPath
from .reading import (
    ScenarioError,
    _as_is,
    _Ctx,
    _join,
    _read_csv,
    _Table,
    boolean,
    integer,
    number,
    numbers,
    rows3,
    string,
    table_list,
    vec3,
)

_ROD_KEYS = {
    "length": "the rod length in m, or {ellipse_perimeter = [width, height]}",
    "radius": "the section radius in m",
    "youngs_modulus": "Young's modulus in Pa",
    "density": "the density in kg/m^3",
    "n_nodes": "the number of nodes, an integer >= 2",
    "poisson_ratio": "Poisson's ratio in (-1, 0.5]",
    "shear_modulus": "the shear modulus in Pa (overrides poisson_ratio)",
    "shear_coefficient": "the Timoshenko shear coefficient",
    "overrides": "[[rod.overrides]] entries: first, last and radius/youngs_modulus/poisson_ratio/density",
    "sections": "[[rod.sections]] entries that tile the rod: from/to (m) or from_fraction/to_fraction and "
                "radius/inner_radius/youngs_modulus/poisson_ratio/shear_modulus/density",
}
_OVERRIDE_KEYS = {
    "first": "the first node (0-based)", "last": "the last node (inclusive)", "radius": "radius in m",
    "youngs_modulus": "Young's modulus in Pa", "poisson_ratio": "Poisson's ratio", "density": "density in kg/m^3",
}


def _rod(ctx: _Ctx, raw) -> RodSpec:
    """The ``[rod]`` table as a ``RodSpec`` (with its ``[[rod.overrides]]``)."""
    t = _Table(ctx, raw, "rod", _ROD_KEYS)
    if isinstance(t.raw.get("length"), dict):
        lt = _Table(ctx, t.raw["length"], "rod.length", {"ellipse_perimeter": "[width, height] of an ellipse in m"})
        wh = lt.get("ellipse_perimeter", numbers("m", 2))
        if wh.size != 2 or np.any(wh <= 0):
            raise ctx.invalid("rod.length.ellipse_perimeter", t.raw["length"]["ellipse_perimeter"],
                              "[width, height], two positive sizes in m")
        length = ellipse_perimeter(float(wh[0]), float(wh[1]))
    else:
        length = t.get("length", number("m", positive=True))
    kwargs = dict(length=length, radius=t.get("radius", number("m", positive=True)),
                  youngs_modulus=t.get("youngs_modulus", number("Pa", positive=True)),
                  density=t.get("density", number("kg/m^3", positive=True)),
                  n_nodes=t.get("n_nodes", integer(2, "an integer >= 2 (a rod needs at least one segment)")))
    for name, conv in (("poisson_ratio", number()), ("shear_modulus", number("Pa", positive=True)),
                       ("shear_coefficient", number(positive=True))):
        if t.has(name):
            kwargs[name] = t.get(name, conv)
    overrides = []
    for i, o in enumerate(t.get("overrides", table_list, [])):
        path = f"rod.overrides.{i}"
        ot = _Table(ctx, o, path, _OVERRIDE_KEYS)
        ov = dict(first=ot.get("first", integer(0, "a node index >= 0")),
                  last=ot.get("last", integer(0, "a node index >= 0")))
        for name, unit in (("radius", "m"), ("youngs_modulus", "Pa"), ("density", "kg/m^3")):
            if ot.has(name):
                ov[name] = ot.get(name, number(unit, positive=True))
        if ot.has("poisson_ratio"):
            ov["poisson_ratio"] = ot.get("poisson_ratio", number())
        try:
            overrides.append(NodeOverride(**ov))
        except SoftrnnInputError as exc:
            raise ctx.wrap(path, exc) from None
    if t.has("sections"):
        kwargs["sections"] = read_sections(ctx, t.get("sections", table_list), length, kwargs["radius"])
    try:
        return RodSpec(**kwargs, overrides=tuple(overrides))
    except SoftrnnInputError as exc:
        raise ctx.wrap("rod", exc) from None


_SHAPE_KEYS = {
    "straight": {"length": "the length in m (default: rod.length)", "origin": "the first node [x, y, z] in m",
                 "direction": "the rod direction [x, y, z]", "normal": "the d1 direction hint [x, y, z]",
                 "bends": "[[...bends]] entries: from/to (m) or from_fraction/to_fraction, curvature (1/m) or "
                          "angle_deg, toward_deg (a pre-shaped tip)"},
    "arc": {"length": "the arc length in m (default: rod.length)", "radius": "the arc radius in m",
            "angle_deg": "the angle the arc turns through, in degrees (instead of radius)",
            "origin": "the first node [x, y, z] in m", "tangent": "the tangent at the first node",
            "inward": "the direction from the first node toward the centre"},
    "ellipse": {"width": "the x-extent in m", "height": "the y-extent in m",
                "origin": "the point where both ends meet [x, y, z] in m",
                "fit_length": "true: scale width and height together so the perimeter equals rod.length"},
    "polyline": {"points": "the node positions [[x, y, z], ...] in m", "file": "a CSV file of x, y, z rows",
                 "normal": "the d1 direction hint at the first node"},
}


def _kind(ctx: _Ctx, raw: dict, path: str, kinds: tuple[str, ...], description: str) -> str:
    """The ``kind`` of the table ``raw`` at ``path``, one of ``kinds``; ``description`` for a missing kind."""
    return _Table(ctx, {"kind": raw["kind"]} if "kind" in raw else {}, path, {"kind": description}
                  ).get("kind", string(kinds))


def _shape(ctx: _Ctx, raw, path: str, rod: RodSpec) -> RodShape:
    """The reference or initial shape (``path``) from its table: straight, arc, ellipse or polyline."""
    if not isinstance(raw, dict):
        raise ctx.invalid(path, raw, "a table with kind = straight, arc, ellipse or polyline")
    kinds = tuple(_SHAPE_KEYS)
    kind = _kind(ctx, raw, path, kinds, "the shape kind: " + ", ".join(kinds))
    t = _Table(ctx, raw, path, {"kind": "the shape kind", **_SHAPE_KEYS[kind]})
    try:
        if kind == "straight":
            kw = _vectors(t, ("origin", "direction", "normal"))
            length = t.get("length", number("m", positive=True), rod.length)
            if t.has("bends"):
                return curved(rod.n_nodes, length, read_bends(ctx, t.get("bends", table_list), path, length), **kw)
            return straight(rod.n_nodes, length, **kw)
        if kind == "arc":
            return _arc(ctx, t, path, rod)
        if kind == "ellipse":
            return _ellipse(t, rod)
        return _polyline(ctx, t, path, rod.n_nodes)
    except ScenarioError:
        raise
    except (ValueError, ArithmeticError) as exc:  # SoftrnnInputError from the API, or bad numbers
        raise ctx.wrap(path, exc) from None


def _vectors(t: _Table, names: tuple[str, ...]) -> dict:
    """The vectors among ``names`` that a shape table gives: ``origin`` in m, the others nonzero directions."""
    return {name: t.get(name, vec3("m" if name == "origin" else "", nonzero=name != "origin"))
            for name in names if t.has(name)}


def _arc(ctx: _Ctx, t: _Table, path: str, rod: RodSpec) -> RodShape:
    """An arc from its length and either its radius or the angle it turns through."""
    length = t.get("length", number("m", positive=True), rod.length)
    if t.has("radius") == t.has("angle_deg"):
        raise ctx.error(path, f"{path}: give exactly one of radius (m) or angle_deg (degrees) for an arc")
    if t.has("radius"):
        radius = t.get("radius", number("m", positive=True))
    else:
        angle = t.get("angle_deg", number("degrees", positive=True))
        radius = length / (np.pi * (angle / 180.0))
    return arc(rod.n_nodes, length, radius, **_vectors(t, ("origin", "tangent", "inward")))


def _ellipse(t: _Table, rod: RodSpec) -> RodShape:
    """A closed ellipse, scaled to the rod's length when ``fit_length``."""
    width = t.get("width", number("m", positive=True))
    height = t.get("height", number("m", positive=True))
    if t.get("fit_length", boolean, False):
        scale = rod.length / ellipse_perimeter(width, height)
        width, height = width * scale, height * scale
    kw = {"origin": t.get("origin", vec3("m"))} if t.has("origin") else {}
    return ellipse(rod.n_nodes, width, height, **kw)


def _polyline(ctx: _Ctx, t: _Table, path: str, n: int) -> RodShape:
    """A polyline through one point per node, inline or from a CSV file."""
    if t.has("points") == t.has("file"):
        raise ctx.error(path, f"{path}: give exactly one of points (inline) or file (CSV) for a polyline")
    key = t.key("points") if t.has("points") else t.key("file")
    pts = t.get("points", rows3("m")) if t.has("points") else _read_csv(ctx, key, t.raw["file"], 3)
    if pts.shape[0] != n:
        raise ctx.invalid(key, f"{pts.shape[0]} points", f"{n} points, one per node (rod.n_nodes)")
    gaps = np.linalg.norm(np.diff(pts, axis=0), axis=1)
    if np.any(gaps <= 0):
        i = int(np.argmin(gaps))
        raise ctx.invalid(key, f"nodes {i} and {i + 1} at the same point", "distinct consecutive points")
    normal = t.get("normal", vec3(nonzero=True), (1.0, 0.0, 0.0))
    first = pts[1] - pts[0]
    if abs(np.dot(first, normal)) >= (1 - 1e-9) * np.linalg.norm(first) * np.linalg.norm(normal):
        raise ctx.invalid(t.key("normal"), list(normal), "a d1 hint not parallel to the first segment "
                                                           f"{(first / np.linalg.norm(first)).round(6).tolist()}")
    return polyline(pts, normal=normal)


_PROFILE_KEYS = {
    "constant": {"value": "the value [x, y, z]"},
    "sinusoid": {"amplitude": "the amplitude [x, y, z]", "frequency": "the frequency in Hz",
                 "phase": "the phase in rad (default 0)", "offset": "a constant offset [x, y, z] (default 0)"},
    "sampled": {"times": "strictly increasing times in s", "values": "one [x, y, z] row per time",
                "file": "a CSV file of t, x, y, z rows (instead of times/values)",
                "interpolation": "'linear' (default) or 'hold'"},
    "piecewise": {"times": "strictly increasing times in s",
                  "values": "one [x, y, z] row per time, held until the next",
                  "file": "a CSV file of t, x, y, z rows (instead of times/values)"},
    "window": {"function": "the profile switched on in [start, stop)", "start": "the start time in s",
               "stop": "the stop time in s"},
    "sum": {"terms": "a list of profiles added together"},
    "square": {"center": "the centre [x, y, z] in m", "side": "the side in m", "period": "one lap in s",
               "u": "the first in-plane axis", "v": "the second in-plane axis", "ramp": "the smooth start in s"},
    "circle": {"center": "the centre [x, y, z] in m", "radius": "the radius in m", "period": "one lap in s",
               "u": "the first in-plane axis", "v": "the second in-plane axis", "ramp": "the smooth start in s"},
    "figure8": {"center": "the centre [x, y, z] in m", "width": "the extent along u in m",
                "height": "the extent along v in m", "period": "one figure-eight in s",
                "u": "the first in-plane axis", "v": "the second in-plane axis", "ramp": "the smooth start in s"},
    "random_smooth": {"center": "the centre [x, y, z] in m", "amplitude": "the largest offset per axis in m",
                      "cutoff": "the highest frequency in Hz", "seed": "an integer >= 0 fixing the path",
                      "n_modes": "sinusoids per axis (default 6)", "u": "the first in-plane axis",
                      "v": "the second in-plane axis", "ramp": "the smooth start in s"},
}


_SCHEDULE_KEY = {"schedule": "a table {start, ramp, release, shape}: ramp the profile in from start, "
                            "remove it at release"}
_SCHEDULE_KEYS = {
    "start": "the time in s before which the profile is 0 (default 0)",
    "ramp": "the seconds over which it rises from 0 to full strength after start (default 0: a step)",
    "release": "the time in s from which it is 0 again, a sudden removal (default: never)",
    "shape": "the ramp's shape: 'smooth' (smoothstep, default) or 'linear'",
}


def _scheduled(ctx: _Ctx, t: _Table, function):
    """``function`` wrapped in ``Scheduled`` by the ``schedule`` sub-table of the profile table
    ``t`` (``function`` itself without one): the one reader of schedules, for vector profiles,
    gravity and the tendons' scalar profiles."""
    if not t.has("schedule"):
        return function
    st = _Table(ctx, t.raw_value("schedule"), t.key("schedule"), _SCHEDULE_KEYS)
    start = st.get("start", number("s"), 0.0)
    release = st.get("release", number("s"), None)
    if release is not None and release <= start:
        raise ctx.invalid(st.key("release"), release, f"a time after {st.key('start')} = {start:g} s "
                                                      "(the profile is removed after it starts)")
    try:
        return Scheduled(function, start=start, ramp=st.get("ramp", number("s", nonnegative=True), 0.0),
                         release=release, shape=st.get("shape", string(SCHEDULE_SHAPES), "smooth"))
    except SoftrnnInputError as exc:
        raise ctx.wrap(st.path, exc) from None


def _gravity(ctx: _Ctx, key: str, x):
    """The converter of the top-level ``gravity``: a constant [gx, gy, gz] (m/s^2), or a profile
    table giving gravity over time (a time function t (K,) -> (K, 3))."""
    if isinstance(x, dict):
        return _profile(ctx, x, key)
    if not isinstance(x, list):
        raise ctx.invalid(key, x, "[gx, gy, gz] in m/s^2, or a profile table (kind = constant, ...) in m/s^2")
    return vec3("m/s^2")(ctx, key, x)


def _profile(ctx: _Ctx, raw, path: str):
    """A time function t (K,) -> (K, 3) from a profile table, with its ``schedule``."""
    kinds = tuple(_PROFILE_KEYS)
    if not isinstance(raw, dict):
        raise ctx.invalid(path, raw, "a profile table with kind = " + ", ".join(kinds))
    kind = _kind(ctx, raw, path, kinds, "the profile kind: " + ", ".join(kinds))
    t = _Table(ctx, raw, path, {"kind": "the profile kind", **_PROFILE_KEYS[kind], **_SCHEDULE_KEY})
    return _scheduled(ctx, t, _profile_function(ctx, t, path, kind))


def _profile_function(ctx: _Ctx, t: _Table, path: str, kind: str):
    """The time function of the profile table ``t`` of ``kind`` (without its schedule)."""
    try:
        if kind == "constant":
            return Constant(t.get("value", vec3()))
        if kind == "sinusoid":
            return Sinusoid(t.get("amplitude", vec3()), t.get("frequency", number("Hz")),
                            phase=t.get("phase", number("rad"), 0.0),
                            offset=t.get("offset", vec3(), (0.0, 0.0, 0.0)))
        if kind in ("sampled", "piecewise"):
            return _sampled(ctx, t, path, kind)
        if kind == "window":
            start = t.get("start", number("s"))
            stop = t.get("stop", number("s"))
            if stop <= start:
                raise ctx.invalid(t.key("stop"), stop, f"a time after start = {start} s")
            return Window(_profile(ctx, t.get("function", _as_is), t.key("function")), start, stop)
        if kind == "sum":
            terms = t.get("terms", _as_is)
            if not isinstance(terms, list) or not terms:
                raise ctx.invalid(t.key("terms"), terms, "a non-empty list of profile tables")
            return Sum(tuple(_profile(ctx, f, _join(t.key("terms"), i)) for i, f in enumerate(terms)))
        return _plane_path(t, kind)
    except ScenarioError:
        raise
    except (ValueError, ArithmeticError) as exc:  # SoftrnnInputError from the API, or bad numbers
        raise ctx.wrap(path, exc) from None


def _sampled(ctx: _Ctx, t: _Table, path: str, kind: str) -> Sampled:
    """A sampled profile (interpolated, or held for ``piecewise``) from times and values or a CSV file."""
    if t.has("file"):
        if t.has("times") or t.has("values"):
            raise ctx.error(t.key("file"), f"{path}: give either file or times/values, not both")
        table = _read_csv(ctx, t.key("file"), t.raw["file"], 4)
        times, values = table[:, 0], table[:, 1:]
    else:
        times = t.get("times", numbers("s"))
        values = t.get("values", rows3())
        if values.shape[0] != times.size:
            raise ctx.invalid(t.key("values"), f"{values.shape[0]} rows", f"{times.size} rows, one per time")
    if times.size > 1 and np.any(np.diff(times) <= 0):
        raise ctx.invalid(t.key("file" if t.has("file") else "times"), times.tolist(),
                          "strictly increasing times in s")
    interp = "hold" if kind == "piecewise" else t.get("interpolation", string(("linear", "hold")), "linear")
    return Sampled(times, values, interpolation=interp)


def _plane_path(t: _Table, kind: str):
    """A target path in the plane of ``u`` and ``v``: square, circle, figure8 or random_smooth."""
    plane = {}
    for name in ("u", "v"):
        if t.has(name):
            plane[name] = t.get(name, vec3(nonzero=True))
    plane["ramp"] = t.get("ramp", number("s", nonnegative=True), 1.0)
    center = t.get("center", vec3("m"))
    if kind == "square":
        return SquarePath(center, t.get("side", number("m", positive=True)),
                          t.get("period", number("s", positive=True)), **plane)
    if kind == "circle":
        return CirclePath(center, t.get("radius", number("m", positive=True)),
                          t.get("period", number("s", positive=True)), **plane)
    if kind == "figure8":
        return Figure8Path(center, t.get("width", number("m", positive=True)),
                           t.get("height", number("m", positive=True)),
                           t.get("period", number("s", positive=True)), **plane)
    # random_smooth
    return RandomSmoothPath(center, t.get("amplitude", number("m", positive=True)),
                            t.get("cutoff", number("Hz", positive=True)),
                            t.get("seed", integer(0, "an integer >= 0")),
                            n_modes=t.get("n_modes", integer(1, "an integer in [1, 64]"), 6), **plane)


def _node(n: int):
    """A converter to a node index of an ``n``-node rod (negative counts from the end)."""
    def conv(ctx, key, x):
        if isinstance(x, bool) or not isinstance(x, int) or not -n <= x < n:
            raise ctx.invalid(key, x, f"a node index in [-{n}, {n - 1}] (the rod has {n} nodes; "
                                      "0-based, negative counts from the end)")
        return x % n
    return conv


def _nodes(n: int):
    """A converter to a non-empty tuple of node indices of an ``n``-node rod."""
    one = _node(n)

    def conv(ctx, key, x):
        if not isinstance(x, list) or not x:
            raise ctx.invalid(key, x, "a non-empty list of node indices")
        return tuple(one(ctx, _join(key, i), a) for i, a in enumerate(x))
    return conv


_BOUNDARY_KEYS = {
    "clamp": {"node": "the node index", "displacement": "a profile: displacement from the initial position in m",
              "rotation": "a profile: rotation vector (axis * angle, rad, world frame) applied to the initial frame"},
    "pin": {"node": "the node index", "displacement": "a profile: displacement from the initial position in m"},
}


def _boundary(ctx: _Ctx, entries, initial: RodShape, n: int) -> tuple:
    """The ``[[boundary]]`` entries as ``Clamp``/``Pin`` (moving with a profile), at most one per node."""
    out = []
    for i, raw in enumerate(entries):
        path = f"boundary.{i}"
        if not isinstance(raw, dict):
            raise ctx.invalid(path, raw, "a table with kind = clamp or pin")
        kind = _kind(ctx, raw, path, ("clamp", "pin"), "the boundary kind: clamp or pin")
        t = _Table(ctx, raw, path, {"kind": "clamp or pin", **_BOUNDARY_KEYS[kind]})
        node = t.get("node", _node(n))
        disp = _profile(ctx, t.raw["displacement"], t.key("displacement")) if t.has("displacement") else None
        try:
            if kind == "clamp":
                rot = _profile(ctx, t.raw["rotation"], t.key("rotation")) if t.has("rotation") else None
                motion = None if disp is None and rot is None else PoseMotion(
                    tuple(initial.positions[node]), initial.rotations[node], disp, rot)
                out.append(Clamp(node, motion=motion))
            else:
                path_fn = None if disp is None else PositionPath(tuple(initial.positions[node]), disp)
                out.append(Pin(node, path=path_fn))
        except SoftrnnInputError as exc:
            raise ctx.wrap(path, exc) from None
    seen = {}
    for i, bc in enumerate(out):
        if bc.node in seen:
            raise ctx.invalid(f"boundary.{i}.node", bc.node,
                              f"a node not already constrained by boundary.{seen[bc.node]}")
        seen[bc.node] = i
    return tuple(out)


_LOAD_KEYS = {
    "force": {"node": "the node index", "profile": "the force profile in N", "frame": "'world' (default) or 'body'"},
    "torque": {"node": "the node index", "profile": "the torque profile in N m",
               "frame": "'world' (default) or 'body'"},
    "pd": {"node": "the node index", "target": "the target path profile in m", "stiffness": "the P gain in N/m",
           "damping": "the D gain in N s/m (default 0)"},
}


def _loads(ctx: _Ctx, entries, n: int) -> tuple:
    """The ``[[loads]]`` entries as ``NodalLoad`` (force or torque) and ``PDTracking``."""
    out = []
    for i, raw in enumerate(entries):
        path = f"loads.{i}"
        if not isinstance(raw, dict):
            raise ctx.invalid(path, raw, "a table with kind = force, torque or pd")
        kind = _kind(ctx, raw, path, tuple(_LOAD_KEYS), "the load kind: force, torque or pd")
        t = _Table(ctx, raw, path, {"kind": "force, torque or pd", **_LOAD_KEYS[kind]})
        node = t.get("node", _node(n))
        try:
            if kind == "pd":
                target = _profile(ctx, t.raw_value("target"), t.key("target"))
                out.append(PDTracking(node, target, stiffness=t.get("stiffness", number("N/m", positive=True)),
                                      damping=t.get("damping", number("N s/m", nonnegative=True), 0.0)))
            else:
                fn = _profile(ctx, t.raw_value("profile"), t.key("profile"))
                frame = t.get("frame", string(("world", "body")), "world")
                out.append(NodalLoad(node, force=fn, frame=frame) if kind == "force"
                           else NodalLoad(node, torque=fn, frame=frame))
        except ScenarioError:
            raise
        except SoftrnnInputError as exc:
            raise ctx.wrap(path, exc) from None
    return tuple(out)


_DAMPING_KEYS = {"translational": "viscous drag per length in N s/m^2",
                 "rotational": "rotational drag per length in N s", "kelvin_voigt": "retardation time in s"}


def read_damping(ctx: _Ctx, raw) -> Damping:
    """The ``[damping]`` table (``raw``, a dict) as ``Damping`` (every key checked)."""
    t = _Table(ctx, raw, "damping", _DAMPING_KEYS)
    try:
        return Damping(**{k: t.get(k, number(nonnegative=True)) for k in t.raw})
    except SoftrnnInputError as exc:
        raise ctx.wrap("damping", exc) from None

_RUN_KEYS = {
    "dt": "the saved interval in s",
    "duration": "the simulated time in s (or give n_samples)",
    "n_samples": "the number of saved samples, the first at t = 0 (or give duration)",
    "substeps": "solver steps per saved interval: an integer >= 1 or \"auto\"",
    "save_nodes": "the nodes to save (default: all)",
    "nodes_of_interest": "the nodes reports and figures follow, a list of node indices",
    "safety": "the stability safety factor in (0, 1]",
    "integrator": "the solver: \"explicit\" (default) or \"implicit\" (stiff rods)",
}


def _run(ctx: _Ctx, raw, rod: RodSpec, damping: Damping) -> tuple[RunConfig, tuple]:
    """The ``[run]`` table: the ``RunConfig`` and the nodes of interest."""
    t = _Table(ctx, raw, "run", _RUN_KEYS)
    n = rod.n_nodes
    dt = t.get("dt", number("s", positive=True))
    if t.has("duration") and t.has("n_samples"):
        raise ctx.error("run.duration", "run: give duration or n_samples, not both")
    if not t.has("duration") and not t.has("n_samples"):
        raise ctx.error("run.duration", "missing key 'run.duration' (the simulated time in s; or give run.n_samples)")
    if t.has("duration"):
        duration = t.get("duration", number("s", positive=True))
        ratio = duration / dt
        n_samples = int(math.ceil(ratio - 1e-9 * max(1.0, ratio))) + 1  # covers the duration
    else:
        n_samples = t.get("n_samples", integer(1, "an integer >= 1"))
    sub = t.raw.get("substeps", "auto")
    if sub == "auto":
        substeps = None
    elif isinstance(sub, int) and not isinstance(sub, bool) and sub >= 1:
        substeps = sub
    else:
        raise ctx.invalid("run.substeps", sub, "an integer >= 1 or \"auto\"")
    safety = t.get("safety", number(), None)
    if safety is not None and not 0 < safety <= 1:
        raise ctx.invalid("run.safety", safety, "a factor in (0, 1]")
    save = t.get("save_nodes", _nodes(n), None)
    interest = t.get("nodes_of_interest", _nodes(n))
    if save is not None:
        for i, a in enumerate(interest):
            if a not in save:
                raise ctx.invalid(f"run.nodes_of_interest.{i}", a, "a node listed in run.save_nodes")
    integrator = t.get("integrator", string(INTEGRATORS), "explicit")
    if substeps is not None and integrator == "explicit":
        _check_stability(ctx, rod, damping, dt, substeps, safety)
    kw = {} if safety is None else {"safety": safety}
    if integrator != "explicit":
        kw["integrator"] = integrator
    try:
        return RunConfig(dt=dt, n_samples=n_samples, substeps=substeps, save_nodes=save, **kw), interest
    except SoftrnnInputError as exc:
        raise ctx.wrap("run", exc) from None


def _check_stability(ctx: _Ctx, rod: RodSpec, damping: Damping, dt: float, substeps: int, safety) -> None:
    """An explicit sub-step count above the rod's stable step is refused here, with the key."""
    try:
        limit = stable_step(rod.lumped(), rod.segment_length, damping.kelvin_voigt,
                            DEFAULT_SAFETY if safety is None else safety)
    except Exception:  # noqa: BLE001 - the simulator checks again when it runs
        return
    if dt / substeps > limit:
        need = math.ceil(dt / limit)
        raise ctx.invalid("run.substeps", substeps,
                          f"an integer >= {need} or \"auto\": dt/substeps = {dt / substeps:.3g} s exceeds the "
                          f"stable step limit {limit:.3g} s of this rod")

