"""More time functions for scenarios: figure-eight and smooth random target paths, sums of
profiles, and prescribed boundary motions built from profiles.

Like the paths in ``softrnn.rod.loads`` they are frozen, validated dataclasses and vectorised
callables t (K,) [s] -> (K, 3); targets start at their centre and blend onto the path over
``ramp`` seconds with the C2 smoothstep, so a PD-tracked tip starts gently.
"""

from dataclasses import dataclass, field

import numpy as np

from ..errors import bad, is_int, nonnegative, positive, vec3
from ..rod.loads import _blend, _plane_axes
from ..rod.so3 import hat


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
        object.__setattr__(self, "center", vec3("Figure8Path.center", self.center))
        positive("Figure8Path.width", self.width)
        positive("Figure8Path.height", self.height)
        positive("Figure8Path.period", self.period)
        nonnegative("Figure8Path.ramp", self.ramp)
        u, v = _plane_axes("Figure8Path", self.u, self.v)
        object.__setattr__(self, "u", u)
        object.__setattr__(self, "v", v)

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
        object.__setattr__(self, "center", vec3("RandomSmoothPath.center", self.center))
        positive("RandomSmoothPath.amplitude", self.amplitude)
        positive("RandomSmoothPath.cutoff", self.cutoff)
        nonnegative("RandomSmoothPath.ramp", self.ramp)
        if not is_int(self.seed) or self.seed < 0:
            raise bad("RandomSmoothPath.seed", self.seed, "an integer >= 0")
        if not is_int(self.n_modes) or not 1 <= self.n_modes <= 64:
            raise bad("RandomSmoothPath.n_modes", self.n_modes, "an integer in [1, 64]")
        u, v = _plane_axes("RandomSmoothPath", self.u, self.v)
        object.__setattr__(self, "u", u)
        object.__setattr__(self, "v", v)
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


def rotation_vector_to_matrix(x: np.ndarray) -> np.ndarray:
    """Rodrigues: rotation vectors (..., 3) (axis times angle [rad]) -> matrices (..., 3, 3)."""
    x = np.asarray(x, dtype=float)
    th = np.linalg.norm(x, axis=-1)[..., None, None]
    X = hat(x)
    a = np.sinc(th / np.pi)  # sin(th)/th, 1 at 0
    b = 0.5 * np.sinc(th / (2 * np.pi)) ** 2  # (1 - cos th)/th^2, 1/2 at 0
    return np.eye(3) + a * X + b * (X @ X)


@dataclass(frozen=True, eq=False)
class PoseMotion:
    """Prescribed pose of a clamped node: position = ``position`` + displacement(t) [m], rotation =
    exp(rotation(t)^) ``rotation0``, with ``rotation(t)`` a rotation vector [rad] in the world frame.
    Either time function may be None (no displacement / no rotation). Returns (K, 3), (K, 3, 3)."""

    position: tuple
    rotation0: np.ndarray
    displacement: object | None = None
    rotation: object | None = None

    def __post_init__(self):
        object.__setattr__(self, "position", vec3("PoseMotion.position", self.position))
        R = np.array(self.rotation0, dtype=float)
        if R.shape != (3, 3) or not np.allclose(R.T @ R, np.eye(3), atol=1e-8):
            raise bad("PoseMotion.rotation0", R.shape, "a 3x3 rotation matrix")
        R.setflags(write=False)
        object.__setattr__(self, "rotation0", R)

    def __call__(self, t):
        t = np.asarray(t, dtype=float)
        pos = np.broadcast_to(np.asarray(self.position), (t.size, 3)).copy()
        if self.displacement is not None:
            pos = pos + self.displacement(t)
        if self.rotation is None:
            rot = np.broadcast_to(self.rotation0, (t.size, 3, 3)).copy()
        else:
            rot = rotation_vector_to_matrix(self.rotation(t)) @ self.rotation0
        return pos, rot


@dataclass(frozen=True, eq=False)
class PositionPath:
    """Prescribed position of a pinned node: ``position`` + displacement(t) [m], (K, 3)."""

    position: tuple
    displacement: object

    def __post_init__(self):
        object.__setattr__(self, "position", vec3("PositionPath.position", self.position))
        if not callable(self.displacement):
            raise bad("PositionPath.displacement", self.displacement, "a time function t (K,) -> (K, 3)")

    def __call__(self, t):
        t = np.asarray(t, dtype=float)
        return np.asarray(self.position) + self.displacement(t)
