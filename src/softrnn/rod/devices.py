"""Endovascular devices built of several materials: ``guidewire`` (a metal core with a soft,
pre-shaped distal tip) as a rod (``RodSpec`` with ``rod.materials`` sections) and its stress-free
shape (docs/guide/simulator.md, "Devices of several materials").

A guidewire's section is a core wire in a polymer jacket of the wire's outer radius. The rod takes
the outer radius (contact and drag see it) and the section's effective values: E = sum E_i I_i / I,
G = sum G_i J_i / J and rho = sum rho_i A_i / A over core and jacket. Toward the tip the core
tapers in steps to a thin distal core, so the tip bends 10-100 times more easily than the body.
"""

import math
from dataclasses import dataclass

from ..errors import bad, integer, positive
from .materials import MaterialSection
from .shapes import Bend, RodShape, curved
from .spec import RodSpec


@dataclass(frozen=True)
class Material:
    """A linear-elastic material: E [Pa], nu [-], rho [kg/m^3]."""

    youngs_modulus: float
    poisson_ratio: float
    density: float


CORE_MATERIALS = {
    "nitinol": Material(60e9, 0.33, 6450.0),   # austenitic, below the superelastic plateau
    "steel": Material(200e9, 0.30, 7850.0),    # stainless 304
}
"""Core materials of ``guidewire`` by name."""

JACKET = Material(30e6, 0.45, 1200.0)
"""The polymer jacket of ``guidewire`` (a polyurethane)."""

TIP_SHAPES = {
    "straight": None,
    "angled": (45.0, 0.015, 0.005),             # degrees, bend length [m], straight tip beyond it [m]
    "j": (180.0, math.pi * 0.005, 0.0),         # a J of radius 5 mm
}
"""Shaped tips of ``guidewire``: (angle [deg], bend length [m], straight tip [m]) or None."""


@dataclass(frozen=True)
class Device:
    """A device's rod (``RodSpec``, with its material sections) and stress-free ``reference`` shape."""

    rod: RodSpec
    reference: RodShape


def composite_section(start: float, end: float, outer_radius: float, core_radius: float, core: Material,
                      jacket: Material = JACKET) -> MaterialSection:
    """The ``MaterialSection`` from ``start`` to ``end`` [m] of a core of ``core_radius`` [m] in a jacket out to
    ``outer_radius`` [m], with the effective E, G and rho of the module docstring."""
    ro4, rc4 = outer_radius ** 4, core_radius ** 4
    ro2, rc2 = outer_radius ** 2, core_radius ** 2
    g_core = core.youngs_modulus / (2.0 * (1.0 + core.poisson_ratio))
    g_jacket = jacket.youngs_modulus / (2.0 * (1.0 + jacket.poisson_ratio))
    return MaterialSection(start=start, end=end, radius=outer_radius,
                           youngs_modulus=(core.youngs_modulus * rc4 + jacket.youngs_modulus * (ro4 - rc4)) / ro4,
                           shear_modulus=(g_core * rc4 + g_jacket * (ro4 - rc4)) / ro4,
                           density=(core.density * rc2 + jacket.density * (ro2 - rc2)) / ro2)


def guidewire(length: float = 1.0, n_nodes: int = 201, *, radius: float = 0.45e-3, core: str = "nitinol",
              core_radius: float = 0.2e-3, tip_core_radius: float = 0.05e-3, tip_length: float = 0.04,
              taper_length: float = 0.06, taper_steps: int = 2, shape: str = "angled", toward_deg: float = 0.0,
              bend: tuple | None = None, origin=(0.0, 0.0, 0.0), direction=(0.0, 0.0, 1.0),
              normal=(1.0, 0.0, 0.0)) -> Device:
    """A guidewire of ``length`` [m] from ``origin`` along ``direction``: a ``core`` wire (a name of
    ``CORE_MATERIALS``) of ``core_radius`` [m] in a polymer jacket of outer ``radius`` [m] (default:
    0.035 inch), the core tapering in ``taper_steps`` steps over ``taper_length`` [m] to
    ``tip_core_radius`` [m] along the soft distal ``tip_length`` [m], and the tip pre-shaped by
    ``shape`` (``TIP_SHAPES``: straight, angled or j; ``bend``: its own (angle [deg], bend length
    [m], straight tip beyond it [m]) instead) toward ``toward_deg`` (``shapes.Bend``; 0: toward
    ``normal``). The tip's bend must span at least 3 of the n_nodes - 1 segments."""
    integer("n_nodes", n_nodes, 2)
    integer("taper_steps", taper_steps, 0)
    for name, value in (("length", length), ("radius", radius), ("core_radius", core_radius),
                        ("tip_core_radius", tip_core_radius), ("tip_length", tip_length)):
        positive(name, value, "m")
    if core not in CORE_MATERIALS:
        raise bad("core", core, f"one of {', '.join(CORE_MATERIALS)}")
    if shape not in TIP_SHAPES:
        raise bad("shape", shape, f"one of {', '.join(TIP_SHAPES)}")
    tip_bend = TIP_SHAPES[shape] if bend is None else tuple(bend)
    if tip_bend is not None and (len(tip_bend) != 3 or not (tip_bend[0] > 0 and tip_bend[1] > 0 and tip_bend[2] >= 0)
                                 or tip_bend[1] + tip_bend[2] > length):
        raise bad("bend", bend, "(angle > 0 in degrees, bend length > 0 in m, straight tip >= 0 in m) within the wire")
    if not tip_core_radius <= core_radius < radius:
        raise bad("core radii", (tip_core_radius, core_radius), f"tip_core_radius <= core_radius < radius = {radius}")
    taper = taper_length if taper_steps else 0.0
    if taper < 0 or tip_length + taper >= length:
        raise bad("tip_length + taper_length", tip_length + taper, f"a length below the wire's {length:g} m")
    mat = CORE_MATERIALS[core]
    body_end = length - tip_length - taper
    sections = [composite_section(0.0, body_end, radius, core_radius, mat)]
    for i in range(taper_steps):
        rc = core_radius + (tip_core_radius - core_radius) * (i + 1) / (taper_steps + 1)
        sections.append(composite_section(body_end + taper * i / taper_steps, body_end + taper * (i + 1) / taper_steps,
                                          radius, rc, mat))
    sections.append(composite_section(length - tip_length, length, radius, tip_core_radius, mat))
    body = sections[0]
    rod = RodSpec(length=length, radius=radius, youngs_modulus=body.youngs_modulus, density=body.density,
                  n_nodes=n_nodes, poisson_ratio=mat.poisson_ratio, shear_modulus=body.shear_modulus,
                  sections=tuple(sections))
    bends = ()
    if tip_bend is not None:
        angle, bend_length, straight_tip = tip_bend
        if bend_length < 3.0 * rod.segment_length * (1.0 - 1e-9):
            need = math.ceil(3.0 * length / bend_length) + 1
            raise bad("n_nodes", n_nodes, f"at least {need} nodes, so that the {shape} tip's bend of "
                                          f"{bend_length * 1e3:.3g} mm spans 3 segments")
        end = length - straight_tip
        bends = (Bend(end - bend_length, end, math.radians(angle) / bend_length, toward_deg),)
    return Device(rod, curved(n_nodes, length, bends, origin=origin, direction=direction, normal=normal))
