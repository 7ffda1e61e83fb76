"""External loads: time functions, nodal forces and torques, and state-feedback (PD) forces.

A time function maps times t (K,) [s] to values (K, 3) (forces [N], torques [N m] or target
positions [m]); all are vectorised and evaluated chunk by chunk ahead of the numba kernel.
"""

from dataclasses import dataclass
from typing import Protocol

import numpy as np

from ..errors import bad, finite, nonnegative, positive, vec3


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
        object.__setattr__(self, "center", vec3("SquarePath.center", self.center))
        positive("SquarePath.side", self.side)
        positive("SquarePath.period", self.period)
        nonnegative("SquarePath.ramp", self.ramp)
        u, v = _plane_axes("SquarePath", self.u, self.v)
        object.__setattr__(self, "u", u)
        object.__setattr__(self, "v", v)

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
class NodalLoad:
    """A force [N] and/or torque [N m] on one node; ``frame`` 'world' (fixed directions) or 'body'
    (follower load, components in the node's frame d1, d2, d3)."""

    node: int
    force: object | None = None
    torque: object | None = None
    frame: str = "world"

    def __post_init__(self):
        if self.frame not in ("world", "body"):
            raise bad("NodalLoad.frame", self.frame, "'world' or 'body'")
        if self.force is None and self.torque is None:
            raise bad("NodalLoad", "no force and no torque", "a force and/or a torque time function")


@dataclass(frozen=True)
class PDTracking:
    """State feedback force on ``node``: f = stiffness (target(t) - r) - damping v [N], pulling
    the node toward a moving target (the square-tracking case)."""

    node: int
    target: object
    stiffness: float
    damping: float = 0.0

    def __post_init__(self):
        positive("PDTracking.stiffness", self.stiffness)
        finite("PDTracking.damping", self.damping)
        if self.damping < 0:
            raise bad("PDTracking.damping", self.damping, "a damping gain >= 0 in N s/m")


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
        object.__setattr__(self, "center", vec3("CirclePath.center", self.center))
        positive("CirclePath.radius", self.radius)
        positive("CirclePath.period", self.period)
        nonnegative("CirclePath.ramp", self.ramp)
        u, v = _plane_axes("CirclePath", self.u, self.v)
        object.__setattr__(self, "u", u)
        object.__setattr__(self, "v", v)

    def __call__(self, t):
        t = np.asarray(t, dtype=float)
        ph = 2 * np.pi * t / self.period
        blend = _blend(t, self.ramp)
        u, v = np.asarray(self.u, float), np.asarray(self.v, float)
        return (np.asarray(self.center)
                + (blend * self.radius)[:, None] * (np.sin(ph)[:, None] * u - np.cos(ph)[:, None] * v))
