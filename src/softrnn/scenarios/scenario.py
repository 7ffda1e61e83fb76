"""Scenario files: a simulation described in TOML and loaded into the frozen config classes of the
Python API (``RodSpec``, shapes, ``Clamp``/``Pin``, loads, ``Damping``, ``Setup``, ``RunConfig``).

A scenario names the rod, its reference (stress-free) and initial shapes, the boundary conditions,
the loads, damping and gravity, the saved interval and duration (or sample count), the solver
sub-steps, the nodes of interest and a seed; an optional ``[randomize]`` table declares which values
a sweep varies and how (``Scenario.variant(i)``). The format is documented in
docs/scenario-format.md. The paper's cases and their generalisation variants ship inside the
package (``SCENARIO_NAMES``, files in ``softrnn/scenarios/``).

Every problem found on load is a one-line ``ScenarioError`` (a ``SoftrnnInputError``) that starts
with the file (or ``builtin:NAME``) and names the key and what was expected.
"""

from __future__ import annotations

import copy
import difflib
import math
import tomllib
from dataclasses import dataclass, field
from importlib import resources
from pathlib import Path

import numpy as np

from ..errors import SoftrnnInputError, bad
from .paths import Figure8Path, PoseMotion, PositionPath, RandomSmoothPath, Sum
from ..rod.boundary import Clamp, Pin
from ..rod.loads import CirclePath, Constant, NodalLoad, PDTracking, Sampled, Sinusoid, SquarePath, Window
from ..rod.shapes import RodShape, arc, ellipse, ellipse_perimeter, polyline, straight
from ..rod.simulation import Damping, RunConfig, Setup
from ..rod.spec import NodeOverride, RodSpec

SCENARIO_NAMES: tuple[str, ...] = ("ellipse", "ellipse-horizontal", "square", "square-circle", "square-figure8",
                                   "square-random", "semicircle", "semicircle-cosine")
FORMAT_VERSION = 1
BUILTIN_PREFIX = "builtin:"
DISTRIBUTIONS = ("uniform", "normal", "loguniform", "integers", "choice")


class ScenarioError(SoftrnnInputError):
    """A bad scenario file: ``source`` (file or builtin name) and ``key`` (dotted, '' for the file)."""

    def __init__(self, source: str, key: str, message: str):
        super().__init__(f"{source}: {_one_line(message)}")
        self.source = source
        self.key = key


def _one_line(text: str) -> str:
    return " ".join(str(text).split())


def _show(value) -> str:
    """A short rendering of a value for messages (strings quoted, long values cut)."""
    text = repr(value) if isinstance(value, str) else _toml_like(value)
    return text if len(text) <= 60 else text[:57] + "..."


def _toml_like(value) -> str:
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, dict):
        return "{" + ", ".join(f"{k} = {_toml_like(v)}" for k, v in value.items()) + "}"
    if isinstance(value, (list, tuple)):
        return "[" + ", ".join(_toml_like(v) for v in value) + "]"
    if isinstance(value, str):
        return repr(value)
    return str(value)


# --------------------------------------------------------------------------- reading helpers
_MISSING = object()


class _Ctx:
    """Where errors point: the source, and the folder that relative file names are read from."""

    def __init__(self, source: str, base):
        self.source = source
        self.base = base  # a pathlib.Path or an importlib.resources Traversable, or None

    def error(self, key: str, message: str) -> ScenarioError:
        return ScenarioError(self.source, key, message)

    def invalid(self, key: str, value, expected: str) -> ScenarioError:
        return self.error(key, f"{key} = {_show(value)} is invalid: expected {expected}")

    def wrap(self, key: str, exc: Exception) -> ScenarioError:
        """Re-raise an API validation error with the file and the key in front."""
        return self.error(key, f"{key}: {exc}")


def _join(path: str, key) -> str:
    return f"{path}.{key}" if path else str(key)


