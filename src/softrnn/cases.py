"""The paper's three simulated cases (Tariverdi et al. 2021, section 4) and their variants.

Every value the paper leaves out is an assumption, chosen here in one place with its reason
(``ASSUMPTIONS``); reports quote this table. Node numbers are 0-based. The ellipse's node of interest is
node 30 (0-based, neighbours 29 and 31 as in the paper's text): at (-0.023, -0.599) m, one node past
the bottom, the closest node to the paper's stated (-0.01, -0.59) with x != 0; the middle node 29
stays on the symmetry axis. The semicircle's is the middle node 50 (the paper's 1-based 51).

Material, all cases (assumption): the urethane rubber of the paper's own experiment (section 5,
PMC-770: E = 2.5 MPa, nu = 0.5, rho = 1000 kg/m^3), so the three simulations describe the same
kind of soft polymer rod as the hardware.
"""

from dataclasses import dataclass, replace

import numpy as np

from .errors import bad
from .rod import (Clamp, Constant, Damping, NodalLoad, PDTracking, RodSpec, RunConfig, Setup, SquarePath,
                  Window, arc, ellipse, straight)
from .rod.loads import CirclePath, Sinusoid
from .rod.shapes import ellipse_perimeter

E_RUBBER = 2.5e6  # Pa, PMC-770 (paper section 5)
NU_RUBBER = 0.5
RHO_RUBBER = 1000.0  # kg/m^3
AIR_DRAG = 0.01  # N s/m^2: light viscous drag, free oscillations decay over ~10 s (assumption)
AIR_DRAG_ROT = 1e-6  # N s: matching rotational drag per length (assumption)

ASSUMPTIONS = {
    "material": "E = 2.5 MPa, nu = 0.5, rho = 1000 kg/m^3 for every case: the PMC-770 urethane of the "
                "paper's experiment (section 5); the paper does not give the simulated rods' properties",
    "damping": f"viscous drag c_t = {AIR_DRAG} N s/m^2 and c_r = {AIR_DRAG_ROT} N s per unit length: a light "
               "environment drag so free motion decays over ~10-20 s and the data still oscillates in the "
               "test span; no Kelvin-Voigt damping (its explicit form would force a much smaller step)",
    "ellipse": "closed rod of length = perimeter of the 0.2 m x 0.6 m ellipse (1.336 m; the paper's errors "
               "give 1.34 m), radius 5 mm, straight stress-free reference (a straight rod bent into a loop), "
               "both end nodes clamped at the origin with the ellipse's tangent frame there (the paper's "
               "Ry(+-18.07 deg) match the direction of the first/last chord, 19.8 deg off the tangent for "
               "59 nodes); no gravity (planar elastica)",
    "square": "rod length 0.5 m (from the paper's errors), 51 nodes, radius 10 mm, clamped at the origin "
              "pointing along +x; a PD force on the tip (stiffness 5 N/m, damping 1 N s/m) pulls it toward "
              "a target moving around a 0.2 m square in the yz-plane (one lap per 8 s, 1 s smooth start); "
              "no gravity",
    "semicircle": "rod length 0.6 m (from the paper's errors), 101 nodes, radius 20 mm (a thinner rubber "
                  "rod sags by more than 10 cm under its weight), stress-free "
                  "semicircle in the horizontal xy-plane clamped at both ends; a 1 N push along -y on the "
                  "middle node (node 50, the paper's 51) for t in [0, 0.5) s; gravity -9.81 m/s^2 along z "
                  "(the arch sags and swings out of plane, as the paper's large z errors suggest)",
}


@dataclass(frozen=True)
class Case:
    """A named simulation: its setup, how to run it, the node of interest and its provenance."""

    name: str
    title: str
    setup: Setup
    config: RunConfig
    node_of_interest: int
    paper_key: str
    paper_section: str


def _rubber(length: float, radius: float, n_nodes: int) -> RodSpec:
    return RodSpec(length=length, radius=radius, youngs_modulus=E_RUBBER, density=RHO_RUBBER,
                   n_nodes=n_nodes, poisson_ratio=NU_RUBBER)


def _drag() -> Damping:
    return Damping(translational=AIR_DRAG, rotational=AIR_DRAG_ROT)


