"""Configuration of the static Cosserat rod BVP (paper appendix): the rod, its stiff segments and
magnets (``StaticRod``), and the loads of one solve (``StaticLoads``); frozen and validated.

Frames and units: SI throughout; world frame with gravity along -z by default; the base is clamped
at ``base_position`` with ``base_rotation`` (columns d1, d2, d3 = body axes in the world, d3 the
tangent). The default base points the rod along +x with d1 = +z, the same frame as
``softrnn.rod.straight(direction=(1, 0, 0), normal=(0, 0, 1))`` (the magnetic setup: horizontal
along x, gravity -z).
"""

import math
from dataclasses import dataclass, field

import numpy as np

from ..errors import bad, is_finite_number, positive
from ..rod.so3 import frame_from_tangent
from ..rod.tendons import Tendon

DEFAULT_BASE_ROTATION = frame_from_tangent(np.array([1.0, 0.0, 0.0]), np.array([0.0, 0.0, 1.0]))


def shown(value):
    """A short one-line stand-in for ``value`` in error messages (arrays become lists, or their
    shape when large)."""
    if isinstance(value, np.ndarray):
        return value.tolist() if value.size <= 9 else f"<array of shape {value.shape}>"
    return value


def _vector(name: str, value, unit: str, shape=(3,)) -> np.ndarray:
    try:
        a = np.array(value, dtype=float)
    except (TypeError, ValueError):
        raise bad(name, shown(value), f"an array of shape {shape} in {unit}") from None
    if a.shape != shape or not np.isfinite(a).all():
        raise bad(name, shown(value), f"a finite array of shape {shape} in {unit}")
    a.setflags(write=False)
    return a


def _arc_length(name: str, s, length: float, what: str) -> float:
    if not is_finite_number(s):
        raise bad(name, s, f"an arc length in [0, {length:g}] m")
    if not 0.0 <= s <= length:
        raise bad(name, s, f"an arc length in [0, {length:g}] m ({what} outside the rod)")
    return float(s)


@dataclass(frozen=True, kw_only=True)
class RigidSegment:
    """A stiffer and heavier part over the arc lengths s0 <= s <= s1 [m], e.g. an embedded magnet.

    youngs_modulus [Pa] and density [kg/m^3] of the segment; radius [m] of its circular section
    (None: the rod's radius); poisson_ratio (None: the rod's) gives its shear modulus.
    """

    s0: float
    s1: float
    youngs_modulus: float
    density: float
    radius: float | None = None
    poisson_ratio: float | None = None

    def __post_init__(self):
        for name in ("s0", "s1"):
            value = getattr(self, name)
            if not is_finite_number(value):
                raise bad(f"rigid_segment.{name}", value, "a finite arc length in m")
        if not self.s0 < self.s1:
            raise bad("rigid_segment", (self.s0, self.s1), "s0 < s1 (the segment's start and end arc lengths in m)")
        positive("rigid_segment.youngs_modulus", self.youngs_modulus, "Pa")
        positive("rigid_segment.density", self.density, "kg/m^3")
        if self.radius is not None:
            positive("rigid_segment.radius", self.radius, "m")
        if self.poisson_ratio is not None and not -1.0 < self.poisson_ratio <= 0.5:
            raise bad("rigid_segment.poisson_ratio", self.poisson_ratio, "a value in (-1, 0.5]")


@dataclass(frozen=True, kw_only=True)
class PointMagnet:
    """A point dipole at arc length s [m] with moment ``moment_body`` (3,) [A m^2] in the body
    frame (e.g. (0, 0, mu) along the tangent d3). In the field B (3,) [T] and gradient G (3, 3)
    [T/m] of a solve it carries the torque (R(s) mu_b) x B and the force G (R(s) mu_b)."""

    s: float
    moment_body: tuple

    def __post_init__(self):
        if not is_finite_number(self.s):
            raise bad("magnet.s", self.s, "a finite arc length in m")
        mu = _vector("magnet.moment_body", self.moment_body, "A m^2")
        object.__setattr__(self, "moment_body", tuple(float(x) for x in mu))


@dataclass(frozen=True, kw_only=True)
class PointLoad:
    """A dead point force (3,) [N] and torque (3,) [N m], world frame, at arc length s [m]."""

    s: float
    force: tuple = (0.0, 0.0, 0.0)
    torque: tuple = (0.0, 0.0, 0.0)

    def __post_init__(self):
        if not is_finite_number(self.s):
            raise bad("point_load.s", self.s, "a finite arc length in m")
        object.__setattr__(self, "force", tuple(float(x) for x in _vector("point_load.force", self.force, "N")))
        object.__setattr__(self, "torque",
                           tuple(float(x) for x in _vector("point_load.torque", self.torque, "N m")))


