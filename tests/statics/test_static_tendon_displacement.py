"""Tendons driven by a displacement in the static solver: the tensions are unknowns solved with the
equilibrium, tau = k max(0, q - (l_0 - l)), l the tendon's path length in the solution.

Closed form (continuum): a straight tendon at the offset r on a straight, weightless, free rod,
terminated at L_e, gives the constant curvature kappa = tau r / (E I), the compression tau / (E A),
a path shortened by L_e (r kappa + tau / (E A)), so tau = k q / (1 + k L_e (r^2 / (E I) + 1 / (E A)))
(without the 1 / (E A) for a Kirchhoff rod); as k -> infinity the Kirchhoff rod bends to the
kinematic kappa = q / (r L_e). A paid-out tendon is slack; a displacement chosen for the tension tau
gives the solution of the tension tau; in a robot of segments, a segment's tendon bends the rod up
to its termination only."""

import math

import numpy as np
import pytest

from softrnn.errors import SoftrnnInputError
from softrnn.rod import Tendon
from softrnn.statics import StaticLoads, StaticRod, StaticSolver, solve

L, RADIUS, E, RHO, NU = 0.2, 0.01, 1e7, 1000.0, 0.5
EI = E * np.pi * RADIUS**4 / 4
EA = E * np.pi * RADIUS**2
OFFSET = 0.008
K_SPRING = 2000.0
Q = 0.002
ANGLES = np.radians([0.0, 120.0, 240.0])
GRAVITY = (0.0, 0.0, -9.81)


def static_rod(tendons, gravity=(0.0, 0.0, 0.0), **kwargs):
    return StaticRod(length=L, radius=RADIUS, youngs_modulus=E, density=RHO, poisson_ratio=NU, gravity=gravity,
                     tendons=tuple(tendons), **kwargs)


def closed_form_tension(k, q, length, extensible=True):
    return k * q / (1.0 + k * length * (OFFSET**2 / EI + (1.0 / EA if extensible else 0.0)))


def turn(rotations, a, b):
    """Angle [rad] between the tangents d3 at grid points a and b."""
    d3 = rotations[:, :, 2]
    return float(np.arctan2(np.linalg.norm(np.cross(d3[a], d3[b])), d3[a] @ d3[b]))


# --------------------------------------------------------------------------- closed form
@pytest.mark.parametrize("extensible", [True, False])
@pytest.mark.parametrize("k", [K_SPRING, 5e4])
@pytest.mark.parametrize("end_s", [None, 0.12])
def test_a_displaced_tendon_bends_the_rod_to_the_closed_form(extensible, k, end_s):
    td = Tendon(name="t", offset=(OFFSET, 0.0), displacement=Q, stiffness=k, end_s=end_s)
    sol = solve(static_rod([td], extensible_shearable=extensible), tol=1e-12).raise_for_status()
    Le = L if end_s is None else end_s
    tau = closed_form_tension(k, Q, Le, extensible)
    kappa = tau * OFFSET / EI
    assert sol.tendon_tensions[0] == pytest.approx(tau, rel=1e-9)
    e = sol.index(Le)
    assert turn(sol.rotations, 0, e) / Le == pytest.approx(kappa, rel=1e-9)
    assert turn(sol.rotations, e, -1) < 1e-12                    # straight beyond the termination
    compression = tau / EA if extensible else 0.0
    assert sol.tendon_shortening[0] == pytest.approx(Le * (OFFSET * kappa + compression), rel=1e-9)
    assert sol.tendon_shortening[0] == pytest.approx(Q - tau / k, rel=1e-9)   # the rest stretches the spring
    # a circle of radius (1 - tau / (E A)) / kappa through the base, bending toward the tendon (+z)
    rho = (1.0 - compression) / kappa
    np.testing.assert_allclose(np.linalg.norm(sol.positions[:e + 1] - [0.0, 0.0, rho], axis=1), rho, rtol=1e-9)


def test_an_infinitely_stiff_servo_bends_the_rod_kinematically():
    """Kirchhoff rod: r kappa L -> q as k grows (the spring's stretch tau / k vanishes as 1 / k)."""
    gaps = []
    for k in (1e3, 1e5, 1e7, 1e9, 1e12):
        td = Tendon(name="t", offset=(OFFSET, 0.0), displacement=Q, stiffness=k)
        sol = solve(static_rod([td], extensible_shearable=False), tol=1e-12).raise_for_status()
        kappa = turn(sol.rotations, 0, -1) / L
        gaps.append(1.0 - kappa * OFFSET * L / Q)
        assert gaps[-1] == pytest.approx(sol.tendon_tensions[0] / k / Q, rel=1e-6, abs=1e-12)
    assert all(a > b for a, b in zip(gaps, gaps[1:])) and gaps[0] > 0.5
    assert abs(gaps[-1]) < 1e-8