class _Table:
    """A TOML table checked against its allowed keys; values are read with converters."""

    def __init__(self, ctx: _Ctx, raw, path: str, keys: dict[str, str]):
        if not isinstance(raw, dict):
            raise ctx.invalid(path, raw, "a table {key = value, ...}")
        self.ctx, self.raw, self.path, self.keys = ctx, raw, path, keys
        for k in raw:
            if k not in keys:
                hint = difflib.get_close_matches(k, list(keys), n=1)
                also = f"; did you mean '{hint[0]}'?" if hint else ""
                raise ctx.error(_join(path, k), f"unknown key '{_join(path, k)}' "
                                                f"(expected one of: {', '.join(keys)}{also})")

    def key(self, name: str) -> str:
        return _join(self.path, name)

    def has(self, name: str) -> bool:
        return name in self.raw

    def raw_value(self, name: str):
        """The value as written (for nested tables read by their own reader); missing is an error."""
        return self.get(name, _as_is)

    def get(self, name: str, conv, default=_MISSING):
        if name not in self.raw:
            if default is _MISSING:
                raise self.ctx.error(self.key(name), f"missing key '{self.key(name)}' ({self.keys[name]})")
            return default
        return conv(self.ctx, self.key(name), self.raw[name])


def _as_is(ctx, key, x):
    return x


def _is_number(x) -> bool:
    return isinstance(x, (int, float)) and not isinstance(x, bool)


def number(unit: str = "", *, positive=False, nonnegative=False):
    what = "a positive number" if positive else "a number >= 0" if nonnegative else "a number"
    what += f" in {unit}" if unit else ""

    def conv(ctx, key, x):
        if not _is_number(x) or not math.isfinite(x) or (positive and x <= 0) or (nonnegative and x < 0):
            raise ctx.invalid(key, x, what)
        return float(x)
    return conv


def integer(minimum: int | None = None, what: str = "an integer"):
    def conv(ctx, key, x):
        if isinstance(x, bool) or not isinstance(x, int) or (minimum is not None and x < minimum):
            raise ctx.invalid(key, x, what)
        return x
    return conv


def string(choices: tuple[str, ...] | None = None, what: str = "a string"):
    def conv(ctx, key, x):
        if not isinstance(x, str) or (choices is not None and x not in choices):
            expected = f"one of {', '.join(repr(c) for c in choices)}" if choices else what
            raise ctx.invalid(key, x, expected)
        return x
    return conv


def boolean(ctx, key, x):
    if not isinstance(x, bool):
        raise ctx.invalid(key, x, "true or false")
    return x


def vec3(unit: str = "", nonzero=False):
    what = "a " + ("nonzero " if nonzero else "") + "3-vector [x, y, z] of numbers" + (f" in {unit}" if unit else "")

    def conv(ctx, key, x):
        if (not isinstance(x, list) or len(x) != 3 or not all(_is_number(c) and math.isfinite(c) for c in x)
                or (nonzero and not any(x))):
            raise ctx.invalid(key, x, what)
        return tuple(float(c) for c in x)
    return conv


def numbers(unit: str = "", min_len: int = 1):
    what = f"a list of at least {min_len} number{'s' if min_len > 1 else ''}" + (f" in {unit}" if unit else "")

    def conv(ctx, key, x):
        if not isinstance(x, list) or len(x) < min_len or not all(_is_number(c) and math.isfinite(c) for c in x):
            raise ctx.invalid(key, x, what)
        return np.array(x, dtype=float)
    return conv


def rows3(unit: str = ""):
    what = "a list of [x, y, z] rows of numbers" + (f" in {unit}" if unit else "")

    def conv(ctx, key, x):
        if not isinstance(x, list) or not x or not all(
                isinstance(r, list) and len(r) == 3 and all(_is_number(c) and math.isfinite(c) for c in r) for r in x):
            raise ctx.invalid(key, x, what)
        return np.array(x, dtype=float)
    return conv


def table_list(ctx, key, x):
    if not isinstance(x, list) or not all(isinstance(e, dict) for e in x):
        raise ctx.invalid(key, x, "an array of tables ([[...]] entries)")
    return x


