"""The ``[[tendons]]`` entries of a scenario: routing, termination and tension profile (or
displacement profile and series stiffness) read into ``softrnn.rod.Tendon`` entries, every value
checked with its key (an offset outside the section, a termination off the rod, a tension profile
that can fall below zero, a displacement without a stiffness)."""

from __future__ import annotations

import math

import numpy as np

from ..errors import SoftrnnInputError
from ..rod.loads import Constant, RandomSmoothPath, Sampled, Sinusoid
from ..rod.spec import RodSpec
from ..rod.tendons import ROUTINGS, Scalar, Tendon
from ._sections import _SCHEDULE_KEY, _scheduled
from .reading import ScenarioError, _Ctx, _Table, integer, number, numbers, string, table_list

_TENDON_KEYS = {
    "name": "the tendon's name (lower-case letters, digits, '_'): the actuation channel tendon_<name>",
    "offset": "[ox, oy]: the offset from the centreline along d1, d2 at the base in m",
    "routing": "'straight' (default) or 'helical'",
    "pitch": "helical routing: the signed arc length of one turn in m (or give turns)",
    "turns": "helical routing: the number of turns up to the termination (or give pitch)",
    "end_node": "the node where the tendon terminates (default: the last node)",
    "end_s": "the termination as an arc length in m (the nearest node; instead of end_node)",
    "tension": "the tension profile table in N (kind = constant, sinusoid, random_smooth, sampled or piecewise)",
    "displacement": "instead of tension: the length pulled in at the servo in m, a number or a profile table "
                    "(kind = constant, sinusoid, random_smooth, sampled or piecewise)",
    "stiffness": "with displacement: the series stiffness of servo and cable in N/m (> 0)",
}
_RAMP = {"ramp": "blend the tension in from 0 over this many seconds (smoothstep, default 0)"}
_TENSION_KEYS = {
    "constant": {"value": "the tension in N (>= 0)"},
    "sinusoid": {"amplitude": "the amplitude in N", "frequency": "the frequency in Hz",
                 "phase": "the phase in rad (default 0)", "offset": "the mean tension in N (>= |amplitude|)"},
    "random_smooth": {"mean": "the mean tension in N (>= amplitude)",
                      "amplitude": "the largest departure from the mean in N",
                      "cutoff": "the highest frequency in Hz", "seed": "an integer >= 0 fixing the profile",
                      "n_modes": "sinusoids in the sum (default 6)"},
    "sampled": {"times": "strictly increasing times in s", "values": "one tension in N (>= 0) per time",
                "interpolation": "'linear' (default) or 'hold'"},
    "piecewise": {"times": "strictly increasing times in s", "values": "one tension in N (>= 0) per time, held"},
}
_PUSH = "a tendon cannot push"
_DISPLACEMENT_KEYS = {
    "constant": {"value": "the displacement in m"},
    "sinusoid": {"amplitude": "the amplitude in m", "frequency": "the frequency in Hz",
                 "phase": "the phase in rad (default 0)", "offset": "the mean displacement in m (default 0)"},
    "random_smooth": {"mean": "the mean displacement in m", "amplitude": "the largest departure from the mean in m",
                      "cutoff": "the highest frequency in Hz", "seed": "an integer >= 0 fixing the profile",
                      "n_modes": "sinusoids in the sum (default 6)"},
    "sampled": {"times": "strictly increasing times in s", "values": "one displacement in m per time",
                "interpolation": "'linear' (default) or 'hold'"},
    "piecewise": {"times": "strictly increasing times in s", "values": "one displacement in m per time, held"},
}
_DISPLACEMENT_RAMP = {"ramp": "blend the displacement in from 0 over this many seconds (smoothstep, default 0)"}


def _ramp(ctx: _Ctx, t: _Table) -> float:
    """The ``ramp`` [s] of a tendon profile table (0 without one); not with a ``schedule``, whose
    ``ramp`` replaces it."""
    if t.has("ramp") and t.has("schedule"):
        raise ctx.error(t.key("ramp"), f"{t.path}: give ramp or schedule, not both (put the ramp in the "
                                       f"schedule: {t.key('schedule')} = {{ramp = ...}})")
    return t.get("ramp", number("s", nonnegative=True), 0.0)