# --------------------------------------------------------------------------- slack
def test_a_paid_out_tendon_is_slack():
    slack = [Tendon(name="a", offset=(OFFSET, 0.0), displacement=-0.001, stiffness=K_SPRING),
             Tendon(name="b", offset=(0.0, OFFSET), displacement=-1e-5, stiffness=K_SPRING)]
    a = solve(static_rod(slack, GRAVITY), tol=1e-12).raise_for_status()
    b = solve(static_rod([], GRAVITY), tol=1e-12).raise_for_status()
    np.testing.assert_array_equal(a.tendon_tensions, [0.0, 0.0])
    np.testing.assert_allclose(a.positions, b.positions, atol=1e-14)
    straight = solve(static_rod(slack), tol=1e-12).raise_for_status()
    np.testing.assert_allclose(straight.positions[:, 1:], 0.0, atol=1e-15)
    np.testing.assert_allclose(straight.tendon_shortening, 0.0, atol=1e-15)


# --------------------------------------------------------------------------- = a tension tendon
def test_the_displacement_for_a_tension_gives_the_solution_of_the_tension():
    """Three tendons with gravity (a Newton iteration on the tensions): pulling with the tensions
    tau, then driving by q = tau / k + shortening, gives the same shape and the tensions tau."""
    tau = np.array([1.5, 0.2, 0.7])
    offsets = [(OFFSET * np.cos(a), OFFSET * np.sin(a)) for a in ANGLES]
    pulled = [Tendon(name=n, offset=o, tension=t) for n, o, t in zip("abc", offsets, tau)]
    one = solve(static_rod(pulled, GRAVITY), tol=1e-10).raise_for_status()
    np.testing.assert_array_equal(one.tendon_tensions, tau)
    q = tau / K_SPRING + one.tendon_shortening
    driven = [Tendon(name=n, offset=o, displacement=x, stiffness=K_SPRING) for n, o, x in zip("abc", offsets, q)]
    two = solve(static_rod(driven, GRAVITY), tol=1e-10).raise_for_status()
    assert "tendon tensions matched" in two.message
    np.testing.assert_allclose(two.tendon_tensions, tau, rtol=1e-6)
    np.testing.assert_allclose(two.positions, one.positions, atol=1e-9 * L)
    np.testing.assert_allclose(two.tendon_shortening, one.tendon_shortening, atol=1e-11)
    assert np.linalg.norm(one.positions[-1, 1:]) > 0.02 * L


def test_displacements_per_solve_and_the_warm_start():
    """StaticLoads.tendon_displacements overrides the tendons' own; the solver's warm start gives
    the same solution as a cold solve."""
    driven = [Tendon(name=n, offset=(OFFSET * np.cos(a), OFFSET * np.sin(a)), displacement=0.0, stiffness=K_SPRING)
              for n, a in zip("abc", ANGLES)]
    rod = static_rod(driven, GRAVITY)
    solver = StaticSolver(rod, tol=1e-10)
    for qs in ((0.002, 0.0, 0.001), (0.0025, 0.0005, 0.001), (0.003, 0.001, 0.0)):
        warm = solver.solve(StaticLoads(tendon_displacements=qs)).raise_for_status()
        cold = solve(rod, StaticLoads(tendon_displacements=qs), tol=1e-10).raise_for_status()
        np.testing.assert_allclose(warm.tendon_tensions, cold.tendon_tensions, rtol=1e-6, atol=1e-9)
        np.testing.assert_allclose(warm.positions, cold.positions, atol=1e-9 * L)
        tau = K_SPRING * np.maximum(np.array(qs) - warm.tendon_shortening, 0.0)
        np.testing.assert_allclose(warm.tendon_tensions, tau, rtol=1e-6, atol=1e-9)
    with pytest.raises(SoftrnnInputError, match="tendon_displacements.*3 displacements in m"):
        solver.solve(StaticLoads(tendon_displacements=(0.001,)))


