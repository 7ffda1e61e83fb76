"""Permanent magnets as point dipoles: moment from grade and volume, torque mu x B and force M(mu) g
(magnetic.md §2.3, §2.4, §3).

Array conventions (leading axes ``...`` broadcast):
    mu (..., 3) [A m^2], B (..., 3) [T], G (..., 3, 3) [T/m], g = pack5(G) (..., 5) [T/m],
    wrench (..., 6) = [force (3) N, torque (3) N m], all in the world frame.
"""

from dataclasses import dataclass, replace

import numpy as np

from ..errors import bad, finite, positive
from ..rod.so3 import hat
from .coils import MU0

GRADES = {"N42": 1.30, "N45": 1.35}
"""Nominal remanence Br [T] of sintered NdFeB grades at 20 C (magnetic.md §3, a [V] table: vendor
ranges N42 1.28-1.32 T and N45 1.32-1.37 T; shanghaimagnet, jingxin, hgtmagnets, it-magnet)."""

MAGNET_DENSITY = 7000.0
"""Magnet density [kg/m^3] as given in Tariverdi et al. 2021 (vendor tables say 7400-7600)."""
MAGNET_YOUNGS_MODULUS = 41.4e9
"""Magnet Young's modulus [Pa] (Tariverdi et al. 2021)."""
MAGNET_POISSON_RATIO = 0.3
"""Magnet Poisson ratio (Tariverdi et al. 2021)."""


@dataclass(frozen=True, kw_only=True)
class Magnet:
    """A rigid block magnet embedded in the rod."""

    arc_length: float
    """s [m] of the block's centre along the undeformed rod, from the clamped base."""
    grade: str = "N42"
    """A key of ``GRADES`` ('N42', 'N45'); ignored when ``remanence`` is given."""
    remanence: float | None = None
    """Br [T], overrides the grade's nominal value (e.g. a perturbed "real" magnet)."""
    size: tuple = (2e-3, 2e-3, 2e-3)
    """Block edges (a, b, c) [m]; c lies along the rod (d3), a along d1, b along d2."""
    direction: tuple = (0.0, 0.0, 1.0)
    """Magnetisation unit vector in the rod's body frame (d1, d2, d3 components); (0, 0, 1) is axial
    along the tangent, (0, 0, -1) antiparallel."""
    density: float = MAGNET_DENSITY
    """Block density [kg/m^3] (paper value)."""
    youngs_modulus: float = MAGNET_YOUNGS_MODULUS
    """Block Young's modulus [Pa] (paper value)."""
    poisson_ratio: float = MAGNET_POISSON_RATIO
    """Block Poisson ratio [-] (paper value)."""

    def __post_init__(self):
        finite("magnet.arc_length", self.arc_length)
        if self.remanence is None:
            if self.grade not in GRADES:
                raise bad("magnet.grade", self.grade, f"one of {sorted(GRADES)} or an explicit remanence in T")
        else:
            positive("magnet.remanence", self.remanence)
        try:
            size = np.asarray(self.size, dtype=float)
        except (TypeError, ValueError):
            size = None
        if size is None or size.shape != (3,) or not np.all(np.isfinite(size)) or np.any(size <= 0):
            raise bad("magnet.size", self.size, "three positive block edges (a, b, c) in m")
        try:
            e = np.asarray(self.direction, dtype=float)
        except (TypeError, ValueError):
            e = None
        if e is None or e.shape != (3,) or not np.all(np.isfinite(e)) or np.linalg.norm(e) == 0:
            raise bad("magnet.direction", self.direction, "a nonzero 3-vector in the body frame (d1, d2, d3)")
        positive("magnet.density", self.density)
        positive("magnet.youngs_modulus", self.youngs_modulus)
        if not (-1.0 < finite("magnet.poisson_ratio", self.poisson_ratio) <= 0.5):
            raise bad("magnet.poisson_ratio", self.poisson_ratio, "a value in (-1, 0.5]")
        object.__setattr__(self, "size", tuple(float(c) for c in size))
        object.__setattr__(self, "direction", tuple(float(c) for c in e / np.linalg.norm(e)))

    @property
    def br(self) -> float:
        """Remanence Br [T] in use."""
        return GRADES[self.grade] if self.remanence is None else float(self.remanence)

    @property
    def volume(self) -> float:
        """V = a b c [m^3]."""
        a, b, c = self.size
        return a * b * c

    @property
    def moment(self) -> float:
        """|mu| = Br V / mu0 [A m^2] (magnetic.md §2.4; 8.28e-3 for a 2 mm N42 cube)."""
        return self.br * self.volume / MU0

    @property
    def moment_body(self) -> np.ndarray:
        """mu (3,) [A m^2] in the rod's body frame."""
        return self.moment * np.asarray(self.direction)

    @property
    def mass(self) -> float:
        """rho V [kg]."""
        return self.density * self.volume

    @property
    def length(self) -> float:
        """Block length c along the rod [m]."""
        return self.size[2]

    def scaled(self, remanence: float = 1.0) -> "Magnet":
        """A copy with Br multiplied by ``remanence`` (a perturbed 'real' magnet)."""
        return replace(self, remanence=self.br * positive("remanence factor", remanence))


