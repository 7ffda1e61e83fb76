"""The displacement-driven tendon robot: closed forms of one segment (the kinematic limit, the
series spring, slack), the complementarity of opposing tendons, a segment's tendon bending only
its own and the segments below, and the calibration recovering a known robot."""

import numpy as np
import pytest

from softrnn.errors import SoftrnnInputError
from softrnn.lab.recording import read_recording
from softrnn.lab.tendon_robot import (
    CalibrationOptions,
    TendonParameters,
    TendonRobot,
    calibrate,
    tip_positions,
)

from helpers import tendon_recording, tendon_robot_truth

L, R = 0.1, 5e-3


def _one_segment(compliance, offsets=(0.0, 0.0, 0.0)):
    robot = TendonRobot((L,), 3, R)
    params = TendonParameters(angles=np.radians([0.0, 120.0, 240.0]), offsets=np.asarray(offsets), routing_radius=R,
                              compliance=np.array([compliance]), marker=0.0, rotation=np.zeros(3), base=np.zeros(3))
    return robot, params


def _arc_tip(kappa):
    """The tip of a constant-curvature arc of length L bending toward +x."""
    return np.array([(1 - np.cos(kappa * L)) / kappa, 0.0, np.sin(kappa * L) / kappa])


@pytest.mark.parametrize("q", [1e-3, 3e-3, 6e-3])
def test_series_spring_closed_form(q):
    """One tendon pulled by q through a spring k on a backbone EI: kappa = beta r q / (1 + beta r^2 L)
    with beta = k / EI; the other two tendons slack (released)."""
    beta = 2.0 / (R ** 2 * L)
    robot, params = _one_segment(beta)
    tip, tau = tip_positions(robot, params, np.array([[q, -5e-3, -5e-3]]))
    kappa = beta * R * q / (1 + beta * R ** 2 * L)
    np.testing.assert_allclose(tip[0], _arc_tip(kappa), atol=1e-9)
    np.testing.assert_allclose(tau[0], [q / (1 + beta * R ** 2 * L), 0.0, 0.0], atol=1e-12)


def test_stiff_tendons_reach_the_kinematic_limit():
    """k >> EI / (r^2 L): the tendon shortens by what the servo pulls, kappa -> q / (r L)."""
    q = 4e-3
    robot, params = _one_segment(1e6 / (R ** 2 * L))
    tip, _ = tip_positions(robot, params, np.array([[q, -5e-3, -5e-3]]))
    np.testing.assert_allclose(tip[0], _arc_tip(q / (R * L)), rtol=1e-5)


def test_slack_tendons_leave_the_backbone_straight():
    robot, params = _one_segment(1.0 / (R ** 2 * L), offsets=(1e-3, 1e-3, 1e-3))
    q = np.array([[-2e-3, 0.5e-3, 1e-3], [0.0, 0.0, 0.0]])   # every pull within its slack
    tip, tau = tip_positions(robot, params, q)
    np.testing.assert_allclose(tip, [[0, 0, L], [0, 0, L]], atol=1e-15)
    assert np.all(tau == 0.0)


def test_equal_pulls_cancel_and_share_the_tension():
    """All three tendons pulled alike: the moments cancel (no bending), every tendon carries
    tau / k = q (nothing shortens); the complementarity holds on every row."""
    beta = 1.0 / (R ** 2 * L)
    robot, params = _one_segment(beta)
    tip, tau = tip_positions(robot, params, np.array([[2e-3, 2e-3, 2e-3]]))
    np.testing.assert_allclose(tip[0], [0, 0, L], atol=1e-10)
    np.testing.assert_allclose(tau[0], [2e-3] * 3, rtol=1e-6)
    rng = np.random.default_rng(1)
    q = rng.uniform(-3e-3, 5e-3, (50, 3))
    _, tau = tip_positions(robot, params, q)
    rho = R * np.stack([np.cos(params.angles), np.sin(params.angles)], 1)
    M = np.eye(3) + beta * L * rho @ rho.T
    w = tau @ M.T - q
    assert np.all(tau >= 0) and np.all(w >= -1e-9) and np.all(np.abs(tau * w) < 1e-12)


