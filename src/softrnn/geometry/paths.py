"""Time functions and target paths: vectorised functions of time t (K,) [s] -> values (K, 3) (forces
[N], torques [N m], target positions [m] or a gravity [m/s^2]), shared by the simulator (its loads,
``softrnn.rod.loads``, evaluated chunk by chunk ahead of the numba kernels) and the learned models
(a PD law's target, read from a data file's record). ``Scheduled`` ramps any of them (and the scalar
tendon profiles) in from a start time and removes it at a release time.

Every one has a record (``function_record``: a JSON-ready dict with its ``kind`` and arguments;
``function_from_record`` builds it back, docs/dataset-format.md).
"""

from dataclasses import dataclass, field, fields
from typing import Protocol

import numpy as np

from ..errors import bad, finite, is_int, nonnegative, positive, vec3


class AbstractTimeFunction(Protocol):
    """A vectorised time function: times t (K,) [s] -> values (K, 3) (a force [N], torque [N m] or
    position [m])."""

    def __call__(self, t: np.ndarray) -> np.ndarray:  # (K,) -> (K, 3)
        ...


def _plane_axes(name: str, u, v) -> tuple[tuple, tuple]:
    """The in-plane axes u, v of a target path: finite, nonzero 3-vectors."""
    u, v = vec3(f"{name}.u", u), vec3(f"{name}.v", v)
    if np.linalg.norm(u) == 0 or np.linalg.norm(v) == 0:
        raise bad(f"{name}.u/v", (u, v), "nonzero axis vectors")
    return u, v


def _check_plane_path(path, sizes: tuple) -> None:
    """Check a target path in a plane (``center``, the positive fields ``sizes``, ``ramp`` >= 0, the
    axes ``u`` and ``v``) and store its center and axes as tuples."""
    name = type(path).__name__
    object.__setattr__(path, "center", vec3(f"{name}.center", path.center))
    for size in sizes:
        positive(f"{name}.{size}", getattr(path, size))
    nonnegative(f"{name}.ramp", path.ramp)
    u, v = _plane_axes(name, path.u, path.v)
    object.__setattr__(path, "u", u)
    object.__setattr__(path, "v", v)


def _blend(t: np.ndarray, ramp: float) -> np.ndarray:
    """Smoothstep ramp from 0 to 1 over ``ramp`` seconds (1 everywhere for ramp = 0)."""
    return smoothstep(t / ramp) if ramp > 0 else np.ones_like(t)


@dataclass(frozen=True)
class Constant:
    """value (3,) at all times."""

    value: tuple

    def __post_init__(self):
        object.__setattr__(self, "value", vec3("Constant.value", self.value))

    def __call__(self, t):
        return np.broadcast_to(np.asarray(self.value), (np.shape(t)[0], 3)).copy()


@dataclass(frozen=True)
class Sinusoid:
    """offset + amplitude * sin(2 pi frequency t + phase); amplitude, offset (3,), frequency [Hz]."""

    amplitude: tuple
    frequency: float
    phase: float = 0.0
    offset: tuple = (0.0, 0.0, 0.0)

    def __post_init__(self):
        object.__setattr__(self, "amplitude", vec3("Sinusoid.amplitude", self.amplitude))
        object.__setattr__(self, "offset", vec3("Sinusoid.offset", self.offset))
        finite("Sinusoid.frequency", self.frequency)
        finite("Sinusoid.phase", self.phase)

    def __call__(self, t):
        t = np.asarray(t, dtype=float)
        s = np.sin(2 * np.pi * self.frequency * t + self.phase)
        return np.asarray(self.offset) + s[:, None] * np.asarray(self.amplitude)


