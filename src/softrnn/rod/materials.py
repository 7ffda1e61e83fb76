"""Devices of several materials: a rod's material table of sections along its arc length
(``MaterialSection``), its check (the sections tile the rod) and its lumping into the arrays of the
integrators (docs/guide/simulator.md, "Devices of several materials").

A section from arc length start to end [m] holds a circular or tubular cross-section and a linear-elastic material;
what it leaves unset comes from the rod (``RodSpec``). Lumping integrates the sections exactly:
node a carries the mass rho A and rotary inertia rho I of its share of the rod
[s_a - l/2, s_a + l/2] (cut at the ends), and a segment that straddles a boundary the series
(compliance-weighted) stiffness of its parts, exact for a constant stress resultant along it.
"""

import math
from dataclasses import dataclass

import numpy as np

from ..errors import bad, finite, positive

_COVER_RTOL = 1e-9
"""Boundaries closer than this fraction of the rod's length count as meeting (rounding)."""


@dataclass(frozen=True, kw_only=True)
class MaterialSection:
    """The cross-section and material of the rod between arc lengths ``start`` and ``end`` [m].

    Attributes
    ----------
    start, end : float
        Arc lengths from the rod's first node [m], 0 <= start < end.
    radius : float or None
        Outer radius [m] (None: the rod's).
    inner_radius : float
        Inner radius [m] of a tube, 0 for a solid section.
    youngs_modulus : float or None
        E [Pa] (None: the rod's); an effective value for a composite section (E I / (pi r^4 / 4)).
    poisson_ratio : float or None
        nu (None: the rod's); G = E / (2 (1 + nu)) unless ``shear_modulus`` is set.
    shear_modulus : float or None
        G [Pa]; None: from E and nu when the section sets either, else the rod's G.
    density : float or None
        rho [kg/m^3] (None: the rod's).
    """

    start: float
    end: float
    radius: float | None = None
    inner_radius: float = 0.0
    youngs_modulus: float | None = None
    poisson_ratio: float | None = None
    shear_modulus: float | None = None
    density: float | None = None

    def __post_init__(self):
        finite("section.start", self.start, "m")
        finite("section.end", self.end, "m")
        if self.start < 0 or self.end <= self.start:
            raise bad("section [start, end]", [self.start, self.end], "0 <= start < end, arc lengths in m")
        for name, unit in (("radius", "m"), ("youngs_modulus", "Pa"), ("shear_modulus", "Pa"),
                           ("density", "kg/m^3")):
            value = getattr(self, name)
            if value is not None:
                positive(f"section.{name}", value, unit)
        if not (isinstance(self.inner_radius, (int, float)) and 0.0 <= self.inner_radius < math.inf):
            raise bad("section.inner_radius", self.inner_radius, "a radius >= 0 in m (0: a solid section)")
        if self.radius is not None and self.inner_radius >= self.radius:
            raise bad("section.inner_radius", self.inner_radius, f"a radius below the outer radius {self.radius} m")
        if self.poisson_ratio is not None and not (-1.0 < self.poisson_ratio <= 0.5):
            raise bad("section.poisson_ratio", self.poisson_ratio, "a value in (-1, 0.5]")


def _section_key(i: int, which: str) -> str:
    return f"sections[{i}].{which}"


def check_cover(spans, length: float, key=_section_key) -> None:
    """Raise a one-line ``SoftrnnInputError`` unless the (start, end) ``spans`` [m], in order along
    the rod, tile [0, ``length``] with no gap and no overlap; ``key(i, "start" | "end")`` names a
    span's boundary in the message (default ``sections[i].start``)."""
    tol = _COVER_RTOL * length
    spans = [(float(f"{a:.12g}"), float(f"{b:.12g}")) for a, b in spans]  # messages without rounding noise
    fix = f"sections in order along the rod that tile [0, {length:g}] m, each starting where the one before ends"
    if not spans:
        raise bad(key(0, "start"), None, f"at least one section; {fix}")
    if abs(spans[0][0]) > tol:
        raise bad(key(0, "start"), spans[0][0], f"0 (the sections leave [0, {spans[0][0]:g}] m uncovered); {fix}")
    for i in range(1, len(spans)):
        prev, here = spans[i - 1][1], spans[i][0]
        if here < prev - tol:
            raise bad(key(i, "start"), here, f"{prev:g}, where {key(i - 1, 'end')} ends (the sections "
                                              f"overlap); {fix}")
        if here > prev + tol:
            raise bad(key(i, "start"), here, f"{prev:g}, where {key(i - 1, 'end')} ends (a gap "
                                              f"[{prev:g}, {here:g}] m); {fix}")
    end = spans[-1][1]
    if abs(end - length) > tol:
        what = "it reaches beyond the rod's end" if end > length else f"[{end:g}, {length:g}] m uncovered"
        raise bad(key(len(spans) - 1, "end"), end, f"the rod's length {length:g} ({what}); {fix}")