@dataclass(frozen=True)
class SectionStiffness:
    """The stiffnesses of a rod section (``StaticRod.stiffness``, ``StaticRod.segment_stiffness``).

    Attributes
    ----------
    EI, GJ : float
        bending and torsional stiffness [N m^2]
    EA, GA : float
        axial and shear (kappa G A) stiffness [N]
    weight : float or None
        mass per length [kg/m] of a rigid segment (None: the flexible rod's, ``weight_per_length``)
    """

    EI: float
    GJ: float
    EA: float
    GA: float
    weight: float | None = None


@dataclass(frozen=True, kw_only=True, eq=False)
class StaticRod:
    """A straight, stress-free Cosserat rod of circular section, clamped at its base.

    Parameters
    ----------
    length : float
        L [m]
    radius : float
        section radius r [m] (area and second moments unless overridden)
    youngs_modulus : float
        E [Pa]
    density : float
        rho [kg/m^3] (weight rho A g per length)
    poisson_ratio : float
        nu, G = E / (2 (1 + nu))
    shear_coefficient : float
        kappa in the shear stiffness kappa G A (1, as the dynamic model)
    bending_stiffness, torsional_stiffness, axial_stiffness, shear_stiffness : float or None
        overrides of EI [N m^2], GJ [N m^2], EA [N], kappa G A [N]
    extensible_shearable : bool
        True: the paper's model, v = Ks^-1 R^T n + e3 (stretch and shear);
        False: Kirchhoff rod, v = e3 (inextensible, unshearable)
    gravity : (3,)
        gravitational acceleration [m/s^2], world frame
    base_position : (3,)
        position of the clamped base [m], world frame
    base_rotation : (3, 3)
        body -> world rotation of the clamped base (columns d1, d2, d3)
    rigid_segments : tuple
        RigidSegment entries (not overlapping)
    magnets : tuple
        PointMagnet entries; a solve gives the field B and gradient G at each
    tendons : tuple
        ``softrnn.rod.Tendon`` entries routed from the base (terminated at ``end_s``, default the
        tip; ``end_node`` is for the dynamic rod); a solve gives their tensions
        (``StaticLoads.tendon_tensions``), or the displacements of those driven by one
        (``StaticLoads.tendon_displacements``), whose tensions it solves for
    """

    length: float
    radius: float
    youngs_modulus: float
    density: float
    poisson_ratio: float = 0.5
    shear_coefficient: float = 1.0
    bending_stiffness: float | None = None
    torsional_stiffness: float | None = None
    axial_stiffness: float | None = None
    shear_stiffness: float | None = None
    extensible_shearable: bool = True
    gravity: tuple = (0.0, 0.0, -9.81)
    base_position: tuple = (0.0, 0.0, 0.0)
    base_rotation: np.ndarray = field(default_factory=lambda: DEFAULT_BASE_ROTATION.copy())
    rigid_segments: tuple = ()
    magnets: tuple = ()
    tendons: tuple = ()

    def __post_init__(self):
        L = positive("length", self.length, "m")
        positive("radius", self.radius, "m")
        positive("youngs_modulus", self.youngs_modulus, "Pa")
        positive("density", self.density, "kg/m^3")
        if isinstance(self.poisson_ratio, bool) or not isinstance(self.poisson_ratio, (int, float)) \
                or not -1.0 < self.poisson_ratio <= 0.5:
            raise bad("poisson_ratio", self.poisson_ratio, "a value in (-1, 0.5]")
        positive("shear_coefficient", self.shear_coefficient, "(dimensionless)")
        for name, unit in (("bending_stiffness", "N m^2"), ("torsional_stiffness", "N m^2"),
                           ("axial_stiffness", "N"), ("shear_stiffness", "N")):
            if getattr(self, name) is not None:
                positive(name, getattr(self, name), unit)
        if not isinstance(self.extensible_shearable, bool):
            raise bad("extensible_shearable", self.extensible_shearable, "True (paper's model) or False (Kirchhoff)")
        object.__setattr__(self, "gravity", tuple(_vector("gravity", self.gravity, "m/s^2").tolist()))
        object.__setattr__(self, "base_position", tuple(_vector("base_position", self.base_position, "m").tolist()))
        R = _vector("base_rotation", self.base_rotation, "(a rotation matrix)", (3, 3))
        if np.abs(R.T @ R - np.eye(3)).max() > 1e-9 or np.linalg.det(R) < 0:
            raise bad("base_rotation", R.round(6).tolist(), "a proper rotation matrix (R^T R = I, det R = 1)")
        object.__setattr__(self, "base_rotation", R)
        self._check_segments(L)
        self._check_magnets(L)
        self._check_tendons(L)

    def _check_segments(self, L: float) -> None:
        segments = tuple(self.rigid_segments)
        for i, seg in enumerate(segments):
            if not isinstance(seg, RigidSegment):
                raise bad(f"rigid_segments[{i}]", seg, "a RigidSegment")
            if seg.s0 < 0.0 or seg.s1 > L:
                raise bad(f"rigid_segments[{i}]", (seg.s0, seg.s1),
                          f"0 <= s0 < s1 <= length = {L:g} m (a rigid segment outside the rod)")
        ordered = sorted(segments, key=lambda seg: seg.s0)
        for a, b in zip(ordered, ordered[1:]):
            if b.s0 < a.s1:
                raise bad("rigid_segments", [(a.s0, a.s1), (b.s0, b.s1)], "segments that do not overlap")
        object.__setattr__(self, "rigid_segments", tuple(ordered))

    def _check_magnets(self, L: float) -> None:
        magnets = tuple(self.magnets)
        for i, mag in enumerate(magnets):
            if not isinstance(mag, PointMagnet):
                raise bad(f"magnets[{i}]", mag, "a PointMagnet")
            _arc_length(f"magnets[{i}].s", mag.s, L, "a magnet")
        object.__setattr__(self, "magnets", magnets)

    def _check_tendons(self, L: float) -> None:
        tendons = tuple(self.tendons)
        names = set()
        for i, td in enumerate(tendons):
            if not isinstance(td, Tendon):
                raise bad(f"tendons[{i}]", td, "a Tendon (softrnn.rod.Tendon)")
            if td.name in names:
                raise bad(f"tendons[{i}].name", td.name, "a name not used by another tendon of the rod")
            names.add(td.name)
            if td.end_node is not None:
                raise bad(f"tendon {td.name!r} end_node", td.end_node,
                          "a termination given as end_s (an arc length in m) for the static rod")
            end = self.tendon_end(td)
            if end > L * (1 + 1e-12):
                raise bad(f"tendon {td.name!r} end_s", td.end_s, f"an arc length in (0, {L:g}] m (the rod length)")
            radii = [self.radius] + [seg.radius for seg in self.rigid_segments
                                     if seg.radius is not None and seg.s0 < end]
            size, limit = math.hypot(*td.offset), min(radii)
            if size > limit * (1 + 1e-12):
                raise bad(f"tendon {td.name!r} offset", td.offset,
                          f"an offset of at most the section radius {limit:g} m from the centreline "
                          f"(|offset| = {size:g} m lies outside the rod)")
        object.__setattr__(self, "tendons", tendons)

    def tendon_end(self, tendon: Tendon) -> float:
        """The termination arc length [m] of one of the rod's tendons (``end_s``, or the tip)."""
        return float(self.length if tendon.end_s is None else min(tendon.end_s, self.length))

    # ------------------------------------------------------------------ section properties
    @property
    def shear_modulus(self) -> float:
        """G [Pa] of the rod material."""
        return self.youngs_modulus / (2.0 * (1.0 + self.poisson_ratio))

    def stiffness(self) -> SectionStiffness:
        """Stiffnesses of the flexible rod: EI, GJ [N m^2], EA, GA (kappa G A) [N]."""
        r, E, G = self.radius, self.youngs_modulus, self.shear_modulus
        area, second = math.pi * r * r, math.pi * r**4 / 4.0
        pick = {"EI": (self.bending_stiffness, E * second), "GJ": (self.torsional_stiffness, 2.0 * G * second),
                "EA": (self.axial_stiffness, E * area),
                "GA": (self.shear_stiffness, self.shear_coefficient * G * area)}
        return SectionStiffness(**{key: float(override if override is not None else default)
                                   for key, (override, default) in pick.items()})

    def segment_stiffness(self, seg: RigidSegment) -> SectionStiffness:
        """Stiffnesses EI, GJ, EA, GA and mass per length ``weight`` [kg/m] of a rigid segment."""
        r = self.radius if seg.radius is None else seg.radius
        nu = self.poisson_ratio if seg.poisson_ratio is None else seg.poisson_ratio
        E = seg.youngs_modulus
        G = E / (2.0 * (1.0 + nu))
        area, second = math.pi * r * r, math.pi * r**4 / 4.0
        return SectionStiffness(EI=E * second, GJ=2.0 * G * second, EA=E * area, GA=self.shear_coefficient * G * area,
                                weight=seg.density * area)

    @property
    def weight_per_length(self) -> float:
        """rho A of the flexible rod [kg/m]."""
        return self.density * math.pi * self.radius**2


