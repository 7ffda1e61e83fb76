"""Electromagnets as point dipoles: field, gradient and the 8 x n actuation matrix (magnetic.md §1.2, §2.1-2.2).

Coil k is a point dipole at c_k with moment m_k = kappa_k I_k a_k (a_k unit axis, I_k current [A]).
Everything is linear in the currents, so B(p) = sum_k beta_k(p) I_k and the 5-gradient
g(p) = pack5(G(p)) = sum_k gamma_k(p) I_k; A(p) = [beta; gamma] (8 x n_coils) (Petruska & Nelson 2015).

Array conventions (P field points, n coils):
    points      (P, 3) or (3,)    [m]
    currents    (n,)              [A]
    B           (P, 3)            [T]
    G           (P, 3, 3)         [T/m], G_ij = dB_i/dx_j (symmetric, traceless)
    A           (P, 8, n)         rows [Bx, By, Bz, dBx/dx, dBx/dy, dBx/dz, dBy/dy, dBy/dz] per ampere

The NumPy functions check their input; ``field_gradient_into`` (``rod.kernels``, where the simulator
calls it every step) is the numba kernel: no checks, it writes into preallocated arrays.
"""

import math
from dataclasses import dataclass

import numpy as np

from ..errors import bad, positive, vec3
from ..rod.kernels import MIN_DIPOLE_DISTANCE
from ..rod.kernels import field_gradient_into as field_gradient_into

MU0 = 4e-7 * math.pi
"""Vacuum permeability mu0 [T m/A] (the pre-2019 exact value; CODATA 2018 differs by 5e-10 relative)."""

MIN_DISTANCE = MIN_DIPOLE_DISTANCE
"""Closest approach [m] of a field point to a coil's dipole (magnetic.md §2.1 guard R > r_min)."""


def centre_field_factor(position: np.ndarray, axis: np.ndarray) -> float:
    """|B| at the origin per unit moment, times 4 pi |c|^3 / mu0: sqrt(1 + 3 cos^2 theta), theta the
    angle between the axis and the line from the coil to the origin (2 on the axis)."""
    d = np.linalg.norm(position)
    cos = float(np.dot(-position / d, axis))
    return math.sqrt(1.0 + 3.0 * cos * cos)


@dataclass(frozen=True, kw_only=True)
class Coil:
    """One electromagnet as a point dipole.

    Attributes
    ----------
    position : (3,) [m]
        dipole centre (origin = workspace centre)
    axis : (3,)
        dipole direction (normalised here); positive current gives a moment along it
    kappa : float or None
        dipole moment per ampere [A m^2 / A]; or give
    b0 : float or None
        field magnitude at the origin per ampere [T/A] instead (kappa then follows from the
        dipole law: kappa = 4 pi |c|^3 b0 / (mu0 sqrt(1 + 3 cos^2 theta)); on the axis
        kappa = 2 pi |c|^3 b0 / mu0, magnetic.md §1.2)
    """

    position: tuple
    axis: tuple
    kappa: float | None = None
    b0: float | None = None

    def __post_init__(self):
        p = np.array(vec3("coil.position", self.position))
        a = np.array(vec3("coil.axis", self.axis, nonzero=True))
        if np.linalg.norm(p) == 0:
            raise bad("coil.position", self.position, "a point away from the workspace centre (0, 0, 0)")
        a = a / np.linalg.norm(a)
        if (self.kappa is None) == (self.b0 is None):
            raise bad("coil strength", (self.kappa, self.b0), "exactly one of kappa [A m^2/A] or b0 [T/A]")
        if self.kappa is not None:
            kappa = positive("coil.kappa", self.kappa, "A m^2 per A")
        else:
            b0 = positive("coil.b0", self.b0, "T/A")
            d = np.linalg.norm(p)
            kappa = 4.0 * math.pi * d**3 * b0 / (MU0 * centre_field_factor(p, a))
        object.__setattr__(self, "position", tuple(float(c) for c in p))
        object.__setattr__(self, "axis", tuple(float(c) for c in a))
        object.__setattr__(self, "kappa", kappa)

    @property
    def moment_per_ampere(self) -> np.ndarray:
        """kappa a (3,) [A m^2/A]."""
        return self.kappa * np.asarray(self.axis)


