"""Static Cosserat rod solver (softrnn.statics): small loads against beam theory, large loads
against the exact elastica, the damped dynamic simulator settling onto the static solution, a
magnet's torque balance, global equilibrium with magnets and stiff segments, the RK4 convergence
order, warm starts, solver status on failures and one-line input errors."""

import json
import math

import numpy as np
import pytest
from scipy.optimize import brentq

from softrnn.errors import SimulationError, SoftrnnInputError
from softrnn.experiments.fig13 import run_fig13_study, write_fig13
from softrnn.rod import Clamp, Constant, Damping, NodalLoad, RodSpec, RunConfig, Setup, Simulator, straight
from softrnn.rod.so3 import axis_rotation
from softrnn.statics import (
    PointLoad,
    PointMagnet,
    RigidSegment,
    StaticLoads,
    StaticRod,
    StaticSolver,
    Status,
    build_grid,
    solve,
)
from softrnn.statics.cases import magnetic_loads, magnetic_rod

from helpers import reissner_cantilever_tip

L, RADIUS, E, RHO, NU = 0.2, 0.01, 1e7, 1000.0, 0.5
BEAM_RTOL = 0.01             # small tip load vs Timoshenko / Euler-Bernoulli
ELASTICA_TOL = 1e-3          # large load: tip error / L vs the exact elastica
DYNAMIC_TOL = 5e-3           # damped dynamic rest state vs static solution: max node distance / L
TORQUE_RTOL = 1e-6           # torque balance of a magnet (solved to tol 1e-12)
EQUILIBRIUM_RTOL = 1e-5      # global force/moment balance (trapezoid quadrature on a fine grid)
ORDER_RANGE = (3.7, 4.3)     # RK4 convergence order in N


def rod(**kw) -> StaticRod:
    base = dict(length=L, radius=RADIUS, youngs_modulus=E, density=RHO, poisson_ratio=NU, gravity=(0.0, 0.0, 0.0))
    return StaticRod(**(base | kw))


def tip_load(force=(0.0, 0.0, 0.0), torque=(0.0, 0.0, 0.0), s=L) -> StaticLoads:
    return StaticLoads(point_loads=(PointLoad(s=s, force=force, torque=torque),))


STIFF = rod().stiffness()
EI, EA, GA = STIFF.EI, STIFF.EA, STIFF.GA


# --------------------------------------------------------------------------- beam theory, elastica
@pytest.mark.parametrize("shearable", [True, False])
def test_small_tip_load_matches_beam_theory(shearable):
    """Timoshenko P L^3/(3EI) + P L/(kappa G A) for the paper's model; Euler-Bernoulli for Kirchhoff."""
    P = 0.02  # N: deflection 0.34 % of L
    sol = solve(rod(extensible_shearable=shearable), tip_load((0.0, 0.0, -P))).raise_for_status()
    expected = P * L**3 / (3 * EI) + (P * L / GA if shearable else 0.0)
    assert -sol.tip_position[2] == pytest.approx(expected, rel=BEAM_RTOL)
    assert abs(sol.tip_position[1]) < 1e-15
    # the rod carries the load: n = F everywhere, base moment = P L about +y
    np.testing.assert_allclose(sol.n, np.tile([0.0, 0.0, -P], (sol.s.size, 1)), atol=1e-12)
    np.testing.assert_allclose(sol.base_wrench[3:], [0.0, P * L, 0.0], rtol=1e-2, atol=1e-12)


def test_self_weight_and_distributed_load_match_beam_theory():
    """Uniform load q: Timoshenko q L^4/(8EI) + q L^2/(2 kappa G A), the same whether it comes
    from gravity or from a distributed force (lgvi.md §2.10 item 3 gives 7.9069e-3 m for this rod)."""
    q = RHO * np.pi * RADIUS**2 * 9.81
    expected = q * L**4 / (8 * EI) + q * L**2 / (2 * GA)
    assert expected == pytest.approx(7.9069e-3, rel=1e-4)
    weight = solve(rod(gravity=(0.0, 0.0, -9.81))).raise_for_status()
    spread = solve(rod(), StaticLoads(distributed_force=(0.0, 0.0, -q))).raise_for_status()
    assert -weight.tip_position[2] == pytest.approx(expected, rel=BEAM_RTOL)
    np.testing.assert_allclose(spread.positions, weight.positions, atol=1e-12)
    np.testing.assert_allclose(weight.base_wrench[:3], [0.0, 0.0, -q * L], atol=weight.tol)  # within E


