"""Rod specification: geometry, material, material sections along the rod and per-node overrides
(frozen, validated).

Lumping follows docs/lgvi.md §2.2: n nodes, n - 1 segments of length l = L / (n - 1); node
masses and rotary inertias use the trapezoid rule (half weight at both ends). A rod of several
materials (``sections``, ``rod.materials``) integrates its sections over each node's share instead.
"""

from dataclasses import dataclass, field

import numpy as np

from ..errors import bad, is_int, positive
from .materials import MaterialSection, check_cover, section_lumped, section_node_properties


@dataclass(frozen=True, kw_only=True)
class NodeOverride:
    """Different section or material on nodes ``first..last`` (inclusive, 0-based), e.g. a magnet.

    Node masses and inertias of those nodes use the override; a segment whose two nodes are both
    inside the range uses the override's stiffness.
    """

    first: int
    last: int
    radius: float | None = None
    youngs_modulus: float | None = None
    poisson_ratio: float | None = None
    density: float | None = None

    def __post_init__(self):
        if (not isinstance(self.first, int) or not isinstance(self.last, int) or self.first < 0
                or self.last < self.first):
            raise bad("override nodes", (self.first, self.last), "0 <= first <= last node indices")
        for name, unit in (("radius", "m"), ("youngs_modulus", "Pa"), ("density", "kg/m^3")):
            value = getattr(self, name)
            if value is not None:
                positive(f"override.{name}", value, unit)
        if self.poisson_ratio is not None and not (-1.0 < self.poisson_ratio <= 0.5):
            raise bad("override.poisson_ratio", self.poisson_ratio, "a value in (-1, 0.5]")