def test_a_segments_tendon_bends_only_up_to_its_end():
    """Segment 1's tendon pulled on a two-segment robot: segment 2 stays straight, along the
    tangent at segment 1's end."""
    robot = TendonRobot((L, L), 3, R)
    params = TendonParameters(angles=np.radians([0, 120, 240, 60, 180, 300]), offsets=np.zeros(6), routing_radius=R,
                              compliance=np.full(2, 1.0 / (R ** 2 * L)), marker=0.0, rotation=np.zeros(3),
                              base=np.zeros(3))
    q = np.array([[2e-3, -5e-3, -5e-3, -5e-3, -5e-3, -5e-3]])
    tip, tau = tip_positions(robot, params, q)
    kappa = tau[0, 0] * params.compliance[0] * R
    end, angle = _arc_tip(kappa), kappa * L
    np.testing.assert_allclose(tip[0], end + L * np.array([np.sin(angle), 0.0, np.cos(angle)]), atol=1e-12)


def test_calibration_recovers_a_known_robot(tmp_path):
    """Noise-free synthetic poses of a known robot: the fit reproduces them and predicts other
    commands to a fraction of a millimetre."""
    truth_robot, truth = tendon_robot_truth(1)
    _, u, tip = tendon_recording(tmp_path / "a.csv", rows=160, noise_mm=0.0)
    cal = calibrate(TendonRobot((0.08,), 3, 4.5e-3), u * 1e-3, tip * 1e-3,
                    CalibrationOptions(quick_evaluations=40, evaluations=300))
    assert cal.rmse_m < 0.05e-3
    rng = np.random.default_rng(5)
    q = rng.uniform(-2e-3, 3e-3, (40, 3))
    np.testing.assert_allclose(cal.predict(q), tip_positions(truth_robot, truth, q)[0], atol=0.3e-3)


def test_calibration_recovers_two_segments_of_four_tendons():
    """Four tendons per segment, 90 degrees apart, the distal segment's turned by 45 degrees: from
    noise-free tips of 160 rows pulling both segments, the fit reproduces them and predicts other
    commands to a fraction of a millimetre (the search's starts are built for any tendon count)."""
    robot = TendonRobot((0.1, 0.08), 4, 5e-3)
    truth = TendonParameters(angles=np.radians(np.tile([0.0, 90.0, 180.0, 270.0], 2) + np.repeat([0.0, 45.0], 4)),
                             offsets=np.full(8, -0.4e-3), routing_radius=5e-3,
                             compliance=np.full(2, 1.0 / (5e-3 ** 2 * 0.09)), marker=5e-3, rotation=np.zeros(3),
                             base=np.array([0.0, 0.0, 0.01]))
    k = np.arange(160)[:, None]
    u = 3e-3 * np.sin(0.07 * k * (1 + 0.3 * np.arange(8)) + np.random.default_rng(0).uniform(0, 6.3, 8)) - 0.5e-3
    tip = tip_positions(robot, truth, u)[0]
    cal = calibrate(TendonRobot((0.1, 0.08), 4, 4.5e-3), u, tip)
    assert cal.rmse_m < 0.05e-3 and cal.params.angles.shape == (8,)
    q = np.random.default_rng(5).uniform(-2e-3, 3e-3, (40, 8))
    np.testing.assert_allclose(cal.predict(q), tip_positions(robot, truth, q)[0], atol=0.3e-3)


def test_calibration_refuses_inputs_that_do_not_match_the_robot(tmp_path):
    tendon_recording(tmp_path / "a.csv", rows=30)
    rec = read_recording(tmp_path / "a.csv")
    with pytest.raises(SoftrnnInputError, match="--segments and --tendons-per-segment"):
        calibrate(TendonRobot((0.04, 0.04), 3), rec.inputs * 1e-3, rec.tip)