def test_interior_point_load_and_rigid_segment_match_beam_theory():
    """Kirchhoff cantilever, small load P at s = a (< L): deflection at a is P a^3/(3EI), the part
    beyond a stays straight. With [a, L] rigid and the load at L, the flexible part takes the force
    and the moment P (L - a)."""
    P, a = 0.01, 0.6 * L
    soft = rod(extensible_shearable=False)
    sol = solve(soft, tip_load((0.0, 0.0, -P), s=a)).raise_for_status()
    k = int(np.argmin(np.abs(sol.s - a)))
    assert sol.s[k] == pytest.approx(a, abs=1e-15)  # the load point is a grid point
    slope_a = P * a**2 / (2 * EI)
    assert -sol.positions[k, 2] == pytest.approx(P * a**3 / (3 * EI), rel=BEAM_RTOL)
    assert -sol.tip_position[2] == pytest.approx(P * a**3 / (3 * EI) + slope_a * (L - a), rel=BEAM_RTOL)

    stiff = rod(extensible_shearable=False, rigid_segments=(RigidSegment(s0=a, s1=L, youngs_modulus=1e6 * E,
                                                                          density=RHO),))
    sol = solve(stiff, tip_load((0.0, 0.0, -P))).raise_for_status()
    M = P * (L - a)
    defl_a = P * a**3 / (3 * EI) + M * a**2 / (2 * EI)
    slope_a = P * a**2 / (2 * EI) + M * a / EI
    assert -sol.tip_position[2] == pytest.approx(defl_a + slope_a * (L - a), rel=BEAM_RTOL)


@pytest.mark.parametrize("shearable", [True, False])
@pytest.mark.parametrize("load", [2.0, 8.0])
def test_large_tip_load_matches_exact_elastica(shearable, load):
    """P = 2 EI/L^2 (tip slope ~50 deg, solved directly) and 8 EI/L^2 (tip slope ~75 deg, solved by
    load stepping from a cold start) against the exact Reissner (shearable, extensible) or Euler
    (Kirchhoff) elastica."""
    P = load * EI / L**2
    x, z = reissner_cantilever_tip(P, L, EI, EA, GA) if shearable else reissner_cantilever_tip(P, L, EI)
    sol = solve(rod(extensible_shearable=shearable), tip_load((0.0, 0.0, -P))).raise_for_status()
    err = math.hypot(sol.tip_position[0] - x, sol.tip_position[2] - z) / L
    assert err < ELASTICA_TOL, err
    assert -sol.tip_position[2] < 0.8 * P * L**3 / (3 * EI)  # far from linear theory


def test_rk4_converges_at_fourth_order():
    """Tip error against N = 1024 for a large 3-D load (no breakpoints: uniform steps)."""
    loads = tip_load((0.3, -0.5, -1.5), torque=(0.02, 0.01, -0.01))
    ref = solve(rod(), loads, n_steps=1024, tol=1e-12).raise_for_status()
    ns = np.array([4, 8, 16, 32])
    errors = [np.linalg.norm(solve(rod(), loads, n_steps=int(n), tol=1e-12).raise_for_status().tip_position
                             - ref.tip_position) for n in ns]
    order = -np.polyfit(np.log(ns), np.log(errors), 1)[0]
    assert ORDER_RANGE[0] < order < ORDER_RANGE[1], (errors, order)


# --------------------------------------------------------------------------- dynamic simulator at rest
@pytest.mark.parametrize("tip_force, gravity", [((0.0, 0.0, -2.0 * EI / L**2), (0.0, 0.0, 0.0)),
                                                ((0.3, -0.5, -1.5), (0.0, 0.0, -9.81))])
def test_damped_dynamic_simulator_settles_on_the_static_solution(tip_force, gravity):
    """The LGVI rod (21 nodes, heavy viscous damping, 0.5 s) comes to rest within 0.5 % of L of the
    static solution at every node: a large planar load, and a 3-D load with gravity."""
    n = 21
    spec = RodSpec(length=L, radius=RADIUS, youngs_modulus=E, density=RHO, n_nodes=n, poisson_ratio=NU)
    setup = Setup(rod=spec, reference=straight(n, L, direction=(1, 0, 0), normal=(0, 0, 1)), boundary=(Clamp(0),),
                  damping=Damping(translational=30.0, rotational=1e-3), gravity=gravity,
                  loads=(NodalLoad(-1, force=Constant(tip_force)),))
    traj = Simulator(setup).run(RunConfig(dt=0.05, n_samples=11))
    assert np.abs(traj.positions[-1] - traj.positions[-2]).max() < 1e-6 * L  # at rest
    static = solve(rod(gravity=gravity), tip_load(tip_force), n_steps=n - 1).raise_for_status()
    np.testing.assert_allclose(static.s, np.linspace(0, L, n), atol=1e-15)
    gap = np.linalg.norm(traj.positions[-1] - static.positions, axis=1).max() / L
    assert gap < DYNAMIC_TOL, gap
    # the frames agree too: tangents within 0.5 % (rad)
    d3_dyn = traj.rotations()[-1][:, :, 2]
    assert np.abs(d3_dyn - static.rotations[:, :, 2]).max() < DYNAMIC_TOL