@dataclass(frozen=True, kw_only=True)
class RodSpec:
    """A circular-section Cosserat rod.

    Parameters
    ----------
    length : float
        undeformed length L [m]
    radius : float
        section radius r [m]
    youngs_modulus : float
        E [Pa]
    density : float
        rho [kg/m^3]
    n_nodes : int
        number of nodes n >= 2 (n - 1 segments)
    poisson_ratio : float
        nu, gives G = E / (2 (1 + nu)) unless ``shear_modulus`` is set
    shear_modulus : float
        G [Pa], overrides ``poisson_ratio``
    shear_coefficient : float
        Timoshenko shear coefficient kappa (1 as in the LGVI references)
    overrides : tuple
        NodeOverride entries (embedded magnets, rigid segments)
    sections : tuple
        MaterialSection entries in order along the rod that tile [0, L] (a device of several
        materials; empty: one material). A section's unset values are the rod's; overrides apply
        on top of them.
    """

    length: float
    radius: float
    youngs_modulus: float
    density: float
    n_nodes: int
    poisson_ratio: float = 0.5
    shear_modulus: float | None = None
    shear_coefficient: float = 1.0
    overrides: tuple[NodeOverride, ...] = field(default_factory=tuple)
    sections: tuple[MaterialSection, ...] = field(default_factory=tuple)

    def __post_init__(self):
        positive("length", self.length, "m")
        positive("radius", self.radius, "m")
        positive("youngs_modulus", self.youngs_modulus, "Pa")
        positive("density", self.density, "kg/m^3")
        if not is_int(self.n_nodes) or self.n_nodes < 2:
            raise bad("n_nodes", self.n_nodes, "an integer >= 2 (a rod needs at least one segment)")
        if not (-1.0 < self.poisson_ratio <= 0.5):
            raise bad("poisson_ratio", self.poisson_ratio, "a value in (-1, 0.5]")
        if self.shear_modulus is not None:
            positive("shear_modulus", self.shear_modulus, "Pa")
        positive("shear_coefficient", self.shear_coefficient, "(dimensionless)")
        if self.radius >= self.length:
            raise bad("radius", self.radius, f"a radius smaller than the length {self.length} m (a rod is slender)")
        object.__setattr__(self, "overrides", tuple(self.overrides))
        for o in self.overrides:
            if not isinstance(o, NodeOverride):
                raise bad("overrides", o, "NodeOverride entries")
            if o.last >= self.n_nodes:
                raise bad("override.last", o.last, f"a node index below n_nodes={self.n_nodes}")
        object.__setattr__(self, "sections", tuple(self.sections))
        if self.sections:
            for i, sec in enumerate(self.sections):
                if not isinstance(sec, MaterialSection):
                    raise bad(f"sections[{i}]", sec, "MaterialSection entries")
            check_cover([(sec.start, sec.end) for sec in self.sections], self.length)
            self.node_properties()  # every section's radius above its inner radius

    @property
    def segment_length(self) -> float:
        """l = L / (n - 1) [m]."""
        return self.length / (self.n_nodes - 1)

    @property
    def shear(self) -> float:
        """G [Pa]."""
        if self.shear_modulus is not None:
            return self.shear_modulus
        return self.youngs_modulus / (2.0 * (1.0 + self.poisson_ratio))

    def node_properties(self) -> dict[str, np.ndarray]:
        """Per-node radius [m], inner (tube) radius [m], E [Pa], G [Pa], rho [kg/m^3], each (n,),
        after overrides (with sections: those of the section that covers most of the node's share
        of the rod, ``rod.materials.section_node_properties``)."""
        n = self.n_nodes
        if self.sections:
            p = section_node_properties(self)
            radius, inner, E, G, rho = p["radius"], p["inner"], p["E"], p["G"], p["rho"]
        else:
            radius = np.full(n, float(self.radius))
            inner = np.zeros(n)
            E = np.full(n, float(self.youngs_modulus))
            G = np.full(n, float(self.shear))
            rho = np.full(n, float(self.density))
        for o in self.overrides:
            sl = slice(o.first, o.last + 1)
            if o.radius is not None:
                radius[sl] = o.radius
                inner[sl] = 0.0
            if o.youngs_modulus is not None:
                E[sl] = o.youngs_modulus
                nu = self.poisson_ratio if o.poisson_ratio is None else o.poisson_ratio
                G[sl] = o.youngs_modulus / (2.0 * (1.0 + nu))
            elif o.poisson_ratio is not None:
                G[sl] = E[sl] / (2.0 * (1.0 + o.poisson_ratio))
            if o.density is not None:
                rho[sl] = o.density
        return {"radius": radius, "inner": inner, "E": E, "G": G, "rho": rho}

    def lumped(self) -> dict[str, np.ndarray]:
        """Lumped arrays used by the integrator.

        Returns
        -------
        dict of str -> ndarray
            ``weight`` (n,): trapezoid weights w_a (1/2 at the ends);
            ``mass`` (n,): m_a = w_a rho A l [kg];
            ``inertia`` (n, 3): J_a = w_a l rho diag(I, I, 2I) [kg m^2];
            ``C1`` (n-1, 3): diag(kappa G A, kappa G A, E A) per segment [N];
            ``C2`` (n-1, 3): diag(E I, E I, G J) per segment [N m^2].
            With ``sections`` the masses and stiffnesses integrate the sections
            (``rod.materials.section_lumped``).
        """
        n, l = self.n_nodes, self.segment_length
        p = self.node_properties()
        w = np.ones(n)
        w[0] = w[-1] = 0.5
        if self.sections:
            return section_lumped(self, w, p)
        area = np.pi * p["radius"] ** 2
        second = np.pi * p["radius"] ** 4 / 4.0
        mass = w * p["rho"] * area * l
        inertia = (w * l * p["rho"] * second)[:, None] * np.array([1.0, 1.0, 2.0])
        # a segment takes the override only if both its nodes carry it: use the softer neighbour
        seg = {}
        for key in ("radius", "E", "G"):
            seg[key] = np.minimum(p[key][:-1], p[key][1:])
        for o in self.overrides:
            sl = slice(o.first, o.last)  # segments first .. last - 1 lie inside the range
            for key in ("radius", "E", "G"):
                seg[key][sl] = p[key][o.first:o.last]
        A_s = np.pi * seg["radius"] ** 2
        I_s = np.pi * seg["radius"] ** 4 / 4.0
        k = self.shear_coefficient
        C1 = np.stack([k * seg["G"] * A_s, k * seg["G"] * A_s, seg["E"] * A_s], -1)
        C2 = np.stack([seg["E"] * I_s, seg["E"] * I_s, seg["G"] * 2.0 * I_s], -1)
        return {"weight": w, "mass": mass, "inertia": inertia, "C1": C1, "C2": C2}
