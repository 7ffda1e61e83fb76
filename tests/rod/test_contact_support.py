"""The lifted heavy beam: a heavy rod lying on a rigid plane, lifted at one end by a clamp (held
horizontal) to the height h, at rest, against linear (Euler-Bernoulli) beam theory with a rigid,
unilateral support.

Theory. With x from the clamp, y the height above the lying rod's centreline, w = rho A g the weight
per length and a the lifted (suspended) length: EI y'''' = -w on [0, a] with y(0) = h, y'(0) = 0 at
the clamp and y(a) = y'(a) = y''(a) = 0 at touchdown (it lies flat beyond, and touchdown is free, so
the moment vanishes there too). In s = a - x from touchdown, y = -w s^4 / (24 EI) + w a s^3 / (18 EI),
i.e. y = h (4 (s/a)^3 - 3 (s/a)^4) with

* a = (72 EI h / w)^(1/4), the lifted length;
* the clamp's vertical reaction -EI y'''(0) = 2 w a / 3 (not w a / 2: the support at touchdown takes
  a point force w a / 3, the shear jumping from w a / 3 to 0 there; the lying part rests on the
  plane with its own weight), and the clamp's moment w a^2 / 6;
* the curvature y'' = (h / a^2) (24 s/a - 36 (s/a)^2): -12 h / a^2 at the clamp, 0 at touchdown and
  changing sign at s = 2a/3, i.e. at x = a/3 from the clamp.

The rod: 0.3 m, r = 5 mm, E = 1 MPa, 61 nodes (5 mm apart), lifted h = 5 mm over 0.2 s, then damped
to rest by drag by 2 s (explicit integrator, about a second on one core). a = 0.123 m, h/a = 0.04,
slopes at most 1.78 h/a = 0.07 rad, so linear theory holds to O((h/a)^2) = 0.2 %.

The contact is made stiff (penetration 1e-5 r under a node's weight): the beam approaches the plane
as a cubic, y ~ 4 h (s/a)^3, so a node within delta of the plane is (delta / 4h)^(1/3) a before
touchdown (1.4 % at delta = 5e-8 m; the default 0.5 % of r would shift it 14 % of a), and the
plane then acts as a Winkler foundation of length (4 EI / k)^(1/4) = 3.4 mm, under one node spacing
(16 mm, 13 % of a, at the default).

Measured (2026-11-27; frictionless and mu = 0.5 agree to 1e-4): touchdown node 24, 0.1199 m against
a = 0.1231 m (-2.6 %, 0.6 node spacings); the curvature's sign change at 0.0405 m against a/3
(-1.2 %); the clamp's reaction 0.06295 N against 2 w a / 3 = 0.06321 N (-0.41 %), its moment
1.926e-3 N m against w a^2 / 6 = 1.945e-3 N m (-0.94 %). These residuals are mostly the rod's
shear flexibility (G = E/3, no shear correction: EI / (GA a^2) = 3 r^2 / (4 a^2) = 1.2e-3, times the
load's coefficients): with nu = 0 (G = E/2) they drop to -0.25 %, -0.64 % and -0.70 %, which
extrapolates to within 0.3 % for a shear-rigid rod.
"""

import math

import numpy as np
import pytest

from softrnn.rod import Clamp, Contact, Damping, Plane, RodSpec, RunConfig, Setup, Simulator, straight
from softrnn.rod.loads import smoothstep

G = 9.81
LENGTH, RADIUS, N, E, RHO = 0.3, 0.005, 61, 1e6, 1000.0
H = 0.005                 # m, the clamp's lift above the lying rod's centreline
LIFT_TIME = 0.2           # s, smoothstep
REST_TIME = 2.0           # s simulated: at rest (speeds below REST_SPEED) well before
PENETRATION = 1e-5        # of r under a node's weight: a nearly rigid plane (module docstring)
DRAG = 0.5                # N s/m^2 per length: motion decays at c / (2 rho A) = 3.2 /s, at rest by REST_TIME
MU = 0.5

EI = E * math.pi * RADIUS**4 / 4
W = RHO * math.pi * RADIUS**2 * G
A = (72 * EI * H / W) ** 0.25          # the lifted length of linear theory
SPACING = LENGTH / (N - 1)