def _read_csv(ctx: _Ctx, key: str, name, columns: int) -> np.ndarray:
    """Rows of ``columns`` numbers from a CSV file relative to the scenario file ('#' comments and
    one header line allowed)."""
    if not isinstance(name, str) or not name:
        raise ctx.invalid(key, name, "a CSV file name relative to the scenario file")
    if ctx.base is None:
        raise ctx.invalid(key, name, "inline values (a scenario given as text has no folder for files)")
    target = Path(name) if Path(name).is_absolute() else ctx.base.joinpath(name)
    try:
        text = target.read_text(encoding="utf-8")
    except (OSError, UnicodeDecodeError) as exc:
        reason = exc.strerror if isinstance(exc, OSError) and exc.strerror else type(exc).__name__
        raise ctx.invalid(key, name, f"a readable UTF-8 CSV file ({reason}: {target})")
    rows = []
    for i, line in enumerate(text.splitlines()):
        line = line.split("#", 1)[0].strip()
        if not line:
            continue
        cells = [c.strip() for c in line.split(",")]
        try:
            values = [float(c) for c in cells]
        except ValueError:
            if not rows and i == 0:
                continue  # a header line
            raise ctx.invalid(key, name, f"numbers only in the CSV rows (line {i + 1}: {line[:40]!r})")
        if len(values) != columns or not all(math.isfinite(v) for v in values):
            raise ctx.invalid(key, name, f"{columns} finite numbers per CSV row (line {i + 1} has {len(values)})")
        rows.append(values)
    if not rows:
        raise ctx.invalid(key, name, "a CSV file with at least one row")
    return np.array(rows, dtype=float)


# --------------------------------------------------------------------------- sections
_TOP_KEYS = {
    "format": f"the format version, {FORMAT_VERSION}",
    "name": "the scenario name",
    "title": "a one-line description",
    "seed": "an integer >= 0 for everything random in the scenario",
    "gravity": "gravity [gx, gy, gz] in m/s^2",
    "paper": "a table: section, key, dataset, role, note",
    "assumptions": "a table of named assumption texts",
    "rod": "the rod table: length, radius, youngs_modulus, density, n_nodes, ...",
    "reference": "the stress-free shape table (kind = straight, arc, ellipse or polyline)",
    "initial": "the initial shape table (default: the reference)",
    "boundary": "[[boundary]] entries (kind = clamp or pin)",
    "loads": "[[loads]] entries (kind = force, torque or pd)",
    "damping": "the damping table: translational, rotational, kelvin_voigt",
    "run": "the run table: dt, duration or n_samples, substeps, nodes_of_interest, ...",
    "randomize": "a table of dotted keys -> distributions for sweeps",
}

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
}
_OVERRIDE_KEYS = {
    "first": "the first node (0-based)", "last": "the last node (inclusive)", "radius": "radius in m",
    "youngs_modulus": "Young's modulus in Pa", "poisson_ratio": "Poisson's ratio", "density": "density in kg/m^3",
}


def _rod(ctx: _Ctx, raw) -> RodSpec:
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
    try:
        return RodSpec(**kwargs, overrides=tuple(overrides))
    except SoftrnnInputError as exc:
        raise ctx.wrap("rod", exc) from None


