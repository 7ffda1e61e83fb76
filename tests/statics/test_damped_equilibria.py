"""Static equilibria reached by damping the dynamic model to rest (lgvi.md §2.10 item 3, §5.4):
cantilever tip deflection against Timoshenko beam theory (small load) and against the exact
planar Reissner/Euler elastica (large load); support reactions balance the applied load."""

import numpy as np
import pytest
from scipy.optimize import brentq

from softrnn.rod import Clamp, Constant, Damping, NodalLoad, Pin, RodSpec, RunConfig, Setup, Simulator, straight

from helpers import planar_bent_shape, reissner_cantilever_tip

L, RADIUS, E, RHO, NU = 0.2, 0.01, 1e7, 1000.0, 0.5
AREA, I2 = np.pi * RADIUS**2, np.pi * RADIUS**4 / 4
EI, EA = E * I2, E * AREA
GA = E / (2 * (1 + NU)) * AREA   # shear coefficient kappa = 1 (RodSpec default)

TIMOSHENKO_RTOL = 0.01        # small tip load: relative error of the tip deflection
ELASTICA_TOL = 0.005          # large tip load: tip position error / rod length
REST_TOL = 1e-5               # settled: max node speed / (tip deflection * first bending frequency)
REACTION_RTOL = 1e-6          # support reaction vs applied load at rest

# strong viscous drag (about critical for the first bending mode) settles every mode at the rate
# c / (2 rho A) ~ 48 1/s, so 0.5 s damps the transient by ~ e^-24
DRAG = 30.0
SETTLE_TIME = 0.5
OMEGA1 = 1.8751**2 * np.sqrt(EI / (RHO * AREA * L**4))


def settled_cantilever(n, tip_force, gravity=(0.0, 0.0, 0.0)):
    rod = RodSpec(length=L, radius=RADIUS, youngs_modulus=E, density=RHO, n_nodes=n, poisson_ratio=NU)
    setup = Setup(rod=rod, reference=straight(n, L, direction=(1, 0, 0), normal=(0, 0, 1)), boundary=(Clamp(0),),
                  damping=Damping(translational=DRAG, rotational=1e-3), gravity=gravity,
                  loads=(NodalLoad(-1, force=Constant(tip_force)),) if tip_force is not None else ())
    sim = Simulator(setup)
    traj = sim.run(RunConfig(dt=SETTLE_TIME / 10, n_samples=11))
    return sim, traj


def assert_at_rest(traj, deflection):
    speed = np.linalg.norm(traj.velocities[-1], axis=1).max()
    assert speed < REST_TOL * deflection * OMEGA1, speed
    assert np.abs(traj.positions[-1] - traj.positions[-2]).max() < REST_TOL * deflection


@pytest.mark.parametrize("n", [20, 50, 100])
def test_cantilever_small_tip_load_matches_timoshenko(n):
    P = 0.02  # N: tip deflection 0.34 % of L, geometric nonlinearity ~1e-5
    expected = P * L**3 / (3 * EI) + P * L / GA
    sim, traj = settled_cantilever(n, (0.0, 0.0, -P))
    tip = traj.positions[-1, -1]
    assert_at_rest(traj, expected)
    assert -tip[2] == pytest.approx(expected, rel=TIMOSHENKO_RTOL)
    assert abs(tip[1]) < 1e-12  # stays in the loading plane


def test_cantilever_self_weight_matches_timoshenko():
    """lgvi.md §2.10 item 3: qL^4/(8EI) + qL^2/(2GA) = 7.9069e-3 m; the prototype found 7.8967e-3 m
    (0.13 % below: geometric nonlinearity at a deflection of 4 % of L)."""
    q = RHO * AREA * 9.81
    expected = q * L**4 / (8 * EI) + q * L**2 / (2 * GA)
    assert expected == pytest.approx(7.9069e-3, rel=1e-4)
    _, traj = settled_cantilever(20, None, gravity=(0.0, 0.0, -9.81))
    assert_at_rest(traj, expected)
    assert -traj.positions[-1, -1, 2] == pytest.approx(expected, rel=TIMOSHENKO_RTOL)
    assert -traj.positions[-1, -1, 2] == pytest.approx(7.8967e-3, rel=1e-3)