def moment_world(magnet: Magnet, rotation: np.ndarray) -> np.ndarray:
    """mu = R mu_body (..., 3) [A m^2] for body-to-world rotations (..., 3, 3)."""
    return np.asarray(rotation, float) @ magnet.moment_body


def force_matrix(mu: np.ndarray) -> np.ndarray:
    """The Petruska-Nelson M(mu) (..., 3, 5) with f = M(mu) pack5(G) = G mu (magnetic.md §2.3; valid for
    curl-free, divergence-free fields)."""
    mu = np.asarray(mu, float)
    x, y, w = mu[..., 0], mu[..., 1], mu[..., 2]
    z = np.zeros(mu.shape[:-1])
    return np.stack([np.stack([x, y, w, z, z], -1),
                     np.stack([z, x, z, y, w], -1),
                     np.stack([-w, z, x, -w, y], -1)], -2)


def wrench_matrix(mu: np.ndarray) -> np.ndarray:
    """W(mu) (..., 6, 8) with ``[f; tau] = W(mu) [B; g] = [[0, M(mu)], [S(mu), 0]] [B; g]``, S(mu) = hat(mu)
    the skew matrix (S(mu) B = mu x B); the wrench per ampere of coil currents is then W(mu) A(p) (6 x n)."""
    mu = np.asarray(mu, float)
    W = np.zeros(mu.shape[:-1] + (6, 8))
    W[..., :3, 3:] = force_matrix(mu)
    W[..., 3:, :3] = hat(mu)
    return W


def torque(mu: np.ndarray, B: np.ndarray) -> np.ndarray:
    """tau = mu x B (..., 3) [N m]."""
    return np.cross(np.asarray(mu, float), np.asarray(B, float))


def force(mu: np.ndarray, G: np.ndarray) -> np.ndarray:
    """f = grad(mu . B) = G^T mu = G mu (..., 3) [N] (G symmetric in a current-free region)."""
    return np.einsum("...ji,...j->...i", np.asarray(G, float), np.asarray(mu, float))


def wrench(mu: np.ndarray, B: np.ndarray, G: np.ndarray) -> np.ndarray:
    """[force, torque] (..., 6) [N, N m] on dipoles mu in the field B with gradient G."""
    return np.concatenate([force(mu, G), torque(mu, B)], axis=-1)


def default_magnets(length: float) -> tuple[Magnet, Magnet]:
    """The two magnets of magnetic.md §1.3 [D] for a rod of ``length`` [m]: 2 mm cubes, axial
    magnetisation, N42 proximal at s = L/2 and N45 distal at s = L - 1 mm (flush with the tip)."""
    positive("length", length)
    return (Magnet(arc_length=0.5 * length, grade="N42"),
            Magnet(arc_length=length - 1e-3, grade="N45"))