def section_values(spec) -> dict[str, np.ndarray]:
    """Per-section values of a ``RodSpec`` with sections, the rod's filling what a section leaves
    unset: ``edges`` (S + 1,) [m] and ``radius``, ``inner``, ``E``, ``G``, ``rho`` (S,)."""
    secs = spec.sections
    edges = np.array([0.0] + [s.end for s in secs[:-1]] + [spec.length])
    out = {"edges": edges, "radius": np.empty(len(secs)), "inner": np.empty(len(secs)), "E": np.empty(len(secs)),
           "G": np.empty(len(secs)), "rho": np.empty(len(secs))}
    for i, s in enumerate(secs):
        E = spec.youngs_modulus if s.youngs_modulus is None else s.youngs_modulus
        if s.shear_modulus is not None:
            G = s.shear_modulus
        elif s.youngs_modulus is None and s.poisson_ratio is None:
            G = spec.shear
        else:
            G = E / (2.0 * (1.0 + (spec.poisson_ratio if s.poisson_ratio is None else s.poisson_ratio)))
        out["radius"][i] = spec.radius if s.radius is None else s.radius
        out["inner"][i] = s.inner_radius
        out["E"][i], out["G"][i] = E, G
        out["rho"][i] = spec.density if s.density is None else s.density
    if np.any(out["inner"] >= out["radius"]):
        i = int(np.argmax(out["inner"] >= out["radius"]))
        raise bad(f"sections[{i}].inner_radius", secs[i].inner_radius, f"a radius below the outer radius "
                                                                         f"{out['radius'][i]:g} m")
    return out


def _overlaps(lo: np.ndarray, hi: np.ndarray, edges: np.ndarray) -> np.ndarray:
    """Length [m] of each interval [lo_k, hi_k] inside each section [edges_i, edges_i+1]: (K, S)."""
    a = np.maximum(lo[:, None], edges[None, :-1])
    b = np.minimum(hi[:, None], edges[None, 1:])
    return np.maximum(b - a, 0.0)


def _moments(v: dict) -> tuple[np.ndarray, np.ndarray]:
    """Area A (S,) [m^2] and second moment I (S,) [m^4] of each section (tubes included)."""
    ro, ri = v["radius"], v["inner"]
    return np.pi * (ro ** 2 - ri ** 2), np.pi * (ro ** 4 - ri ** 4) / 4.0


def section_node_properties(spec) -> dict[str, np.ndarray]:
    """Per-node radius, inner radius, E, G, rho (n,) of a rod with sections: those of the section
    that covers most of the node's share [s_a - l/2, s_a + l/2] (a tie: the nearer the base)."""
    v = section_values(spec)
    n, l = spec.n_nodes, spec.segment_length
    s = np.arange(n) * l
    share = _overlaps(np.maximum(s - 0.5 * l, 0.0), np.minimum(s + 0.5 * l, spec.length), v["edges"])
    pick = np.argmax(share, axis=1)
    return {"radius": v["radius"][pick], "inner": v["inner"][pick], "E": v["E"][pick], "G": v["G"][pick],
            "rho": v["rho"][pick]}


def section_lumped(spec, weight: np.ndarray, props: dict) -> dict[str, np.ndarray]:
    """The lumped arrays of ``RodSpec.lumped`` for a rod with sections (module docstring): mass (n,)
    [kg] and inertia (n, 3) [kg m^2] integrated over each node's share, C1, C2 (n - 1, 3) the
    series stiffness of each segment's parts; nodes and segments of a ``NodeOverride`` then take
    ``props`` (per-node values after the overrides, as ``RodSpec.node_properties``) as a uniform rod
    does."""
    v = section_values(spec)
    n, l, L = spec.n_nodes, spec.segment_length, spec.length
    s = np.arange(n) * l
    A, I = _moments(v)
    share = _overlaps(np.maximum(s - 0.5 * l, 0.0), np.minimum(s + 0.5 * l, L), v["edges"])
    mass = share @ (v["rho"] * A)
    inertia = (share @ (v["rho"] * I))[:, None] * np.array([1.0, 1.0, 2.0])
    k = spec.shear_coefficient
    C1s = np.stack([k * v["G"] * A, k * v["G"] * A, v["E"] * A], -1)
    C2s = np.stack([v["E"] * I, v["E"] * I, v["G"] * 2.0 * I], -1)
    frac = _overlaps(s[:-1], np.minimum(s[1:], L), v["edges"]) / l
    frac = frac / frac.sum(axis=1, keepdims=True)
    whole = frac.max(axis=1) >= 1.0 - 1e-12
    C1 = np.where(whole[:, None], C1s[np.argmax(frac, axis=1)], 1.0 / (frac @ (1.0 / C1s)))
    C2 = np.where(whole[:, None], C2s[np.argmax(frac, axis=1)], 1.0 / (frac @ (1.0 / C2s)))
    ro, ri = props["radius"], props["inner"]
    An, In = np.pi * (ro ** 2 - ri ** 2), np.pi * (ro ** 4 - ri ** 4) / 4.0
    for o in spec.overrides:
        nodes = slice(o.first, o.last + 1)
        mass[nodes] = weight[nodes] * props["rho"][nodes] * An[nodes] * l
        inertia[nodes] = (weight[nodes] * l * props["rho"][nodes] * In[nodes])[:, None] * np.array([1.0, 1.0, 2.0])
        seg = slice(o.first, o.last)
        G, E = props["G"][seg], props["E"][seg]
        C1[seg] = np.stack([k * G * An[seg], k * G * An[seg], E * An[seg]], -1)
        C2[seg] = np.stack([E * In[seg], E * In[seg], G * 2.0 * In[seg]], -1)
    return {"weight": weight, "mass": mass, "inertia": inertia, "C1": C1, "C2": C2}