@dataclass(frozen=True, eq=False)
class Sampled:
    """Values (m, 3) at increasing times (m,), linearly interpolated ('linear') or held from each
    sample to the next ('hold'); zero before the first and after the last sample time."""

    times: np.ndarray
    values: np.ndarray
    interpolation: str = "linear"

    def __post_init__(self):
        t = np.asarray(self.times, dtype=float)
        v = np.asarray(self.values, dtype=float)
        if t.ndim != 1 or t.size < 1 or not np.all(np.isfinite(t)) or np.any(np.diff(t) <= 0):
            raise bad("Sampled.times", self.times, "a 1-D array of strictly increasing finite times in s")
        if v.shape != (t.size, 3) or not np.all(np.isfinite(v)):
            raise bad("Sampled.values.shape", v.shape, f"({t.size}, 3) finite values, one row per time")
        if self.interpolation not in ("linear", "hold"):
            raise bad("Sampled.interpolation", self.interpolation, "'linear' or 'hold'")
        object.__setattr__(self, "times", t)
        object.__setattr__(self, "values", v)

    def __call__(self, t):
        t = np.asarray(t, dtype=float)
        out = np.zeros((t.size, 3))
        inside = (t >= self.times[0]) & (t <= self.times[-1])
        if self.interpolation == "linear":
            for c in range(3):
                out[inside, c] = np.interp(t[inside], self.times, self.values[:, c])
        else:
            idx = np.searchsorted(self.times, t[inside], side="right") - 1
            out[inside] = self.values[idx]
        return out


def Piecewise(times, values) -> Sampled:
    """Piecewise-constant: ``values[i]`` (3,) holds on [times[i], times[i+1]); the last value holds
    at the last time only, so end a load with a zero row."""
    return Sampled(times, values, interpolation="hold")


@dataclass(frozen=True)
class Window:
    """``function`` on [start, stop), zero outside (e.g. a push for 0.5 s)."""

    function: object
    start: float
    stop: float

    def __post_init__(self):
        finite("Window.start", self.start)
        finite("Window.stop", self.stop)
        if self.stop <= self.start:
            raise bad("Window.stop", self.stop, f"a time after start={self.start} s")

    def __call__(self, t):
        t = np.asarray(t, dtype=float)
        on = (t >= self.start) & (t < self.stop)
        return self.function(t) * on[:, None]


def smoothstep(x: np.ndarray) -> np.ndarray:
    """C2 ramp 0 -> 1 on [0, 1]: 6x^5 - 15x^4 + 10x^3."""
    x = np.clip(x, 0.0, 1.0)
    return x * x * x * (x * (6 * x - 15) + 10)


SCHEDULE_SHAPES = ("smooth", "linear")


@dataclass(frozen=True)
class Scheduled:
    """``function`` times a schedule factor w(t): 0 before ``start`` [s], rising to 1 over ``ramp``
    [s] (``shape`` "smooth": the C2 smoothstep; "linear": a straight ramp; ramp 0: a step at
    ``start``), 1 after, and 0 again from ``release`` [s] on (a sudden removal; None: never).

    One implementation for every profile whose values have the time axis first: vector time
    functions (K,) -> (K, 3) (forces, torques, targets, boundary motions, gravity) and scalar tendon
    tension or displacement profiles (K,) -> (K,). A target position or a boundary displacement is
    scaled as a whole (toward the origin, or toward the node's initial pose). ``function`` is
    evaluated at t itself, not at t - start."""

    function: object
    start: float = 0.0
    ramp: float = 0.0
    release: float | None = None
    shape: str = "smooth"

    def __post_init__(self):
        if not callable(self.function):
            raise bad("Scheduled.function", self.function, "a time function of t (K,) [s]")
        object.__setattr__(self, "start", finite("Scheduled.start", self.start, "s"))
        object.__setattr__(self, "ramp", nonnegative("Scheduled.ramp", self.ramp, "s"))
        if self.release is not None:
            release = finite("Scheduled.release", self.release, "s")
            if release <= self.start:
                raise bad("Scheduled.release", self.release, f"a time after start = {self.start:g} s, or None")
            object.__setattr__(self, "release", release)
        if self.shape not in SCHEDULE_SHAPES:
            raise bad("Scheduled.shape", self.shape, "'smooth' or 'linear'")

    def factor(self, t) -> np.ndarray:
        """The schedule factor w (K,) in [0, 1] at times t (K,) [s]."""
        t = np.asarray(t, dtype=float)
        if self.ramp > 0:
            x = (t - self.start) / self.ramp
            w = smoothstep(x) if self.shape == "smooth" else np.clip(x, 0.0, 1.0)
        else:
            w = (t >= self.start).astype(float)
        if self.release is not None:
            w = np.where(t < self.release, w, 0.0)
        return w

    def __call__(self, t):
        t = np.asarray(t, dtype=float)
        value = np.asarray(self.function(t), dtype=float)
        w = self.factor(t)
        return value * w.reshape(w.shape + (1,) * (value.ndim - w.ndim))