REST_SPEED = 1e-4          # m/s: at rest (a node moves < 1 um in 10 ms, 2e-4 h)
TOUCHDOWN_SPACINGS = 2     # the touchdown node within 2 node spacings of a: the node grid (1 spacing), the
                           # cubic approach (1.4 % of a = 0.35 spacings) and shear (~1 %)
INFLECTION_RTOL = 0.03     # the sign change of the curvature at a/3: linear interpolation between nodes,
                           # shear (measured 1.2 %)
FLAT_TOL = 1e-3 * H        # the lying part's height above the plane: only the contact penetration (~1e-7 m)
REACTION_RTOL = 0.02       # clamp force against 2 w a / 3: shear flexibility (0.4 %), O((h/a)^2) = 0.2 %; a clamp
                           # force of w a / 2 (-25 %) or w a (+50 %) fails
MOMENT_RTOL = 0.03         # clamp moment against w a^2 / 6: shear (0.9 %), a^2 doubles the relative error of a
SAME_REST_TOL = 0.01       # friction against frictionless: heights within 1 % of h, reactions within 1 %


class _Lift:
    """Clamp motion: node 0 raised by h [m] over LIFT_TIME (smoothstep), its orientation kept."""

    def __init__(self, origin, rotation, h):
        self.origin, self.rotation, self.h = np.asarray(origin), np.asarray(rotation), h

    def __call__(self, t):
        z = self.h * smoothstep(np.asarray(t) / LIFT_TIME)
        return self.origin + z[:, None] * np.array([0.0, 0.0, 1.0]), np.broadcast_to(self.rotation, (t.size, 3, 3))


def _at_rest(mu: float, h: float = H):
    """The rod lifted by h [m], after REST_TIME: (setup, trajectory saved every 0.05 s, all nodes)."""
    rod = RodSpec(length=LENGTH, radius=RADIUS, youngs_modulus=E, density=RHO, n_nodes=N, poisson_ratio=0.5)
    # lying along +x at the contact's rest penetration
    shape = straight(N, LENGTH, origin=(0.0, 0.0, RADIUS * (1 - PENETRATION)), direction=(1.0, 0.0, 0.0),
                     normal=(0.0, 0.0, 1.0))
    setup = Setup(rod=rod, reference=shape, gravity=(0.0, 0.0, -G),
                  boundary=(Clamp(0, motion=_Lift(shape.positions[0], shape.rotations[0], h)),),
                  contact=Contact(obstacles=Plane((0.0, 0.0, 0.0), (0.0, 0.0, 1.0)), friction=mu,
                                  penetration=PENETRATION),
                  damping=Damping(translational=DRAG, rotational=DRAG * RADIUS**2))
    traj = Simulator(setup).run(RunConfig(dt=0.05, n_samples=round(REST_TIME / 0.05) + 1))
    return setup, traj


@pytest.fixture(scope="module")
def rest():
    """{mu: (setup, trajectory)}, frictionless and with friction."""
    return {mu: _at_rest(mu) for mu in (0.0, MU)}