# --------------------------------------------------------------------------- magnets
def test_tip_magnet_in_uniform_field_bends_the_rod_to_the_torque_balance():
    """No gravity, a dipole mu along the tangent at the tip, B along +z: n = 0, the moment is the
    magnetic torque |mu||B| cos(theta) everywhere, so the rod is a circular arc of curvature
    kappa = |mu||B| cos(theta)/EI with tip angle theta = kappa L."""
    length, mu = 0.05, 8.6e-3
    soft = StaticRod(length=length, radius=1.5e-3, youngs_modulus=2.5e6, density=1000.0, gravity=(0.0, 0.0, 0.0),
                     magnets=(PointMagnet(s=length, moment_body=(0.0, 0.0, mu)),))
    ei = soft.stiffness().EI
    B = 1.85 * ei / (mu * length)  # T: a tip angle of about 1 rad
    sol = solve(soft, StaticLoads(magnetic_field=(0.0, 0.0, B)), tol=1e-12).raise_for_status()
    theta = brentq(lambda t: t - mu * B * length * math.cos(t) / ei, 0.0, math.pi / 2)
    tangent = sol.rotations[-1][:, 2]
    assert math.atan2(tangent[2], tangent[0]) == pytest.approx(theta, rel=TORQUE_RTOL)
    # torque balance at the tip: the internal moment equals mu_world x B
    torque = np.cross(sol.rotations[-1] @ [0.0, 0.0, mu], [0.0, 0.0, B])
    np.testing.assert_allclose(sol.m[-1], torque, rtol=TORQUE_RTOL, atol=1e-18)
    np.testing.assert_allclose(sol.n, 0.0, atol=1e-15)
    kappa = theta / length
    np.testing.assert_allclose(sol.tip_position, [math.sin(theta) / kappa, 0.0, (1 - math.cos(theta)) / kappa],
                               atol=1e-7 * length)
    assert ei * kappa == pytest.approx(np.linalg.norm(torque), rel=TORQUE_RTOL)


def test_magnetic_manipulator_is_in_global_equilibrium():
    """Two magnets (rigid, heavier segments) in a field with a gradient, and gravity: the base
    wrench balances the weight, the magnets' forces G R mu and torques (R mu) x B and the moments
    of all forces about the base at the deformed positions."""
    mrod, loads = magnetic_rod(), magnetic_loads()
    sol = solve(mrod, loads, n_steps=800, tol=1e-12).raise_for_status()
    g = np.array(mrod.gravity)
    p0 = sol.positions[0]
    mid_s = 0.5 * (sol.s[1:] + sol.s[:-1])
    in_magnet = [any(seg.s0 <= s <= seg.s1 for seg in mrod.rigid_segments) for s in mid_s]
    weight = np.where(in_magnet, mrod.segment_stiffness(mrod.rigid_segments[0]).weight, mrod.weight_per_length)
    ds = np.diff(sol.s)
    mid = 0.5 * (sol.positions[1:] + sol.positions[:-1]) - p0
    force = (weight * ds)[:, None] * g
    total_force = force.sum(0)
    total_moment = np.cross(mid, force).sum(0)
    B, G = loads.magnetic_field[0], loads.field_gradient[0]
    for mag in mrod.magnets:
        k = int(np.argmin(np.abs(sol.s - mag.s)))
        mu = sol.rotations[k] @ np.array(mag.moment_body)
        f = G @ mu
        total_force += f
        total_moment += np.cross(sol.positions[k] - p0, f) + np.cross(mu, B)
    np.testing.assert_allclose(sol.base_wrench[:3], total_force, rtol=EQUILIBRIUM_RTOL,
                               atol=EQUILIBRIUM_RTOL * np.abs(total_force).max())
    np.testing.assert_allclose(sol.base_wrench[3:], total_moment, rtol=EQUILIBRIUM_RTOL,
                               atol=EQUILIBRIUM_RTOL * np.abs(total_moment).max())
    # the field lifts the tip against gravity; the magnets stay (nearly) straight
    assert sol.tip_position[2] > 0.01
    for seg in mrod.rigid_segments:
        inside = (sol.s >= seg.s0) & (sol.s <= seg.s1)
        d3 = sol.rotations[inside][:, :, 2]
        assert np.abs(d3 - d3[0]).max() < 1e-4


