"""The static solver's load case of the paper's Fig. 13 study (``softrnn.experiments.fig13``), shared
with its benchmark (``softrnn.bench.statics``), with the paper's reported figures of that study.

Load case (documented defaults of docs magnetic.md §1.3, the paper's Fig. 9A is not available):
a PMC-770 rod (L 50 mm, D 3 mm, E 2.5 MPa, nu 0.5, rho 1000 kg/m^3) clamped at the origin along
+x, gravity -z, with two 2 mm NdFeB cubes as rigid segments (E 41.4 GPa, nu 0.3): N42 centred at
L/2 and N45 centred at L - 1 mm, both magnetised along the tangent (mu = Br V / mu0 with Br 1.30 T
and 1.35 T), in a 20 mT field along +z with a weak gradient (below). The field lifts the rod
against gravity to a tip angle of about 42 deg.
"""

import math

from .rod import PointMagnet, RigidSegment, StaticLoads, StaticRod

PAPER_FIG13 = {
    "source": "Tariverdi et al. 2021, Front. Robot. AI 8:631303, Sec. 5.2 and Figure 13 (static Cosserat BVP, "
              "RK4 + Levenberg-Marquardt); bandwidth from the text (8.33-50 Hz), 13 nodes in the experiment",
    "bandwidth_hz": [8.33, 50.0],
    "solve_time_ms": [20.0, 120.0],
    "nodes": 13,
    "repetitions": 50,
    "guess_errors_percent": [0, 10],
    "hardware": "16 GB, 1.99 GHz Intel i7 laptop, Windows 10",
    "note": "the figure's individual points are not in the text; only the bandwidth range is",
}

MU0 = 4e-7 * math.pi
MAGNET_SIDE = 2e-3            # m, cube
MAGNET_DENSITY = 7000.0       # kg/m^3 (paper)
MAGNET_YOUNGS_MODULUS = 41.4e9
MAGNET_POISSON_RATIO = 0.3
REMANENCE = {"N42": 1.30, "N45": 1.35}  # T, nominal (magnetic.md §3)
FIELD = (0.0, 0.0, 0.020)     # T at both magnets
# weak, symmetric and traceless gradient [T/m] (curl- and divergence-free), ~ a coil system's
GRADIENT = ((0.05, 0.0, 0.02), (0.0, -0.025, 0.0), (0.02, 0.0, -0.025))


def magnetic_rod(length: float = 0.05, diameter: float = 3e-3, gravity=(0.0, 0.0, -9.81)) -> StaticRod:
    """The magnetic manipulator of the paper's experiment with the defaults of magnetic.md §1.3.

    Each magnet is a rigid segment of the cube's length over the rod's section; its density is
    the section's mean (cube of NdFeB plus the surrounding PMC), so the segment weighs what the
    magnet and its embedding weigh.
    """
    r = diameter / 2
    area = math.pi * r * r
    cube = MAGNET_SIDE**3
    section_volume = area * MAGNET_SIDE
    density = (MAGNET_DENSITY * cube + 1000.0 * max(section_volume - cube, 0.0)) / section_volume
    centres = {"N42": length / 2, "N45": length - MAGNET_SIDE / 2}
    segments = tuple(RigidSegment(s0=c - MAGNET_SIDE / 2, s1=c + MAGNET_SIDE / 2, youngs_modulus=MAGNET_YOUNGS_MODULUS,
                                  density=density, poisson_ratio=MAGNET_POISSON_RATIO) for c in centres.values())
    magnets = tuple(PointMagnet(s=c, moment_body=(0.0, 0.0, REMANENCE[grade] * cube / MU0))
                    for grade, c in centres.items())
    return StaticRod(length=length, radius=r, youngs_modulus=2.5e6, density=1000.0, poisson_ratio=0.5,
                     gravity=gravity, rigid_segments=segments, magnets=magnets)


def magnetic_loads(field=FIELD, gradient=GRADIENT) -> StaticLoads:
    """The study's field B (3,) [T] and gradient G (3, 3) [T/m], the same at both magnets."""
    return StaticLoads(magnetic_field=field, field_gradient=gradient)