def test_agrees_with_the_cosserat_statics_of_displacement_tendons():
    """The same two-segment robot in the Cosserat static solver (weightless Kirchhoff rod, tendons
    driven by displacements through a series spring, an independent implementation: shooting with
    the tensions as unknowns): constant curvature per segment is its exact solution, so the tips
    and the tensions agree to the solvers' tolerance."""
    from softrnn.rod import Tendon
    from softrnn.statics import StaticRod, solve

    L2, r, E, radius, k = 0.2, 0.006, 2e6, 0.008, 3000.0
    EI = E * np.pi * radius ** 4 / 4
    angles = np.radians([0.0, 120.0, 240.0, 60.0, 180.0, 300.0])
    q = np.array([3e-3, -2e-3, -2e-3, -2e-3, 2e-3, 1.2e-3])
    tendons = [Tendon(name=f"t{i}", offset=(r * np.cos(a), r * np.sin(a)), displacement=float(q[i]), stiffness=k,
                      end_s=0.1 if i < 3 else 0.2) for i, a in enumerate(angles)]
    sol = solve(StaticRod(length=L2, radius=radius, youngs_modulus=E, density=1000.0, poisson_ratio=0.5,
                          gravity=(0.0, 0.0, 0.0), tendons=tuple(tendons), extensible_shearable=False), tol=1e-12)
    sol.raise_for_status()
    robot = TendonRobot((0.1, 0.1), 3, r)
    params = TendonParameters(angles=angles, offsets=np.zeros(6), routing_radius=r, compliance=np.full(2, k / EI),
                              marker=0.0, rotation=np.zeros(3), base=np.zeros(3))
    tip, tau = tip_positions(robot, params, q[None])
    # the static rod lies along d3 = +x with d1 = +z, d2 = -y; the model along +z with d1 = +x
    cosserat = np.array([sol.positions[-1, 2], -sol.positions[-1, 1], sol.positions[-1, 0]])
    assert np.linalg.norm(tip[0]) > 0 and np.linalg.norm(tip[0, :2]) > 0.05 * L2      # well bent
    np.testing.assert_allclose(tip[0], cosserat, atol=1e-7 * L2)
    np.testing.assert_allclose(tau[0] * k, sol.tendon_tensions, rtol=1e-6, atol=1e-9)


def _twisted_truth(twist_deg):
    """A two-segment robot whose second segment's tendons are turned by ``twist_deg`` from the first's,
    and its noise-free tips for smooth random pulls: (robot, q (K, 6) [m], tip (K, 3) [m])."""
    robot = TendonRobot((0.08, 0.08), 3, 4e-3)
    angles = np.radians(np.tile([0.0, 120.0, 240.0], 2) + np.repeat([0.0, twist_deg], 3))
    truth = TendonParameters(angles=angles, offsets=np.full(6, -0.5e-3), routing_radius=4e-3,
                             compliance=np.full(2, 1.0 / (4e-3 ** 2 * 0.08)), marker=5e-3, rotation=np.zeros(3),
                             base=np.array([0.0, 0.0, 0.01]))
    k = np.arange(200)
    q = (3.0 * np.sin(0.07 * k[:, None] * (1 + 0.3 * np.arange(6)) + np.arange(6)) - 0.5) * 1e-3
    return robot, q, tip_positions(robot, truth, q)[0]


def test_the_start_search_covers_every_twist_of_a_full_turn():
    """The segments' tendons turned by 100 deg: the default search (both orders x 18 twists over a
    full turn, screened, the best six fitted on) finds the robot; from one twist (0) alone the search
    stops in a worse minimum."""
    robot, q, tip = _twisted_truth(100.0)
    found = calibrate(robot, q, tip)
    one = calibrate(robot, q, tip, CalibrationOptions(twists=1))
    assert found.rmse_m < 0.1e-3 < one.rmse_m
    assert len(found.starts) == 36 and sum("rmse_mm" in s for s in found.starts) == 6
    assert all("screen_rmse_mm" in s for s in found.starts)


def test_the_screen_options_are_validated():
    with pytest.raises(SoftrnnInputError, match="twists"):
        CalibrationOptions(twists=0)
    with pytest.raises(SoftrnnInputError, match="screen_evaluations"):
        CalibrationOptions(screen_evaluations=0, screen_keep=3)