def _tension(ctx: _Ctx, raw, path: str):
    """A tension profile t (K,) -> (K,) [N] whose values can never fall below 0."""
    kinds = tuple(_TENSION_KEYS)
    if not isinstance(raw, dict):
        raise ctx.invalid(path, raw, "a tension profile table with kind = " + ", ".join(kinds))
    kind = _Table(ctx, {"kind": raw["kind"]} if "kind" in raw else {}, path,
                  {"kind": "the tension profile kind: " + ", ".join(kinds)}).get("kind", string(kinds))
    t = _Table(ctx, raw, path, {"kind": "the profile kind", **_TENSION_KEYS[kind], **_RAMP, **_SCHEDULE_KEY})
    ramp = _ramp(ctx, t)
    try:
        return _scheduled(ctx, t, Scalar(_tension_function(ctx, t, kind), ramp=ramp))
    except ScenarioError:
        raise
    except (SoftrnnInputError, ArithmeticError) as exc:
        raise ctx.wrap(path, exc) from None


def _tension_function(ctx: _Ctx, t: _Table, kind: str):
    """The vector time function whose first component is the tension of the profile table ``t``."""
    if kind == "constant":
        return Constant((t.get("value", number("N", nonnegative=True)), 0.0, 0.0))
    if kind == "sinusoid":
        amp = t.get("amplitude", number("N"))
        mean = t.get("offset", number("N"), 0.0)
        if mean < abs(amp):
            raise ctx.invalid(t.key("offset"), mean, f"a mean tension >= |amplitude| = {abs(amp):g} N "
                                                     f"(the tension would fall to {mean - abs(amp):g} N; {_PUSH})")
        return Sinusoid((amp, 0.0, 0.0), t.get("frequency", number("Hz")),
                        phase=t.get("phase", number("rad"), 0.0), offset=(mean, 0.0, 0.0))
    if kind == "random_smooth":
        amp = t.get("amplitude", number("N", positive=True))
        mean = t.get("mean", number("N"))
        if mean < amp:
            raise ctx.invalid(t.key("mean"), mean, f"a mean tension >= amplitude = {amp:g} N "
                                                   f"(the tension could fall to {mean - amp:g} N; {_PUSH})")
        return RandomSmoothPath((mean, 0.0, 0.0), amp, t.get("cutoff", number("Hz", positive=True)),
                                t.get("seed", integer(0, "an integer >= 0")),
                                n_modes=t.get("n_modes", integer(1, "an integer in [1, 64]"), 6),
                                u=(1.0, 0.0, 0.0), v=(0.0, 1.0, 0.0), ramp=0.0)
    times = t.get("times", numbers("s"))
    values = t.get("values", numbers("N"))
    if values.size != times.size:
        raise ctx.invalid(t.key("values"), values.tolist(), f"{times.size} values, one per time")
    if np.any(values < 0):
        raise ctx.invalid(t.key("values"), values.tolist(), f"tensions >= 0 in N ({_PUSH})")
    if times.size > 1 and np.any(np.diff(times) <= 0):
        raise ctx.invalid(t.key("times"), times.tolist(), "strictly increasing times in s")
    interp = "hold" if kind == "piecewise" else t.get("interpolation", string(("linear", "hold")), "linear")
    return Sampled(times, values[:, None] * np.array([1.0, 0.0, 0.0]), interpolation=interp)