def _ellipse(name: str, width: float, height: float, title: str) -> Case:
    n = 59
    length = ellipse_perimeter(0.2, 0.6)
    rod = _rubber(length, 0.005, n)
    reference = straight(n, length, direction=(1.0, 0.0, 0.0), normal=(0.0, 1.0, 0.0))
    initial = ellipse(n, width, height)
    setup = Setup(rod=rod, reference=reference, initial=initial, boundary=(Clamp(0), Clamp(n - 1)),
                  damping=_drag())
    return Case(name, title, setup, RunConfig(dt=1e-3, n_samples=50001), node_of_interest=30,
                paper_key="ellipse", paper_section="4.1")


def _square(name: str, target, title: str) -> Case:
    n = 51
    rod = _rubber(0.5, 0.01, n)
    shape = straight(n, 0.5, direction=(1.0, 0.0, 0.0), normal=(0.0, 0.0, 1.0))
    setup = Setup(rod=rod, reference=shape, boundary=(Clamp(0),),
                  loads=(PDTracking(n - 1, target, stiffness=5.0, damping=1.0),), damping=_drag())
    return Case(name, title, setup, RunConfig(dt=1e-4, n_samples=160001), node_of_interest=n - 1,
                paper_key="square_tip", paper_section="4.2")


def _semicircle(name: str, load: NodalLoad, title: str) -> Case:
    n = 101
    length = 0.6
    shape = arc(n, length, length / np.pi, tangent=(0.0, 1.0, 0.0), inward=(1.0, 0.0, 0.0))
    setup = Setup(rod=_rubber(length, 0.02, n), reference=shape, boundary=(Clamp(0), Clamp(n - 1)),
                  loads=(load,), damping=_drag(), gravity=(0.0, 0.0, -9.81))
    return Case(name, title, setup, RunConfig(dt=1e-4, n_samples=20001), node_of_interest=50,
                paper_key="semicircle", paper_section="4.3")


def _build(name: str) -> Case:
    if name == "ellipse":
        return _ellipse(name, 0.2, 0.6, "Released vertical ellipse (paper 4.1, Data-set I)")
    if name == "ellipse-horizontal":
        return _ellipse(name, 0.6, 0.2, "Released horizontal ellipse (paper 4.1 generalisation)")
    if name == "square":
        return _square(name, SquarePath(center=(0.5, 0.0, 0.0), side=0.2, period=8.0),
                       "Tip tracking a square by PD forces (paper 4.2, Data-set II)")
    if name == "square-circle":
        return _square(name, CirclePath(center=(0.5, 0.0, 0.0), radius=0.1, period=6.0),
                       "Tip tracking a circle (paper 4.2 generalisation: another force profile)")
    if name == "semicircle":
        push = NodalLoad(50, force=Window(Constant((0.0, -1.0, 0.0)), 0.0, 0.5))
        return _semicircle(name, push, "Semicircle pushed at its middle node (paper 4.3, Data-set III)")
    if name == "semicircle-cosine":
        load = NodalLoad(50, force=Window(Sinusoid((0.0, 0.0, -0.1), 0.5, phase=np.pi / 2), 1.0, 2.0 + 1e-9))
        return _semicircle(name, load, "Semicircle, force [0, 0, -100 cos(pi t)] mN on t in [1, 2] s "
                                       "(paper 4.3 generalisation)")
    raise bad("case", name, f"one of {', '.join(CASE_NAMES)}")


CASE_NAMES = ("ellipse", "ellipse-horizontal", "square", "square-circle", "semicircle", "semicircle-cosine")
PAPER_CASES = ("ellipse", "square", "semicircle")


def build_case(name: str) -> Case:
    """The named case; raises SoftrnnInputError for an unknown name."""
    return _build(name)


def with_overrides(case: Case, *, rod: dict | None = None, dt: float | None = None) -> Case:
    """The case with rod properties (RodSpec field names) and/or the saved interval replaced;
    the new values are validated like any RodSpec / RunConfig."""
    setup = case.setup
    if rod:
        setup = replace(setup, rod=replace(setup.rod, **rod))
    config = case.config if dt is None else replace(case.config, dt=dt)
    return replace(case, setup=setup, config=config)