# --------------------------------------------------------------------------- robots of segments
def _robot(qs, extra=()):
    """Two segments of three tendons 120 deg apart: segment 1 ends at L / 2, segment 2 (turned by
    60 deg) at the tip."""
    tendons = []
    for seg, (end, rot) in enumerate(((L / 2, 0.0), (L, np.pi / 3))):
        for i, a in enumerate(ANGLES + rot):
            tendons.append(Tendon(name=f"s{seg + 1}{'abc'[i]}", offset=(OFFSET * np.cos(a), OFFSET * np.sin(a)),
                                  displacement=qs[3 * seg + i], stiffness=K_SPRING, end_s=end))
    return tendons + list(extra)


def test_a_segment_tendon_bends_its_segment_only():
    """Weightless: segment 1's first tendon pulled in, the others paid out: the closed form over
    L_e = L / 2, straight beyond; segment 2's first tendon instead bends the whole rod about the
    other axis (its offset turned by 60 deg) with L_e = L."""
    out = -0.003
    first = solve(static_rod(_robot([Q, out, out, out, out, out])), tol=1e-12).raise_for_status()
    tau = closed_form_tension(K_SPRING, Q, L / 2)
    np.testing.assert_allclose(first.tendon_tensions, [tau, 0, 0, 0, 0, 0], rtol=1e-9, atol=1e-12)
    mid = first.index(L / 2)
    assert turn(first.rotations, 0, mid) / (L / 2) == pytest.approx(tau * OFFSET / EI, rel=1e-9)
    assert turn(first.rotations, mid, -1) < 1e-12
    second = solve(static_rod(_robot([out, out, out, Q, out, out])), tol=1e-12).raise_for_status()
    tau2 = closed_form_tension(K_SPRING, Q, L)
    np.testing.assert_allclose(second.tendon_tensions, [0, 0, 0, tau2, 0, 0], rtol=1e-9, atol=1e-12)
    assert turn(second.rotations, 0, -1) / L == pytest.approx(tau2 * OFFSET / EI, rel=1e-9)
    # bending toward the tendon: the tip moves along its offset direction (60 deg from d1 toward d2)
    side = math.cos(np.pi / 3) * np.array([0.0, 0.0, 1.0]) + math.sin(np.pi / 3) * np.array([0.0, -1.0, 0.0])
    tip = second.positions[-1]
    assert tip @ side > 0.99 * np.linalg.norm(tip[1:])


def test_a_two_segment_robot_with_gravity_and_a_tension_tendon():
    """Six servo-driven tendons and one pulled with a tension, with gravity: every tension matches
    its displacement, and the tension tendon keeps its tension."""
    extra = (Tendon(name="pull", offset=(0.0, 0.005), tension=0.4, end_s=0.15),)
    qs = (0.003, 0.0, 0.001, 0.0015, 0.0005, 0.0)
    sol = solve(static_rod(_robot(qs, extra), GRAVITY), tol=1e-10).raise_for_status()
    tau = sol.tendon_tensions
    assert tau[-1] == 0.4
    expected = K_SPRING * np.maximum(np.array(qs) - sol.tendon_shortening[:6], 0.0)
    np.testing.assert_allclose(tau[:6], expected, rtol=1e-6, atol=1e-9)
    assert np.count_nonzero(tau[:6] > 0.1) >= 3 and np.count_nonzero(tau[:6] == 0.0) >= 1


# --------------------------------------------------------------------------- bad inputs
def test_bad_displacement_inputs_are_refused_in_one_line():
    td = Tendon(name="t", offset=(OFFSET, 0.0), displacement=Q, stiffness=K_SPRING)
    for make, match in (
            (lambda: StaticLoads(tendon_displacements=(float("inf"),)), "tendon_displacements.*finite displacements"),
            (lambda: StaticLoads(tendon_displacements="far"), "tendon_displacements"),
            (lambda: Tendon(name="t", offset=(0.0, 0.0), displacement=Q), "stiffness=None is invalid"),
            (lambda: Tendon(name="t", offset=(0.0, 0.0), tension=1.0, displacement=Q, stiffness=1.0),
             "tension=1.0 is invalid.*not both"),
            (lambda: solve(static_rod([td]), StaticLoads(tendon_displacements=(0.1, 0.2))),
             "tendon_displacements=.*1 displacement in m")):
        with pytest.raises(SoftrnnInputError, match=match) as err:
            make()
        assert "\n" not in str(err.value)