@pytest.mark.parametrize("n", [20, 50])
def test_cantilever_large_tip_load_matches_exact_elastica(n):
    P = 2.0 * EI / L**2  # tip deflection ~ 0.5 L, tip slope ~ 50 deg
    x, z = reissner_cantilever_tip(P, L, EI, EA, GA)
    x_inext, z_inext = reissner_cantilever_tip(P, L, EI)  # Euler elastica, for the record
    assert np.hypot(x - x_inext, z - z_inext) < 0.005 * L  # shear/extension matter a little at L/r = 20
    _, traj = settled_cantilever(n, (0.0, 0.0, -P))
    tip = traj.positions[-1, -1]
    assert_at_rest(traj, -z)
    err = np.hypot(tip[0] - x, tip[2] - z) / L
    assert err < ELASTICA_TOL, err
    # far outside the linear regime: linear theory would be off by > 25 %
    assert -tip[2] < 0.8 * (P * L**3 / (3 * EI))


def test_large_deflection_converges_at_second_order_in_space():
    """The SE(3)-Cayley strains make the spatial discretisation second order (lgvi.md §2.2)."""
    P = 2.0 * EI / L**2
    x, z = reissner_cantilever_tip(P, L, EI, EA, GA)
    errors = []
    for n in (11, 21, 41):
        _, traj = settled_cantilever(n, (0.0, 0.0, -P))
        tip = traj.positions[-1, -1]
        errors.append(np.hypot(tip[0] - x, tip[2] - z))
    order = np.log2(np.array(errors[:-1]) / np.array(errors[1:]))
    assert np.all((order > 1.8) & (order < 2.2)), (errors, order)


def test_reissner_helper_reduces_to_linear_theory():
    """The exact reference solution itself: tiny load -> Timoshenko formula."""
    P = 1e-6
    x, z = reissner_cantilever_tip(P, L, EI, EA, GA)
    assert -z == pytest.approx(P * L**3 / (3 * EI) + P * L / GA, rel=1e-6)
    assert x == pytest.approx(L, rel=1e-6)


def test_support_reactions_balance_the_tip_load():
    P = np.array([0.3, -0.5, -1.5])  # N, a 3-D load with large deflection
    sim, traj = settled_cantilever(20, tuple(P))
    assert_at_rest(traj, 0.05)
    r0, tip = traj.positions[-1, 0], traj.positions[-1, -1]
    Rf, Rt = traj.reaction_forces[-1, 0], traj.reaction_torques[-1, 0]
    np.testing.assert_allclose(Rf, -P, atol=REACTION_RTOL * np.linalg.norm(P))
    moment = np.cross(tip - r0, P)
    np.testing.assert_allclose(Rt, -moment, atol=REACTION_RTOL * np.linalg.norm(moment) + 1e-12)
    # free nodes carry no reaction
    assert np.abs(traj.reaction_forces[-1, 1:]).max() == 0.0


def discrete_pure_bending_angle(M, l, EI):
    """Node-to-node rotation angle of the discrete rod under an end couple M: the segment moment
    T = EI K (1 + l^2 K^2 / 4) with K = 2 tan(dtheta/2) / l must equal M (lgvi.md §2.4, c = 0)."""
    K = brentq(lambda K: EI * K * (1 + 0.25 * l * l * K * K) - M, 0.0, M / EI)
    return 2 * np.arctan(0.5 * l * K)