def _displacement(ctx: _Ctx, raw, path: str):
    """A displacement [m]: a number, or a profile t (K,) -> (K,) [m] (any sign: a negative
    displacement pays the tendon out)."""
    kinds = tuple(_DISPLACEMENT_KEYS)
    if isinstance(raw, (int, float)) and not isinstance(raw, bool):
        return number("m")(ctx, path, raw)
    if not isinstance(raw, dict):
        raise ctx.invalid(path, raw, "a displacement in m, or a displacement profile table with kind = "
                                     + ", ".join(kinds))
    kind = _Table(ctx, {"kind": raw["kind"]} if "kind" in raw else {}, path,
                  {"kind": "the displacement profile kind: " + ", ".join(kinds)}).get("kind", string(kinds))
    t = _Table(ctx, raw, path, {"kind": "the profile kind", **_DISPLACEMENT_KEYS[kind], **_DISPLACEMENT_RAMP,
                                **_SCHEDULE_KEY})
    ramp = _ramp(ctx, t)
    try:
        return _scheduled(ctx, t, Scalar(_displacement_function(t, kind), ramp=ramp))
    except ScenarioError:
        raise
    except (SoftrnnInputError, ArithmeticError) as exc:
        raise ctx.wrap(path, exc) from None


def _displacement_function(t: _Table, kind: str):
    """The vector time function whose first component is the displacement of the profile table ``t``."""
    ctx = t.ctx
    if kind == "constant":
        return Constant((t.get("value", number("m")), 0.0, 0.0))
    if kind == "sinusoid":
        return Sinusoid((t.get("amplitude", number("m")), 0.0, 0.0), t.get("frequency", number("Hz")),
                        phase=t.get("phase", number("rad"), 0.0),
                        offset=(t.get("offset", number("m"), 0.0), 0.0, 0.0))
    if kind == "random_smooth":
        return RandomSmoothPath((t.get("mean", number("m")), 0.0, 0.0), t.get("amplitude", number("m", positive=True)),
                                t.get("cutoff", number("Hz", positive=True)),
                                t.get("seed", integer(0, "an integer >= 0")),
                                n_modes=t.get("n_modes", integer(1, "an integer in [1, 64]"), 6),
                                u=(1.0, 0.0, 0.0), v=(0.0, 1.0, 0.0), ramp=0.0)
    times = t.get("times", numbers("s"))
    values = t.get("values", numbers("m"))
    if values.size != times.size:
        raise ctx.invalid(t.key("values"), values.tolist(), f"{times.size} values, one per time")
    if times.size > 1 and np.any(np.diff(times) <= 0):
        raise ctx.invalid(t.key("times"), times.tolist(), "strictly increasing times in s")
    interp = "hold" if kind == "piecewise" else t.get("interpolation", string(("linear", "hold")), "linear")
    return Sampled(times, values[:, None] * np.array([1.0, 0.0, 0.0]), interpolation=interp)


def _drive(ctx: _Ctx, t: _Table) -> dict:
    """The tendon's drive: {tension: profile}, or {displacement: value or profile, stiffness: N/m}."""
    if t.has("tension") and t.has("displacement"):
        raise ctx.error(t.key("displacement"), f"{t.path}: give tension or displacement, not both (a tendon is "
                                               "pulled with a tension or pulled in by a servo through a stiffness)")
    if t.has("displacement"):
        if not t.has("stiffness"):
            raise ctx.error(t.key("stiffness"), f"missing key '{t.key('stiffness')}' (the series stiffness of servo "
                                                "and cable in N/m, > 0: a tendon driven by a displacement needs it)")
        return {"displacement": _displacement(ctx, t.raw_value("displacement"), t.key("displacement")),
                "stiffness": t.get("stiffness", number("N/m", positive=True))}
    if t.has("stiffness"):
        raise ctx.error(t.key("stiffness"), f"{t.key('stiffness')}: only a tendon driven by a displacement has "
                                            f"a stiffness (give {t.key('displacement')} instead of tension, or "
                                            "remove it)")
    if not t.has("tension"):
        raise ctx.error(t.key("tension"), f"missing key '{t.key('tension')}' ({_TENDON_KEYS['tension']}; or give "
                                          "displacement and stiffness)")
    return {"tension": _tension(ctx, t.raw_value("tension"), t.key("tension"))}