def test_grid_puts_load_points_and_segment_ends_on_nodes():
    mrod = magnetic_rod()
    grid = build_grid(mrod, (0.01,), 13)
    assert grid.s.size == 14 and grid.h.size == 13
    for s in (0.0, 0.01, 0.024, 0.025, 0.026, 0.048, 0.049, 0.05):
        assert np.abs(grid.s - s).min() < 1e-12
    assert grid.kinv[grid.s[:-1] >= 0.024][0, 0] < 1e-3 * grid.kinv[0, 0]  # magnets are stiff
    assert np.all(grid.h > 0)


def test_base_pose_rotates_and_translates_the_solution():
    """Rotating the base, gravity and the loads by Q and moving the base by b maps the solution
    by x -> Q x + b (objectivity)."""
    Q = axis_rotation("z", 0.7) @ axis_rotation("x", -0.4)
    b = np.array([0.1, -0.2, 0.05])
    F, T = np.array([0.3, -0.5, -1.5]), np.array([0.01, 0.0, -0.02])
    plain = solve(rod(gravity=(0.0, 0.0, -9.81)), tip_load(F, T), tol=1e-12).raise_for_status()
    moved_rod = rod(gravity=tuple(Q @ [0.0, 0.0, -9.81]), base_position=tuple(b),
                    base_rotation=Q @ rod().base_rotation)
    moved = solve(moved_rod, tip_load(Q @ F, Q @ T), tol=1e-12).raise_for_status()
    np.testing.assert_allclose(moved.positions, plain.positions @ Q.T + b, atol=1e-10 * L)
    np.testing.assert_allclose(moved.rotations, Q @ plain.rotations, atol=1e-9)


# --------------------------------------------------------------------------- warm start
def test_warm_start_reaches_the_cold_answer_with_fewer_integrations():
    mrod = magnetic_rod()
    solver = StaticSolver(mrod, n_steps=13, tol=1e-9)
    solver.solve(magnetic_loads())
    for angle in np.radians([2.0, 4.0, 6.0]):
        loads = magnetic_loads(field=(0.02 * math.sin(angle), 0.0, 0.02 * math.cos(angle)))
        warm = solver.solve(loads).raise_for_status()
        cold = StaticSolver(mrod, n_steps=13, tol=1e-9).solve(loads).raise_for_status()
        np.testing.assert_allclose(warm.positions, cold.positions, atol=1e-6 * mrod.length)
        assert warm.integrations < cold.integrations
        assert warm.residual <= 1e-9
    assert solver.warm
    solver.reset()
    assert not solver.warm


def test_explicit_guess_and_solution_as_guess():
    loads = tip_load((0.0, 0.0, -1.0))
    first = solve(rod(), loads).raise_for_status()
    again = solve(rod(), loads, guess=first)
    assert again.converged and again.iterations == 0 and again.integrations == 1
    perturbed = solve(rod(), loads, guess=0.9 * first.base_wrench).raise_for_status()
    np.testing.assert_allclose(perturbed.positions, first.positions, atol=1e-6 * L)


# --------------------------------------------------------------------------- status: never silently wrong
def test_iteration_limit_is_reported_not_hidden():
    loads = tip_load((0.0, 0.0, -5 * EI / L**2))
    sol = solve(rod(), loads, guess=np.zeros(6), max_iter=1)
    assert sol.status is Status.ITERATION_LIMIT and not sol.converged
    assert sol.residual > sol.tol and sol.iterations == 1
    assert "max_iter=1" in sol.message and "\n" not in sol.message
    with pytest.raises(SimulationError, match=r"^static solve iteration_limit: no convergence in max_iter=1") as err:
        sol.raise_for_status()
    assert "\n" not in str(err.value)


def test_absurd_load_gives_a_status_not_an_exception():
    sol = solve(rod(), tip_load((0.0, 0.0, -1e300)))
    assert sol.status is Status.NOT_FINITE
    assert "non-finite" in sol.message
    with pytest.raises(SimulationError, match="static solve not_finite"):
        sol.raise_for_status()
    # a load that stretches the rod far beyond its length: some failure status, never CONVERGED
    # with a residual above tol
    huge = solve(rod(), tip_load((0.0, 0.0, -1000 * EI / L**2)), max_iter=20)
    assert huge.converged == (huge.residual <= huge.tol)