@dataclass(frozen=True, kw_only=True, eq=False)
class StaticLoads:
    """The loads of one solve (in addition to the rod's own weight).

    Parameters
    ----------
    point_loads : tuple
        PointLoad entries (world-frame dead forces and torques)
    distributed_force : (3,)
        uniform force per length [N/m], world frame
    magnetic_field : (M, 3) or (3,) or None
        B [T] at each of the rod's M magnets, in the order of ``StaticRod.magnets`` ((3,): the same
        field at all; None: zero)
    field_gradient : (M, 3, 3) or (3, 3) or None
        G [T/m], G[i, j] = dB_i/dx_j, at each magnet (None: uniform field)
    tendon_tensions : (m,) or None
        tension [N] >= 0 of each of the rod's m tendons, in the order of ``StaticRod.tendons``
        (None: each tendon's own tension at t = 0); the entries of tendons driven by a displacement
        are not used
    tendon_displacements : (m,) or None
        displacement [m] (pulled in at the servo; negative: paid out) of each of the rod's m
        tendons, in the order of ``StaticRod.tendons``, for the tendons driven by one (None: each
        one's own displacement at t = 0); the entries of tendons pulled with a tension are not used
    """

    point_loads: tuple = ()
    distributed_force: tuple = (0.0, 0.0, 0.0)
    magnetic_field: np.ndarray | None = None
    field_gradient: np.ndarray | None = None
    tendon_tensions: tuple | None = None
    tendon_displacements: tuple | None = None

    def __post_init__(self):
        loads = tuple(self.point_loads)
        for i, load in enumerate(loads):
            if not isinstance(load, PointLoad):
                raise bad(f"point_loads[{i}]", load, "a PointLoad(s=..., force=(3,), torque=(3,))")
        object.__setattr__(self, "point_loads", loads)
        object.__setattr__(self, "distributed_force", _vector("distributed_force", self.distributed_force, "N/m"))
        for name, tail, unit in (("magnetic_field", (3,), "T"), ("field_gradient", (3, 3), "T/m")):
            value = getattr(self, name)
            if value is None:
                continue
            try:
                a = np.array(value, dtype=float)
            except (TypeError, ValueError):
                raise bad(name, shown(value), f"an array of shape (M, {', '.join(map(str, tail))}) in {unit}") \
                    from None
            if a.shape == tail:
                a = a[None]
            if a.ndim != len(tail) + 1 or a.shape[1:] != tail or not np.isfinite(a).all():
                raise bad(name, shown(value), f"a finite array of shape (M, {', '.join(map(str, tail))}) or "
                                                 f"{tail} in {unit}, one entry per magnet")
            a.setflags(write=False)
            object.__setattr__(self, name, a)
        if self.tendon_tensions is not None:
            try:
                tau = np.array(self.tendon_tensions, dtype=float).reshape(-1)
            except (TypeError, ValueError):
                tau = np.array([np.nan])
            if not np.isfinite(tau).all() or (tau < 0).any():
                raise bad("tendon_tensions", shown(np.asarray(self.tendon_tensions, dtype=object)),
                          "finite tensions >= 0 in N, one per tendon (a tendon cannot push)")
            object.__setattr__(self, "tendon_tensions", tuple(float(x) for x in tau))
        if self.tendon_displacements is not None:
            try:
                q = np.array(self.tendon_displacements, dtype=float).reshape(-1)
            except (TypeError, ValueError):
                q = np.array([np.nan])
            if not np.isfinite(q).all():
                raise bad("tendon_displacements", shown(np.asarray(self.tendon_displacements, dtype=object)),
                          "finite displacements in m, one per tendon (pulled in at the servo: positive)")
            object.__setattr__(self, "tendon_displacements", tuple(float(x) for x in q))