@dataclass(frozen=True)
class SquarePath:
    """A target moving at constant speed around a square of ``side`` [m] centred at ``center``,
    in the plane of unit axes ``u`` and ``v``, one lap per ``period`` [s]; it starts at the centre
    and blends onto the square over ``ramp`` [s] (smoothstep) so the start is gentle."""

    center: tuple
    side: float
    period: float
    u: tuple = (0.0, 1.0, 0.0)
    v: tuple = (0.0, 0.0, 1.0)
    ramp: float = 1.0

    def __post_init__(self):
        _check_plane_path(self, ("side", "period"))

    def __call__(self, t):
        t = np.asarray(t, dtype=float)
        half = 0.5 * self.side
        corners = np.array([[half, half], [-half, half], [-half, -half], [half, -half], [half, half]])
        phase = (t / self.period) % 1.0 * 4.0
        k = np.minimum(phase.astype(int), 3)
        f = (phase - k)[:, None]
        uv = corners[k] * (1 - f) + corners[k + 1] * f
        blend = _blend(t, self.ramp)
        u, v = np.asarray(self.u, float), np.asarray(self.v, float)
        return np.asarray(self.center) + blend[:, None] * (uv[:, :1] * u + uv[:, 1:] * v)


@dataclass(frozen=True)
class CirclePath:
    """A target on a circle of ``radius`` [m] around ``center`` in the plane of unit axes ``u`` and
    ``v``, one lap per ``period`` [s]: center + radius (sin(phase) u - cos(phase) v), blended in
    from the centre over ``ramp`` [s]."""

    center: tuple
    radius: float
    period: float
    u: tuple = (0.0, 1.0, 0.0)
    v: tuple = (0.0, 0.0, 1.0)
    ramp: float = 1.0

    def __post_init__(self):
        _check_plane_path(self, ("radius", "period"))

    def __call__(self, t):
        t = np.asarray(t, dtype=float)
        ph = 2 * np.pi * t / self.period
        blend = _blend(t, self.ramp)
        u, v = np.asarray(self.u, float), np.asarray(self.v, float)
        return (np.asarray(self.center)
                + (blend * self.radius)[:, None] * (np.sin(ph)[:, None] * u - np.cos(ph)[:, None] * v))


@dataclass(frozen=True)
class Figure8Path:
    """A figure-eight (lemniscate of Gerono) around ``center`` in the plane of axes ``u`` and ``v``:
    center + (width/2) sin(phase) u + (height/2) sin(2 phase) v, phase = 2 pi t / period; it crosses
    itself at the centre, where it starts, and blends in over ``ramp`` [s]. ``width`` and ``height``
    [m] are the full extents along u and v; one figure-eight per ``period`` [s]."""

    center: tuple
    width: float
    height: float
    period: float
    u: tuple = (0.0, 1.0, 0.0)
    v: tuple = (0.0, 0.0, 1.0)
    ramp: float = 1.0

    def __post_init__(self):
        _check_plane_path(self, ("width", "height", "period"))

    def __call__(self, t):
        t = np.asarray(t, dtype=float)
        ph = 2 * np.pi * t / self.period
        a = 0.5 * self.width * np.sin(ph)
        b = 0.5 * self.height * np.sin(2 * ph)
        w = _blend(t, self.ramp)
        return (np.asarray(self.center) + (w * a)[:, None] * np.asarray(self.u)
                + (w * b)[:, None] * np.asarray(self.v))