_SHAPE_KEYS = {
    "straight": {"length": "the length in m (default: rod.length)", "origin": "the first node [x, y, z] in m",
                 "direction": "the rod direction [x, y, z]", "normal": "the d1 direction hint [x, y, z]"},
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


def _shape(ctx: _Ctx, raw, path: str, rod: RodSpec) -> RodShape:
    if not isinstance(raw, dict):
        raise ctx.invalid(path, raw, "a table with kind = straight, arc, ellipse or polyline")
    kinds = tuple(_SHAPE_KEYS)
    kind = _Table(ctx, {"kind": raw["kind"]} if "kind" in raw else {}, path, {"kind": "the shape kind: " + ", ".join(kinds)}
                  ).get("kind", string(kinds))
    t = _Table(ctx, raw, path, {"kind": "the shape kind", **_SHAPE_KEYS[kind]})
    n = rod.n_nodes
    try:
        if kind == "straight":
            kw = {}
            for name in ("origin", "direction", "normal"):
                if t.has(name):
                    kw[name] = t.get(name, vec3("m" if name == "origin" else "", nonzero=name != "origin"))
            return straight(n, t.get("length", number("m", positive=True), rod.length), **kw)
        if kind == "arc":
            length = t.get("length", number("m", positive=True), rod.length)
            if t.has("radius") == t.has("angle_deg"):
                raise ctx.error(path, f"{path}: give exactly one of radius (m) or angle_deg (degrees) for an arc")
            if t.has("radius"):
                radius = t.get("radius", number("m", positive=True))
            else:
                angle = t.get("angle_deg", number("degrees", positive=True))
                radius = length / (np.pi * (angle / 180.0))
            kw = {}
            for name in ("origin", "tangent", "inward"):
                if t.has(name):
                    kw[name] = t.get(name, vec3("m" if name == "origin" else "", nonzero=name != "origin"))
            return arc(n, length, radius, **kw)
        if kind == "ellipse":
            width = t.get("width", number("m", positive=True))
            height = t.get("height", number("m", positive=True))
            if t.get("fit_length", boolean, False):
                scale = rod.length / ellipse_perimeter(width, height)
                width, height = width * scale, height * scale
            kw = {"origin": t.get("origin", vec3("m"))} if t.has("origin") else {}
            return ellipse(n, width, height, **kw)
        # polyline
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
    except ScenarioError:
        raise
    except (ValueError, ArithmeticError) as exc:  # SoftrnnInputError from the API, or bad numbers
        raise ctx.wrap(path, exc) from None


_PROFILE_KEYS = {
    "constant": {"value": "the value [x, y, z]"},
    "sinusoid": {"amplitude": "the amplitude [x, y, z]", "frequency": "the frequency in Hz",
                 "phase": "the phase in rad (default 0)", "offset": "a constant offset [x, y, z] (default 0)"},
    "sampled": {"times": "strictly increasing times in s", "values": "one [x, y, z] row per time",
                "file": "a CSV file of t, x, y, z rows (instead of times/values)",
                "interpolation": "'linear' (default) or 'hold'"},
    "piecewise": {"times": "strictly increasing times in s", "values": "one [x, y, z] row per time, held until the next",
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


def _profile(ctx: _Ctx, raw, path: str):
    """A time function t (K,) -> (K, 3) from a profile table."""
    kinds = tuple(_PROFILE_KEYS)
    if not isinstance(raw, dict):
        raise ctx.invalid(path, raw, "a profile table with kind = " + ", ".join(kinds))
    kind = _Table(ctx, {"kind": raw["kind"]} if "kind" in raw else {}, path,
                  {"kind": "the profile kind: " + ", ".join(kinds)}).get("kind", string(kinds))
    t = _Table(ctx, raw, path, {"kind": "the profile kind", **_PROFILE_KEYS[kind]})
    try:
        if kind == "constant":
            return Constant(t.get("value", vec3()))
        if kind == "sinusoid":
            return Sinusoid(t.get("amplitude", vec3()), t.get("frequency", number("Hz")),
                            phase=t.get("phase", number("rad"), 0.0),
                            offset=t.get("offset", vec3(), (0.0, 0.0, 0.0)))
        if kind in ("sampled", "piecewise"):
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
    except ScenarioError:
        raise
    except (ValueError, ArithmeticError) as exc:  # SoftrnnInputError from the API, or bad numbers
        raise ctx.wrap(path, exc) from None


def _node(n: int):
    def conv(ctx, key, x):
        if isinstance(x, bool) or not isinstance(x, int) or not -n <= x < n:
            raise ctx.invalid(key, x, f"a node index in [-{n}, {n - 1}] (the rod has {n} nodes; "
                                      "0-based, negative counts from the end)")
        return x % n
    return conv


def _nodes(n: int):
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
    out = []
    for i, raw in enumerate(entries):
        path = f"boundary.{i}"
        if not isinstance(raw, dict):
            raise ctx.invalid(path, raw, "a table with kind = clamp or pin")
        kind = _Table(ctx, {"kind": raw["kind"]} if "kind" in raw else {}, path,
                      {"kind": "the boundary kind: clamp or pin"}).get("kind", string(("clamp", "pin")))
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
    "torque": {"node": "the node index", "profile": "the torque profile in N m", "frame": "'world' (default) or 'body'"},
    "pd": {"node": "the node index", "target": "the target path profile in m", "stiffness": "the P gain in N/m",
           "damping": "the D gain in N s/m (default 0)"},
}


def _loads(ctx: _Ctx, entries, n: int) -> tuple:
    out = []
    for i, raw in enumerate(entries):
        path = f"loads.{i}"
        if not isinstance(raw, dict):
            raise ctx.invalid(path, raw, "a table with kind = force, torque or pd")
        kind = _Table(ctx, {"kind": raw["kind"]} if "kind" in raw else {}, path,
                      {"kind": "the load kind: force, torque or pd"}).get("kind", string(tuple(_LOAD_KEYS)))
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

_RUN_KEYS = {
    "dt": "the saved interval in s",
    "duration": "the simulated time in s (or give n_samples)",
    "n_samples": "the number of saved samples, the first at t = 0 (or give duration)",
    "substeps": "solver steps per saved interval: an integer >= 1 or \"auto\"",
    "save_nodes": "the nodes to save (default: all)",
    "nodes_of_interest": "the nodes reports and figures follow, a list of node indices",
    "safety": "the stability safety factor in (0, 1]",
}


def _run(ctx: _Ctx, raw, rod: RodSpec, damping: Damping) -> tuple[RunConfig, tuple]:
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
    if substeps is not None:
        _check_stability(ctx, rod, damping, dt, substeps, safety)
    kw = {} if safety is None else {"safety": safety}
    try:
        return RunConfig(dt=dt, n_samples=n_samples, substeps=substeps, save_nodes=save, **kw), interest
    except SoftrnnInputError as exc:
        raise ctx.wrap("run", exc) from None


def _check_stability(ctx: _Ctx, rod: RodSpec, damping: Damping, dt: float, substeps: int, safety) -> None:
    """An explicit sub-step count above the rod's stable step is refused here, with the key."""
    try:
        from ..rod.stability import DEFAULT_SAFETY, stable_step
        limit = stable_step(rod.lumped(), rod.segment_length, damping.kelvin_voigt,
                            DEFAULT_SAFETY if safety is None else safety)
    except Exception:  # noqa: BLE001 - the simulator checks again when it runs
        return
    if dt / substeps > limit:
        need = math.ceil(dt / limit)
        raise ctx.invalid("run.substeps", substeps,
                          f"an integer >= {need} or \"auto\": dt/substeps = {dt / substeps:.3g} s exceeds the "
                          f"stable step limit {limit:.3g} s of this rod")


# --------------------------------------------------------------------------- randomisation
def _flatten_randomize(ctx: _Ctx, raw, prefix: str = "") -> dict[str, tuple[str, object]]:
    """{dotted key: (distribution, parameters)}; nested tables (unquoted dotted keys) are flattened."""
    if not isinstance(raw, dict):
        raise ctx.invalid(_join("randomize", prefix) if prefix else "randomize", raw,
                          "a table of \"dotted.key\" = {distribution = parameters}")
    out = {}
    for k, v in raw.items():
        key = _join(prefix, k)
        if isinstance(v, dict) and len(v) == 1 and next(iter(v)) in DISTRIBUTIONS:
            out[key] = _distribution(ctx, f"randomize.{key}", *next(iter(v.items())))
        elif isinstance(v, dict) and v and not any(d in v for d in DISTRIBUTIONS):
            out.update(_flatten_randomize(ctx, v, key))
        else:
            raise ctx.invalid(f"randomize.{key}", v, "one distribution: {uniform = [lo, hi]}, {normal = [mean, std]}, "
                                                     "{loguniform = [lo, hi]}, {integers = [lo, hi]} or {choice = [...]}")
    return out


def _distribution(ctx: _Ctx, key: str, dist: str, p):
    where = f"{key}.{dist}"
    if dist == "choice":
        if not isinstance(p, list) or not p:
            raise ctx.invalid(where, p, "a non-empty list of values to choose from")
        return dist, p
    if dist == "integers":
        if not (isinstance(p, list) and len(p) == 2 and all(isinstance(x, int) and not isinstance(x, bool) for x in p)
                and p[0] <= p[1]):
            raise ctx.invalid(where, p, "[lo, hi], integers with lo <= hi (both included)")
        return dist, p
    if not (isinstance(p, list) and len(p) == 2 and all(_is_number(x) and math.isfinite(x) for x in p)):
        raise ctx.invalid(where, p, f"[{'mean, std' if dist == 'normal' else 'lo, hi'}], two numbers")
    if dist == "normal" and p[1] < 0:
        raise ctx.invalid(where, p, "[mean, std] with std >= 0")
    if dist in ("uniform", "loguniform") and p[0] > p[1]:
        raise ctx.invalid(where, p, "[lo, hi] with lo <= hi")
    if dist == "loguniform" and p[0] <= 0:
        raise ctx.invalid(where, p, "[lo, hi] with 0 < lo <= hi")
    return dist, [float(x) for x in p]


def _draw(rng: np.random.Generator, dist: str, p):
    if dist == "uniform":
        return float(rng.uniform(p[0], p[1]))
    if dist == "normal":
        return float(rng.normal(p[0], p[1]))
    if dist == "loguniform":
        return float(np.exp(rng.uniform(np.log(p[0]), np.log(p[1]))))
    if dist == "integers":
        return int(rng.integers(p[0], p[1], endpoint=True))
    return copy.deepcopy(p[int(rng.integers(0, len(p)))])  # choice


def _set_path(ctx: _Ctx, doc: dict, dotted: str, value) -> None:
    """Set doc[a][b][0]... = value; every container on the way must exist (the last key of a table
    may be new, e.g. an optional key left at its default)."""
    parts = dotted.split(".")
    if parts[0] in ("randomize", "format", "name", "seed"):
        raise ctx.error(f"randomize.{dotted}", f"randomize: '{dotted}' cannot be randomised")
    node = doc
    for depth, part in enumerate(parts):
        last = depth == len(parts) - 1
        here = ".".join(parts[:depth]) or "the document"
        if isinstance(node, dict):
            if part not in node and not last:
                raise ctx.error(f"randomize.{dotted}",
                                f"randomize: '{dotted}' names no value: {here} has no key '{part}'")
            if last:
                node[part] = value
            else:
                node = node[part]
        elif isinstance(node, list):
            if not part.isdigit() or int(part) >= len(node):
                raise ctx.error(f"randomize.{dotted}", f"randomize: '{dotted}' names no value: {here} is a list of "
                                                       f"{len(node)} entries, '{part}' is not an index in it")
            if last:
                node[int(part)] = value
            else:
                node = node[int(part)]
        else:
            raise ctx.error(f"randomize.{dotted}",
                            f"randomize: '{dotted}' names no value: {here} = {_show(node)} has no entries")


def _sample(ctx: _Ctx, doc: dict, randomize: dict, seed: int, index: int) -> tuple[dict, dict]:
    rng = np.random.default_rng([seed, index])
    data = copy.deepcopy(doc)
    sampled = {}
    for key, (dist, p) in randomize.items():
        value = _draw(rng, dist, p)
        _set_path(ctx, data, key, value)
        sampled[key] = value
    return data, sampled


# --------------------------------------------------------------------------- the scenario
@dataclass(frozen=True, eq=False)
class Scenario:
    """A loaded scenario: the TOML ``text`` and its parsed ``data`` (for a variant: with the sampled
    values substituted), and what they build: ``setup``, ``config``, ``nodes_of_interest``."""

    name: str
    title: str
    source: str
    text: str
    data: dict
    setup: Setup
    config: RunConfig
    nodes_of_interest: tuple[int, ...]
    seed: int
    paper: dict
    variant_index: int | None = None
    sampled: dict = field(default_factory=dict)
    assumptions: dict = field(default_factory=dict)
    randomize: dict = field(default_factory=dict, repr=False)

    @property
    def randomized(self) -> bool:
        """Whether the scenario declares values to randomise (a ``[randomize]`` table)."""
        return bool(self.randomize)

    def variant(self, index: int) -> "Scenario":
        """Variant ``index`` (>= 0): the base scenario with every ``[randomize]`` key drawn from its
        distribution, in the table's order, by ``numpy.random.default_rng([seed, index])``. The same
        scenario text, seed and index always give the same variant."""
        if isinstance(index, bool) or not isinstance(index, (int, np.integer)) or index < 0:
            raise bad("variant index", index, "an integer >= 0")
        if not self.randomized:
            raise ScenarioError(self.source, "randomize",
                                "randomize: this scenario declares nothing to randomise (add a [randomize] table)")
        ctx = _Ctx(self.source, _base_for(self.source))
        doc = _parse_toml(ctx, self.text)
        data, sampled = _sample(ctx, doc, self.randomize, self.seed, int(index))
        try:
            return _build(ctx, self.text, data, variant_index=int(index), sampled=sampled)
        except ScenarioError as exc:
            raise ScenarioError(exc.source, exc.key, f"{str(exc)[len(exc.source) + 2:]} "
                                                     f"(variant {index}, sampled {_show(sampled)})") from None


def _parse_toml(ctx: _Ctx, text: str) -> dict:
    try:
        return tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        raise ctx.error("", f"malformed TOML: {exc}") from None


def _build(ctx: _Ctx, text: str, doc: dict, variant_index: int | None = None, sampled: dict | None = None) -> Scenario:
    top = _Table(ctx, doc, "", _TOP_KEYS)
    fmt = top.get("format", integer(), FORMAT_VERSION)
    if fmt != FORMAT_VERSION:
        raise ctx.invalid("format", fmt, f"{FORMAT_VERSION} (the format this softrnn reads)")
    default_name = ctx.source[len(BUILTIN_PREFIX):] if ctx.source.startswith(BUILTIN_PREFIX) else Path(ctx.source).stem
    name = top.get("name", string(), default_name)
    if not name.strip():
        raise ctx.invalid("name", name, "a non-empty name")
    title = top.get("title", string(), name)
    seed = top.get("seed", integer(0, "an integer >= 0"), 0)
    gravity = top.get("gravity", vec3("m/s^2"), (0.0, 0.0, 0.0))
    paper = top.get("paper", _as_is, {})
    pt = _Table(ctx, paper, "paper", {"section": "the paper's section, e.g. \"4.2\"",
                                      "key": "the key of the paper's results (softrnn/data/paper_results.json)",
                                      "dataset": "the paper's data-set name", "role": "\"training\" or \"generalisation\"",
                                      "note": "free text"})
    for k in pt.raw:
        pt.get(k, string())
    assumptions = top.get("assumptions", _as_is, {})
    at = _Table(ctx, assumptions, "assumptions", {k: "text" for k in assumptions} if isinstance(assumptions, dict) else {})
    for k in at.raw:
        at.get(k, string())

    rod = _rod(ctx, top.raw_value("rod"))
    reference = _shape(ctx, top.raw_value("reference"), "reference", rod)
    initial = _shape(ctx, doc["initial"], "initial", rod) if "initial" in doc else None
    if initial is not None:
        arc_len = initial.arc_length()
        if abs(arc_len / rod.length - 1.0) > 0.05:
            raise ctx.invalid("initial", f"a shape of arc length {arc_len:.4g} m",
                              f"an initial shape within 5% of rod.length = {rod.length:.4g} m "
                              "(the rod would start stretched; use fit_length = true for an ellipse)")
    start = initial if initial is not None else reference
    boundary = _boundary(ctx, top.get("boundary", table_list, []), start, rod.n_nodes)
    loads = _loads(ctx, top.get("loads", table_list, []), rod.n_nodes)
    dt_ = _Table(ctx, top.get("damping", _as_is, {}), "damping", _DAMPING_KEYS)
    try:
        damping = Damping(**{k: dt_.get(k, number(nonnegative=True)) for k in dt_.raw})
    except SoftrnnInputError as exc:
        raise ctx.wrap("damping", exc) from None
    try:
        setup = Setup(rod=rod, reference=reference, initial=initial, boundary=boundary, loads=loads,
                      damping=damping, gravity=gravity)
    except SoftrnnInputError as exc:
        raise ctx.wrap("reference" if "reference" in str(exc) else "setup", exc) from None
    config, interest = _run(ctx, top.raw_value("run"), rod, damping)
    randomize = _flatten_randomize(ctx, top.get("randomize", _as_is, {}))
    return Scenario(name=name, title=title, source=ctx.source, text=text, data=doc, setup=setup, config=config,
                    nodes_of_interest=interest, seed=seed, paper=dict(paper), variant_index=variant_index,
                    sampled=dict(sampled or {}), assumptions=dict(assumptions), randomize=randomize)


def _builtin_dir():
    return resources.files("softrnn").joinpath("scenarios")


def _base_for(source: str):
    """The folder relative file names in a scenario are read from."""
    if source.startswith(BUILTIN_PREFIX):
        return _builtin_dir()
    if source.startswith("<"):
        return Path.cwd()
    return Path(source).parent


def parse_scenario(text: str, source: str = "<string>") -> Scenario:
    """A scenario from TOML ``text``; ``source`` (a path, ``builtin:NAME`` or ``<string>``) prefixes
    every error and locates relative file names. A randomised scenario also builds its variant 0 as
    a check, so a bad ``[randomize]`` key is reported on load."""
    if not isinstance(text, str):
        raise bad("text", type(text).__name__, "the TOML text as a str")
    ctx = _Ctx(str(source), _base_for(str(source)))
    doc = _parse_toml(ctx, text)
    scenario = _build(ctx, text, doc)
    if scenario.randomized:
        scenario.variant(0)
    return scenario


def scenario_text(name: str) -> str:
    """The TOML text of a shipped scenario."""
    if name not in SCENARIO_NAMES:
        raise bad("scenario", name, f"one of {', '.join(SCENARIO_NAMES)}, or a path to a .toml file")
    return _builtin_dir().joinpath(f"{name}.toml").read_text(encoding="utf-8")


def load_scenario(name_or_path) -> Scenario:
    """A shipped scenario by name (``SCENARIO_NAMES``) or a scenario file by path."""
    s = str(name_or_path)
    if s in SCENARIO_NAMES and not isinstance(name_or_path, Path):
        return parse_scenario(scenario_text(s), BUILTIN_PREFIX + s)
    path = Path(s)
    if path.is_file():
        try:
            text = path.read_bytes().decode("utf-8")
        except OSError as exc:
            raise ScenarioError(s, "", f"cannot read the file: {exc.strerror or exc}") from None
        except UnicodeDecodeError:
            raise ScenarioError(s, "", "malformed TOML: the file is not UTF-8 text") from None
        return parse_scenario(text, s)
    if path.suffix == ".toml" or "/" in s or "\\" in s:
        raise bad("scenario", s, "an existing .toml file (no such file)" if not path.exists()
                  else "a .toml file, not a folder")
    raise bad("scenario", s, f"one of {', '.join(SCENARIO_NAMES)}, or a path to a .toml file")