def _end(ctx: _Ctx, t: _Table, rod: RodSpec) -> int:
    """The termination node (1 .. n - 1) from ``end_node`` or ``end_s`` (default: the last node)."""
    n, l = rod.n_nodes, rod.segment_length
    if t.has("end_node") and t.has("end_s"):
        raise ctx.error(t.key("end_s"), f"{t.path}: give end_node or end_s, not both")
    if t.has("end_s"):
        s = t.get("end_s", number("m", positive=True))
        if not l * 0.5 <= s <= rod.length * (1 + 1e-9):
            raise ctx.invalid(t.key("end_s"), s, f"an arc length in [{l / 2:g}, {rod.length:g}] m (on the rod, "
                                                 "beyond the base node)")
        return int(round(s / l))
    if not t.has("end_node"):
        return n - 1
    x = t.raw["end_node"]
    if isinstance(x, bool) or not isinstance(x, int) or not -n <= x < n or x % n == 0:
        raise ctx.invalid(t.key("end_node"), x, f"a node index in [1, {n - 1}] or [-{n - 1}, -1] (the rod has "
                                                f"{n} nodes; the tendon starts at the base node 0)")
    return x % n


def _offset(ctx: _Ctx, t: _Table, rod: RodSpec, end: int) -> tuple[float, float]:
    """The offset [ox, oy] [m], inside the cross-sections of the nodes 0 .. end."""
    raw = t.raw_value("offset")
    if (not isinstance(raw, list) or len(raw) != 2
            or not all(isinstance(c, (int, float)) and not isinstance(c, bool) and math.isfinite(c) for c in raw)):
        raise ctx.invalid(t.key("offset"), raw, "[ox, oy], two numbers in m")
    limit = float(rod.node_properties()["radius"][:end + 1].min())
    size = math.hypot(*raw)
    if size > limit * (1 + 1e-12):
        raise ctx.invalid(t.key("offset"), raw, f"an offset of at most the section radius {limit:g} m from the "
                                                f"centreline (|offset| = {size:.4g} m lies outside the rod)")
    return float(raw[0]), float(raw[1])


def _pitch(ctx: _Ctx, t: _Table, routing: str, end_s: float) -> float | None:
    """The helical pitch [m] from ``pitch`` or ``turns`` (None for straight routing)."""
    given = [k for k in ("pitch", "turns") if t.has(k)]
    if routing == "straight":
        if given:
            raise ctx.error(t.key(given[0]), f"{t.key(given[0])}: only a helical tendon has a {given[0]} "
                                             f"(set {t.key('routing')} = \"helical\" or remove it)")
        return None
    if len(given) != 1:
        raise ctx.error(t.key("pitch"), f"{t.path}: give exactly one of pitch (m per turn) or turns for a "
                                        "helical tendon")
    value = t.get(given[0], number("m" if given[0] == "pitch" else ""))
    if value == 0:
        raise ctx.invalid(t.key(given[0]), value, "a nonzero value (its sign sets the handedness)")
    return value if given[0] == "pitch" else end_s / value


def read_tendons(ctx: _Ctx, entries, rod: RodSpec) -> tuple[Tendon, ...]:
    """The ``[[tendons]]`` entries as ``Tendon`` entries terminated at a node, with distinct names."""
    out, names = [], {}
    for i, raw in enumerate(table_list(ctx, "tendons", entries)):
        path = f"tendons.{i}"
        t = _Table(ctx, raw, path, _TENDON_KEYS)
        name = t.get("name", string())
        if name in names:
            raise ctx.invalid(t.key("name"), name, f"a name not used by tendons.{names[name]}")
        names[name] = i
        end = _end(ctx, t, rod)
        offset = _offset(ctx, t, rod, end)
        routing = t.get("routing", string(ROUTINGS), "straight")
        pitch = _pitch(ctx, t, routing, end * rod.segment_length)
        drive = _drive(ctx, t)
        try:
            out.append(Tendon(name=name, offset=offset, routing=routing, pitch=pitch, end_node=end, **drive))
        except SoftrnnInputError as exc:
            raise ctx.wrap(path, exc) from None
    return tuple(out)