def test_converged_means_residual_below_tol():
    for tol in (1e-3, 1e-6, 1e-10):
        sol = solve(rod(gravity=(0.0, 0.0, -9.81)), tip_load((0.3, -0.5, -1.5)), tol=tol)
        assert sol.converged and sol.residual <= tol
        assert f"tol {tol:.3g}" in sol.message


# --------------------------------------------------------------------------- input validation
@pytest.mark.parametrize("build, pattern", [
    (lambda: magnetic_rod().__class__(length=0.05, radius=1e-3, youngs_modulus=1e6, density=1e3,
                                      magnets=(PointMagnet(s=0.06, moment_body=(0, 0, 1e-3)),)),
     r"magnets\[0\]\.s=0\.06 is invalid: .*\(a magnet outside the rod\)"),
    (lambda: solve(rod(), tip_load((0, 0, -1), s=-0.01)),
     r"point_loads\[0\]\.s=-0\.01 is invalid: .*a point load outside"),
    (lambda: rod(rigid_segments=(RigidSegment(s0=0.1, s1=0.3, youngs_modulus=1e9, density=7e3),)),
     r"rigid_segments\[0\]=.* is invalid: .*outside the rod"),
    (lambda: rod(rigid_segments=(RigidSegment(s0=0.0, s1=0.1, youngs_modulus=1e9, density=7e3),
                                 RigidSegment(s0=0.05, s1=0.15, youngs_modulus=1e9, density=7e3))),
     r"rigid_segments=.* is invalid: segments that do not overlap"),
    (lambda: RigidSegment(s0=0.1, s1=0.05, youngs_modulus=1e9, density=7e3), r"rigid_segment=.*s0 < s1"),
    (lambda: rod(length=-1.0), r"length=-1\.0 is invalid"),
    (lambda: rod(base_rotation=np.eye(3) * 2), r"base_rotation=.* is invalid: a proper rotation"),
    (lambda: rod(gravity=(0, 0)), r"gravity=.* is invalid"),
    (lambda: solve(rod(), tol=-1.0), r"tol=-1\.0 is invalid"),
    (lambda: solve(rod(), n_steps=0), r"n_steps=0 is invalid"),
    (lambda: solve(magnetic_rod(), n_steps=3), r"n_steps=3 is invalid: at least 6: one RK4 step per interval"),
    (lambda: solve(rod(), guess=(1.0, 2.0)), r"guess=.* is invalid"),
    (lambda: solve(rod(), StaticLoads(magnetic_field=(0, 0, 0.02))), r"magnetic_field\.shape=\(1, 3\) is invalid"),
    (lambda: solve(magnetic_rod(), StaticLoads(magnetic_field=np.zeros((3, 3)))), r"magnetic_field\.shape=\(3, 3\)"),
    (lambda: StaticLoads(field_gradient=np.full((3, 3), np.nan)), r"field_gradient=\[\[nan, .* is invalid: a finite"),
    (lambda: StaticLoads(point_loads=(1.0,)), r"point_loads\[0\]=1\.0 is invalid"),
    (lambda: PointLoad(s=0.1, force=(1, 2)), r"point_load\.force=.* is invalid"),
    (lambda: solve(rod(), loads="gravity"), r"loads='StaticLoads'|loads='str' is invalid"),
])
def test_bad_input_is_a_one_line_error(build, pattern):
    with pytest.raises(SoftrnnInputError, match=pattern) as err:
        build()
    assert "\n" not in str(err.value)


# --------------------------------------------------------------------------- Fig. 13 study
def test_fig13_study_runs_and_writes_json_and_figure(tmp_path):
    result = run_fig13_study(repetitions=2, tolerances=(1e-4, 1e-8), n_steps=(6, 13), guess_errors=(0.0, 0.1))
    sweep = result["tolerance_sweep"]
    assert np.array(sweep["mean_ms"]).shape == (2, 2)
    assert np.all(np.array(sweep["converged"]) == 1.0)
    assert np.all(np.array(result["node_sweep"]["converged"]) == 1.0)
    # a guess off by 10 % needs iterations; the exact one none
    assert sweep["iterations"][1][0] == 0 and sweep["iterations"][1][1] >= 1
    assert result["paper"]["bandwidth_hz"] == [8.33, 50.0]
    write_fig13(result, tmp_path / "fig13.json", tmp_path / "fig13.png")
    assert json.loads((tmp_path / "fig13.json").read_text())["repetitions"] == 2
    assert (tmp_path / "fig13.png").stat().st_size > 10_000
    assert sorted(p.name for p in tmp_path.iterdir()) == ["fig13.json", "fig13.png"]  # no temporary files left