@dataclass(frozen=True, kw_only=True)
class CoilLayout:
    """A set of stationary electromagnets around a spherical workspace."""

    coils: tuple
    """The electromagnets (``Coil``)."""
    current_limit: float = 8.0
    """Largest |I_k| [A] of every coil."""
    workspace_radius: float = 0.05
    """Radius [m] of the workspace around the origin; every coil must lie outside it by at least
    ``MIN_DISTANCE`` (the point-dipole model is singular at the coil)."""

    def __post_init__(self):
        coils = tuple(self.coils)
        if len(coils) == 0:
            raise bad("coils", self.coils, "at least one Coil")
        for k, c in enumerate(coils):
            if not isinstance(c, Coil):
                raise bad(f"coils[{k}]", c, "a Coil")
        positive("current_limit", self.current_limit, "A")
        positive("workspace_radius", self.workspace_radius, "m")
        object.__setattr__(self, "coils", coils)
        for k, c in enumerate(coils):
            d = float(np.linalg.norm(c.position))
            if d < self.workspace_radius + MIN_DISTANCE:
                raise bad(f"coils[{k}].position", c.position,
                          f"a coil outside the workspace: |position| = {d:.4g} m must be >= workspace_radius "
                          f"+ {MIN_DISTANCE} m = {self.workspace_radius + MIN_DISTANCE:.4g} m")

    @property
    def n_coils(self) -> int:
        """Number of coils n."""
        return len(self.coils)

    @property
    def positions(self) -> np.ndarray:
        """Coil dipole centres (n, 3) [m]."""
        return np.array([c.position for c in self.coils], dtype=float)

    @property
    def moments_per_ampere(self) -> np.ndarray:
        """kappa_k a_k (n, 3) [A m^2/A]."""
        return np.array([c.moment_per_ampere for c in self.coils], dtype=float)

    def check_currents(self, currents, name: str = "currents") -> np.ndarray:
        """Currents (..., n) as a float array, or a one-line error (wrong shape, non-finite, beyond the limit)."""
        try:
            I = np.asarray(currents, dtype=float)
        except (TypeError, ValueError):
            raise bad(name, currents, f"numbers in A, shape (..., {self.n_coils})") from None
        if I.ndim == 0 or I.shape[-1] != self.n_coils:
            raise bad(f"{name}.shape", I.shape, f"(..., {self.n_coils}): one current per coil")
        if not np.all(np.isfinite(I)):
            raise bad(name, "non-finite values", "finite currents in A")
        peak = float(np.max(np.abs(I))) if I.size else 0.0
        if peak > self.current_limit * (1.0 + 1e-12):
            raise bad(f"max |{name}|", round(peak, 6),
                      f"currents within the coil limit +/-{self.current_limit:g} A (scale them down or raise "
                      f"current_limit)")
        return I

    def check_points(self, points, name: str = "points") -> np.ndarray:
        """Points (P, 3) or (3,) as a float array, at least ``MIN_DISTANCE`` from every coil."""
        try:
            p = np.asarray(points, dtype=float)
        except (TypeError, ValueError):
            raise bad(name, points, "points in m, shape (P, 3) or (3,)") from None
        if p.shape[-1:] != (3,) or p.ndim > 2:
            raise bad(f"{name}.shape", p.shape, "(P, 3) or (3,)")
        if not np.all(np.isfinite(p)):
            raise bad(name, "non-finite values", "finite coordinates in m")
        d = np.linalg.norm(p.reshape(-1, 1, 3) - self.positions[None], axis=-1)
        if d.size and d.min() < MIN_DISTANCE:
            raise bad(name, f"a point {d.min():.3g} m from a coil",
                      f"points at least {MIN_DISTANCE} m from every coil (the dipole model is singular there)")
        return p


def bigmag_like(*, radius: float = 0.12, b0: float = 1.0e-3, elevation_deg: float = 30.0,
                current_limit: float = 8.0, workspace_radius: float = 0.05) -> CoilLayout:
    """The default 'BigMag-like' layout of magnetic.md §1.2 [D]: 6 dipoles at distance ``radius``
    [m], azimuth phi_k = 60 k deg, elevation +elevation_deg for even k and -elevation_deg for odd k,
    each pointing at the origin with ``b0`` [T/A] there (1 mT/A: kappa = 8.64 A m^2/A at 0.12 m),
    currents within +/-``current_limit`` [A]. Not BigMag's calibrated geometry, which is not public."""
    positive("radius", radius, "m")
    coils = []
    for k in range(6):
        phi = math.radians(60.0 * k)
        el = math.radians(elevation_deg if k % 2 == 0 else -elevation_deg)
        p = radius * np.array([math.cos(phi) * math.cos(el), math.sin(phi) * math.cos(el), math.sin(el)])
        coils.append(Coil(position=tuple(p), axis=tuple(-p / radius), b0=b0))
    return CoilLayout(coils=tuple(coils), current_limit=current_limit, workspace_radius=workspace_radius)