@pytest.mark.parametrize("n", [21, 41])
def test_pure_bending_by_a_follower_couple_rolls_the_rod_into_a_circle(n):
    """A tip couple M about d2 bends the cantilever into a circular arc of curvature M/EI; here
    M L/EI = 1.5 pi (three quarters of a full circle). Discretely every segment turns by the same
    angle, given exactly by discrete_pure_bending_angle, so the discrete equilibrium is known to
    round-off; it differs from the continuum circle by the predicted O(l^2) amount."""
    l = L / (n - 1)
    phi = 1.5 * np.pi
    M = phi * EI / L
    rod = RodSpec(length=L, radius=RADIUS, youngs_modulus=E, density=RHO, n_nodes=n, poisson_ratio=NU)
    setup = Setup(rod=rod, reference=straight(n, L, direction=(1, 0, 0), normal=(0, 0, 1)), boundary=(Clamp(0),),
                  damping=Damping(translational=DRAG, rotational=1e-2),
                  loads=(NodalLoad(-1, torque=Constant((0.0, M, 0.0)), frame="body"),))
    sim = Simulator(setup)
    traj = sim.run(RunConfig(dt=SETTLE_TIME / 5, n_samples=11))
    assert_at_rest(traj, L)
    # exact discrete equilibrium: node a turned by a * dtheta about d2 = -y (bending toward +z)
    dtheta = discrete_pure_bending_angle(M, l, EI)
    exact = planar_bent_shape(-dtheta * np.arange(n), l)
    np.testing.assert_allclose(traj.positions[-1], exact.positions, atol=1e-7 * L)
    np.testing.assert_allclose(sim.state.rotations, exact.rotations, atol=1e-6)
    # continuum: circle of radius rho = EI/M. Discretely the radius is rho (1 + eps^2/4) and the
    # total angle phi (1 - eps^2/3), eps = l M/EI, which moves the tip by delta (leading order)
    rho = EI / M
    eps2 = (l * M / EI) ** 2
    circle_tip = rho * np.array([np.sin(phi), 0.0, 1 - np.cos(phi)])
    delta = rho * eps2 * (np.array([np.sin(phi), 0.0, 1 - np.cos(phi)]) / 4
                          - phi / 3 * np.array([np.cos(phi), 0.0, np.sin(phi)]))
    assert np.linalg.norm(traj.positions[-1, -1] - circle_tip - delta) < 0.1 * np.linalg.norm(delta)
    assert np.linalg.norm(traj.positions[-1, -1] - circle_tip) < 0.03 * L  # 2.1 % at n = 21
    # the support holds the couple
    np.testing.assert_allclose(traj.reaction_torques[-1, 0], [0.0, M, 0.0], atol=REACTION_RTOL * M)


@pytest.mark.parametrize("n", [21, 41])
def test_simply_supported_beam_midspan_load_matches_timoshenko(n):
    """Both ends pinned (position fixed, rotation free): midspan deflection PL^3/(48EI) + PL/(4GA)
    and each pin carries half the load."""
    P = 0.05
    expected = P * L**3 / (48 * EI) + P * L / (4 * GA)
    rod = RodSpec(length=L, radius=RADIUS, youngs_modulus=E, density=RHO, n_nodes=n, poisson_ratio=NU)
    setup = Setup(rod=rod, reference=straight(n, L, direction=(1, 0, 0), normal=(0, 0, 1)),
                  boundary=(Pin(0), Pin(-1)), damping=Damping(translational=DRAG, rotational=1e-3),
                  loads=(NodalLoad((n - 1) // 2, force=Constant((0.0, 0.0, -P))),))
    traj = Simulator(setup).run(RunConfig(dt=SETTLE_TIME / 10, n_samples=11))
    assert_at_rest(traj, expected)
    assert -traj.positions[-1, (n - 1) // 2, 2] == pytest.approx(expected, rel=TIMOSHENKO_RTOL)
    np.testing.assert_allclose(traj.reaction_forces[-1, [0, -1], 2], [P / 2, P / 2], rtol=1e-6)
    np.testing.assert_allclose(traj.reaction_torques[-1, [0, -1]], 0.0, atol=0)