def _lcp_by_enumeration(M, b):
    """The LCP's solution found by trying every set of taut tendons (the one whose solve meets every
    condition)."""
    n = b.size
    for mask in range(2 ** n):
        taut = np.array([(mask >> i) & 1 for i in range(n)], dtype=bool)
        tau = np.zeros(n)
        if taut.any():
            tau[taut] = np.linalg.solve(M[np.ix_(taut, taut)], b[taut])
        w = M @ tau - b
        if (tau >= -1e-13).all() and (w[~taut] >= -1e-13).all():
            return tau
    raise AssertionError("no solution")


def test_the_tensions_solve_the_complementarity_problem_exactly():
    """Random positive definite I + A (rank-deficient A, as the routing's) and loads: the pivoting solve
    equals the solution found by enumerating every set of taut tendons, row after row (each row starting
    from the row before's set), with M tau - b >= 0, tau >= 0 and tau (M tau - b) = 0 to round-off; a
    matrix that is singular in floating point falls back to Gauss-Seidel and stays finite."""
    from softrnn.lab.tendon_robot import _tensions

    rng = np.random.default_rng(4)
    for _ in range(20):
        rho = rng.normal(size=(6, 2)) * 4e-3
        M = np.eye(6) + rng.uniform(1e3, 1e5) * (rho @ rho.T)
        b = rng.normal(scale=5e-3, size=(40, 6))
        tau = np.empty_like(b)
        _tensions(M, b, tau)
        for k in range(len(b)):
            np.testing.assert_allclose(tau[k], _lcp_by_enumeration(M, b[k]), rtol=1e-9, atol=1e-15)
            w = M @ tau[k] - b[k]
            assert (tau[k] >= 0).all() and (w >= -1e-15).all() and abs(tau[k] @ w) < 1e-15
    rho = np.array([[1.0, 0.0], [-0.5, 0.8], [-0.5, -0.8]]) * 4e-3
    M = np.eye(3) + 1e25 * (rho @ rho.T)                    # I lost against A: singular in floating point
    tau = np.empty((2, 3))
    _tensions(M, np.array([[1e-3, 0.0, 0.0], [2e-3, 1e-3, 0.0]]), tau)
    assert np.isfinite(tau).all() and (tau >= 0).all()


def test_the_tensions_with_friction_solve_their_unsymmetric_complementarity_problem():
    """With friction along the routing a tendon's tension falls along its path, so the matrix of the
    tension solve is I + A F with F the capstan factors of each tendon in each segment: unsymmetric.
    The pivoting solve equals the enumerated solution and meets every condition there too (a Cholesky
    solve of the lower triangle would not: most of these rows failed when it was used)."""
    from softrnn.lab.tendon_kernels import _lcp

    rng = np.random.default_rng(7)
    n, S = 6, 2
    seg = np.array([0, 0, 0, 1, 1, 1])
    for _ in range(20):
        rho = rng.normal(size=(n, 2)) * 4e-3
        L, compliance = np.array([0.1, 0.1]), rng.uniform(1e5, 1e6, S)
        f = np.exp(-rng.uniform(0.05, 0.4) * rng.choice([-1.0, 1.0], n)[:, None] * rng.uniform(0.0, 2.0, (n, S)))
        M = np.eye(n) + np.array([[sum(L[s] * compliance[s] * f[j, s] for s in range(min(seg[i], seg[j]) + 1))
                                   * (rho[i] @ rho[j]) for j in range(n)] for i in range(n)])
        assert not np.allclose(M, M.T)
        tau, active, A, idx = np.zeros(n), np.zeros(n, dtype=bool), np.empty((n, n + 1)), np.empty(n, dtype=np.int64)
        for b in rng.normal(scale=5e-3, size=(10, n)):
            _lcp(M, b, tau, active, A, idx)                  # warm-started from the row before
            np.testing.assert_allclose(tau, _lcp_by_enumeration(M, b), rtol=1e-9, atol=1e-15)
            w = M @ tau - b
            assert (tau >= 0).all() and (w >= -1e-15).all() and abs(tau @ w) < 1e-15