@dataclass(frozen=True)
class RandomSmoothPath:
    """A smooth random path around ``center`` in the plane of axes ``u`` and ``v``, fixed by ``seed``.

    Each of the two in-plane coordinates is a sum of ``n_modes`` sinusoids whose frequencies are
    drawn uniformly between cutoff / 10 and cutoff [Hz] (band-limited: nothing faster than ``cutoff``),
    with random phases and random positive weights normalised to sum to ``amplitude`` [m], so each
    coordinate stays within +-amplitude of the centre. The path starts at the centre and blends in
    over ``ramp`` [s]. The same seed gives the same path on every machine (NumPy's PCG64)."""

    center: tuple
    amplitude: float
    cutoff: float
    seed: int
    n_modes: int = 6
    u: tuple = (0.0, 1.0, 0.0)
    v: tuple = (0.0, 0.0, 1.0)
    ramp: float = 1.0
    _coef: tuple = field(init=False, repr=False, compare=False)

    def __post_init__(self):
        _check_plane_path(self, ("amplitude", "cutoff"))
        if not is_int(self.seed) or self.seed < 0:
            raise bad("RandomSmoothPath.seed", self.seed, "an integer >= 0")
        if not is_int(self.n_modes) or not 1 <= self.n_modes <= 64:
            raise bad("RandomSmoothPath.n_modes", self.n_modes, "an integer in [1, 64]")
        rng = np.random.default_rng(int(self.seed))
        freq = rng.uniform(0.1 * self.cutoff, self.cutoff, size=(2, self.n_modes))
        phase = rng.uniform(0.0, 2 * np.pi, size=(2, self.n_modes))
        weight = rng.uniform(0.2, 1.0, size=(2, self.n_modes))
        amp = self.amplitude * weight / weight.sum(axis=1, keepdims=True)
        object.__setattr__(self, "_coef", (freq, phase, amp))

    def __call__(self, t):
        t = np.asarray(t, dtype=float)
        freq, phase, amp = self._coef
        # (K, 2, modes) -> (K, 2)
        uv = np.sum(amp * np.sin(2 * np.pi * freq * t[:, None, None] + phase), axis=-1)
        uv = uv * _blend(t, self.ramp)[:, None]
        return np.asarray(self.center) + uv[:, :1] * np.asarray(self.u) + uv[:, 1:] * np.asarray(self.v)


@dataclass(frozen=True)
class Sum:
    """The sum of several time functions (e.g. an offset push plus an oscillation)."""

    terms: tuple

    def __post_init__(self):
        object.__setattr__(self, "terms", tuple(self.terms))
        if not self.terms or not all(callable(f) for f in self.terms):
            raise bad("Sum.terms", self.terms, "one or more time functions")

    def __call__(self, t):
        t = np.asarray(t, dtype=float)
        out = np.zeros((t.size, 3))
        for f in self.terms:
            out = out + f(t)
        return out


KINDS = {"constant": Constant, "sinusoid": Sinusoid, "sampled": Sampled, "window": Window, "sum": Sum,
         "scheduled": Scheduled, "square": SquarePath, "circle": CirclePath, "figure8": Figure8Path,
         "random_smooth": RandomSmoothPath}
"""The time functions by their record's ``kind`` (the scenario files' profile kinds)."""


def function_record(function) -> dict:
    """The record of a time function of this module (JSON-ready): ``kind`` and its arguments, numbers
    and lists of numbers, a nested function as its record (``Window``, ``Scheduled``, ``Sum``)."""
    kind = next((k for k, cls in KINDS.items() if type(function) is cls), None)
    if kind is None:
        raise bad("function", type(function).__name__,
                  f"a time function of softrnn.geometry.paths ({', '.join(KINDS)})")
    out = {"kind": kind}
    for f in fields(function):
        if f.init:
            out[f.name] = _plain(getattr(function, f.name))
    return out


def _plain(value):
    """An argument as JSON: a function's record, a list of them, or the value (arrays as lists)."""
    if type(value) in KINDS.values():
        return function_record(value)
    if isinstance(value, tuple) and value and type(value[0]) in KINDS.values():
        return [function_record(v) for v in value]
    if value is None or isinstance(value, (str, bool, int, float)):
        return value
    return np.asarray(value).tolist()


def function_from_record(record) -> object:
    """The time function of a record (``function_record``); a malformed one is a one-line
    ``SoftrnnInputError``."""
    kind = record.get("kind") if isinstance(record, dict) else None
    if kind not in KINDS:
        raise bad("function", record, f"a record with kind one of {', '.join(KINDS)}")
    args = {k: _value(v) for k, v in record.items() if k != "kind"}
    try:
        return KINDS[kind](**args)
    except TypeError as err:
        raise bad("function", record, f"a valid {kind} record ({err})") from None


def _value(value):
    """A record's argument back: a nested function, a tuple of them, or the value."""
    if isinstance(value, dict):
        return function_from_record(value)
    if isinstance(value, list) and value and isinstance(value[0], dict):
        return tuple(function_from_record(v) for v in value)
    return value