def _curvature(x: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(x-coordinate from the clamp (n - 2,), curvature in the xz-plane (n - 2,)) at the interior nodes
    of positions x (n, 3) [m]."""
    angle = np.arctan2(np.diff(x[:, 2]), np.diff(x[:, 0]))
    return x[1:-1, 0] - x[0, 0], np.diff(angle) / SPACING


def _touchdown(traj) -> int:
    """The first node from the clamp that touches the plane (carries a contact force)."""
    touching = traj.contact_forces[-1, :, 2] > 0
    assert touching.any() and not touching[0]
    return int(np.argmax(touching))


@pytest.mark.parametrize("mu", [0.0, MU], ids=["frictionless", "friction"])
def test_the_lifted_length_is_that_of_linear_beam_theory(rest, mu):
    """At rest; the touchdown node within 2 node spacings of a = (72 EI h / w)^(1/4) (measured -0.6
    spacings, -2.6 %); the curvature changing sign at a/3 (measured -1.2 %); the curvature at
    touchdown small against the clamp's (theory: 0, rising 24 h l / a^3 per spacing l, 8 % of the
    clamp's 12 h / a^2); the part beyond touchdown flat on the plane."""
    setup, traj = rest[mu]
    assert np.max(np.abs(traj.velocities[-1])) < REST_SPEED
    x = traj.positions[-1]
    assert x[0, 2] - x[-1, 2] == pytest.approx(H, rel=1e-3)   # lifted by h above the lying end
    td = _touchdown(traj)
    s_td = x[td, 0] - x[0, 0]
    assert abs(s_td - A) <= TOUCHDOWN_SPACINGS * SPACING, (td, s_td, A)

    s, kappa = _curvature(x)
    assert kappa[0] < 0  # concave down at the clamp
    i = int(np.argmax(kappa > 0))  # the first sign change
    assert i > 0 and kappa[i - 1] < 0 < kappa[i]
    inflection = s[i - 1] - kappa[i - 1] * (s[i] - s[i - 1]) / (kappa[i] - kappa[i - 1])
    assert inflection == pytest.approx(A / 3, rel=INFLECTION_RTOL)
    clamp_curvature = 12 * H / A**2
    assert abs(kappa[td - 1]) < 3 * SPACING / A * clamp_curvature   # node td, curvature index td - 1

    gap = x[:, 2] - RADIUS
    assert np.max(np.abs(gap[td:])) < FLAT_TOL
    assert np.max(np.abs(kappa[td + 1:])) < 0.01 * clamp_curvature


@pytest.mark.parametrize("mu", [0.0, MU], ids=["frictionless", "friction"])
def test_the_clamp_carries_two_thirds_of_the_lifted_weight(rest, mu):
    """The clamp's reaction: 2 w a / 3 upward (measured -0.41 %), the moment w a^2 / 6 (measured
    -0.94 %) about -y (the lifted span, along +x, pulls the clamp down), no horizontal force (below
    2e-3 of the vertical one: measured 2e-5 frictionless, 6e-4 with friction, whose regularised
    form still holds a little of the tension of the lift in the lying part); the plane carries the
    rest of the weight."""
    setup, traj = rest[mu]
    force, torque = traj.reaction_forces[-1, 0], traj.reaction_torques[-1, 0]
    assert force[2] == pytest.approx(2 * W * A / 3, rel=REACTION_RTOL)
    assert -torque[1] == pytest.approx(W * A**2 / 6, rel=MOMENT_RTOL)
    assert abs(force[0]) < 2e-3 * force[2] and abs(force[1]) < 1e-9 and abs(torque[0]) < 1e-9
    weight = W * LENGTH
    assert force[2] + traj.contact_forces[-1, :, 2].sum() == pytest.approx(weight, rel=1e-4)


def test_friction_reaches_the_same_rest_state(rest):
    """With friction (mu = 0.5) and without, the same rest state: heights within 1 % of h, the same
    touchdown node, reactions within 1 % (regularised friction vanishes at rest)."""
    (_, smooth), (_, rough) = rest[0.0], rest[MU]
    assert np.max(np.abs(smooth.positions[-1, :, 2] - rough.positions[-1, :, 2])) < SAME_REST_TOL * H
    assert _touchdown(smooth) == _touchdown(rough)
    assert rough.reaction_forces[-1, 0, 2] == pytest.approx(smooth.reaction_forces[-1, 0, 2], rel=SAME_REST_TOL)
    assert rough.reaction_torques[-1, 0, 1] == pytest.approx(smooth.reaction_torques[-1, 0, 1], rel=SAME_REST_TOL)


def test_a_lower_lift_shortens_the_lifted_length_as_its_fourth_root(rest):
    """Lifted to h / 4 instead, frictionless: a shrinks by (1/4)^(1/4) = 0.707, and so does the
    clamp's reaction 2 w a / 3 (within REACTION_RTOL; h/a = 0.014, the shear residual about 1 %)."""
    _, low = _at_rest(0.0, H / 4)
    ratio = low.reaction_forces[-1, 0, 2] / rest[0.0][1].reaction_forces[-1, 0, 2]
    assert ratio == pytest.approx(0.25**0.25, rel=REACTION_RTOL)
    assert low.reaction_forces[-1, 0, 2] == pytest.approx(2 * W * A * 0.25**0.25 / 3, rel=REACTION_RTOL)