# --------------------------------------------------------------------------- dipole formulas (NumPy)
def dipole_field(moment: np.ndarray, source: np.ndarray, points: np.ndarray) -> np.ndarray:
    """B (..., 3) [T] of dipoles ``moment`` (..., 3) [A m^2] at ``source`` (..., 3) [m] at ``points`` (..., 3):
    mu0/(4 pi) [3 r (r.m)/R^5 - m/R^3], r = p - c (magnetic.md §2.1). Arguments broadcast."""
    r = np.asarray(points, float) - np.asarray(source, float)
    m = np.asarray(moment, float)
    R2 = np.sum(r * r, axis=-1, keepdims=True)
    R = np.sqrt(R2)
    rm = np.sum(r * m, axis=-1, keepdims=True)
    return MU0 / (4.0 * math.pi) * (3.0 * r * rm / (R2 * R2 * R) - m / (R2 * R))


def dipole_gradient(moment: np.ndarray, source: np.ndarray, points: np.ndarray) -> np.ndarray:
    """G (..., 3, 3) [T/m], G_ij = dB_i/dx_j = 3 mu0/(4 pi R^5) [m r^T + r m^T + (r.m) I - 5 (r.m) r r^T / R^2]."""
    r = np.asarray(points, float) - np.asarray(source, float)
    m = np.broadcast_to(np.asarray(moment, float), r.shape)
    R2 = np.sum(r * r, axis=-1)[..., None, None]
    rm = np.sum(r * m, axis=-1)[..., None, None]
    outer = m[..., :, None] * r[..., None, :] + r[..., :, None] * m[..., None, :]
    rr = r[..., :, None] * r[..., None, :]
    return 3.0 * MU0 / (4.0 * math.pi * R2 * R2 * np.sqrt(R2)) * (outer + rm * np.eye(3) - 5.0 * rm * rr / R2)


def pack5(G: np.ndarray) -> np.ndarray:
    """(..., 3, 3) -> (..., 5): [dBx/dx, dBx/dy, dBx/dz, dBy/dy, dBy/dz] (magnetic.md §2.2, mag_manip packing)."""
    G = np.asarray(G, float)
    return np.stack([G[..., 0, 0], G[..., 0, 1], G[..., 0, 2], G[..., 1, 1], G[..., 1, 2]], -1)


def unpack5(g: np.ndarray) -> np.ndarray:
    """(..., 5) -> symmetric, traceless (..., 3, 3)."""
    g = np.asarray(g, float)
    g0, g1, g2, g3, g4 = (g[..., i] for i in range(5))
    return np.stack([np.stack([g0, g1, g2], -1), np.stack([g1, g3, g4], -1),
                     np.stack([g2, g4, -g0 - g3], -1)], -2)


# --------------------------------------------------------------------------- layout maps (NumPy)
def unit_field_maps(layout: CoilLayout, points) -> tuple[np.ndarray, np.ndarray]:
    """Per-ampere maps at points (P, 3) or (3,): beta (P, 3, n) [T/A] and the gradients
    (P, n, 3, 3) [T/(m A)] of every coil (leading P dropped for a single point)."""
    p = layout.check_points(points)
    single = p.ndim == 1
    p = p.reshape(-1, 3)
    c = layout.positions
    m = layout.moments_per_ampere
    beta = dipole_field(m[None], c[None], p[:, None])          # (P, n, 3)
    grad = dipole_gradient(m[None], c[None], p[:, None])       # (P, n, 3, 3)
    beta = np.swapaxes(beta, 1, 2)
    return (beta[0], grad[0]) if single else (beta, grad)


def actuation_matrix(layout: CoilLayout, points) -> np.ndarray:
    """A (P, 8, n) (or (8, n) for one point) with [B; g] = A I (magnetic.md §2.2): rows 0-2 in T/A,
    rows 3-7 the packed gradient in T/(m A)."""
    beta, grad = unit_field_maps(layout, points)
    gamma = np.swapaxes(pack5(grad), -1, -2)                     # (..., 5, n)
    return np.concatenate([beta, gamma], axis=-2)


def field(layout: CoilLayout, points, currents) -> np.ndarray:
    """B (P, 3) or (3,) [T] at points for coil currents (n,) [A]."""
    I = layout.check_currents(currents)
    if I.ndim != 1:
        raise bad("currents.shape", I.shape, f"({layout.n_coils},)")
    beta, _ = unit_field_maps(layout, points)
    return beta @ I


def gradient(layout: CoilLayout, points, currents) -> np.ndarray:
    """G (P, 3, 3) or (3, 3) [T/m] at points for coil currents (n,) [A]."""
    I = layout.check_currents(currents)
    if I.ndim != 1:
        raise bad("currents.shape", I.shape, f"({layout.n_coils},)")
    _, grad = unit_field_maps(layout, points)
    return np.einsum("...kij,k->...ij", grad, I)
