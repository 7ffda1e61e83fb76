"""The tendon robot's fuller physics: gravity (checked against the Cosserat statics and
Euler-Bernoulli for a cantilever under its own weight) and friction along the routing (the capstan
ratio, hysteresis between pull and release), both off reproducing the plain model, the options and
the calibration recovering a known robot with both."""

import dataclasses

import numpy as np
import pytest

from softrnn.errors import SoftrnnInputError
from softrnn.lab.physics_variants import VARIANTS, choose_physics
from softrnn.lab.recording import read_recording
from softrnn.lab.tendon_robot import (
    CalibrationOptions,
    TendonParameters,
    TendonRobot,
    calibrate,
    session_resets,
    solve_rows,
    tip_positions,
)

from helpers import tendon_recording, tendon_robot_truth

R = 4e-3


def _robot(n_segments, L=0.1, compliance=None, **extra):
    robot = TendonRobot(tuple([L] * n_segments), 3, R)
    angles = np.radians(np.tile([0.0, 120.0, 240.0], n_segments) + np.repeat(np.arange(n_segments) * 40.0, 3))
    c = np.full(n_segments, 1.0 / (R ** 2 * L) if compliance is None else compliance)
    params = TendonParameters(angles=angles, offsets=np.zeros(3 * n_segments), routing_radius=R, compliance=c,
                              marker=2e-3, rotation=np.array([0.1, -0.2, 0.3]), base=np.array([0.01, 0.0, 0.02]),
                              **extra)
    return robot, params


def test_no_weight_and_no_friction_reproduce_the_plain_model():
    """mu = 0 and a zero weight in the row-by-row solver give the plain model's tips and tensions, to
    rounding: both solve the tensions exactly, by the same active-set method."""
    robot, plain = _robot(2)
    q = np.random.default_rng(3).uniform(-3e-3, 4e-3, (60, 6))
    tip, tau = tip_positions(robot, plain, q)
    for extra in (dict(friction=0.0), dict(gravity=np.zeros(3)), dict(friction=0.0, gravity=np.zeros(3))):
        other = dataclasses.replace(plain, **extra)
        assert not other.plain
        tip2, tau2 = tip_positions(robot, other, q)
        np.testing.assert_allclose(tip2, tip, rtol=0, atol=1e-14)
        np.testing.assert_allclose(tau2, tau, rtol=0, atol=1e-15)


@pytest.mark.parametrize("segments", [1, 2])
@pytest.mark.parametrize("fraction, tolerance", [(0.01, 0.002), (0.05, 0.006), (0.15, 0.02)])
def test_cantilever_under_its_own_weight_matches_the_cosserat_statics(segments, fraction, tolerance):
    """A horizontal cantilever without tendons bent by its own weight w: the tip lies within
    ``tolerance`` x its deflection of the Cosserat statics (a Kirchhoff rod, RK4 shooting), and its
    deflection within 2 % of Euler-Bernoulli's w L^4 / (8 EI) (``fraction`` of L)."""
    from softrnn.statics import StaticRod, solve

    L, radius, density = 0.2, 2e-3, 1000.0
    w = density * np.pi * radius ** 2 * 9.81
    EI = w * L ** 4 / (8 * fraction * L)
    E = EI / (np.pi * radius ** 4 / 4)
    sol = solve(StaticRod(length=L, radius=radius, youngs_modulus=E, density=density, poisson_ratio=0.5,
                          gravity=(0.0, 0.0, -9.81), extensible_shearable=False), tol=1e-12)
    sol.raise_for_status()
    # the static rod lies along d3 = +x with d1 = +z, d2 = -y (gravity along -d1); the model along +z, d1 = +x
    cosserat = np.array([sol.positions[-1, 2], -sol.positions[-1, 1], sol.positions[-1, 0]])
    robot = TendonRobot(tuple([L / segments] * segments), 3, R)
    # no tendon pulls (every slack 1 m); k = 1 N/m, so compliance = 1 / EI and gravity = w g_hat
    params = TendonParameters(angles=np.radians(np.tile([0.0, 120.0, 240.0], segments)),
                              offsets=np.ones(3 * segments), routing_radius=R, compliance=np.full(segments, 1 / EI),
                              marker=0.0, rotation=np.zeros(3), base=np.zeros(3), gravity=np.array([-w, 0.0, 0.0]))
    tip, tau, _, _, _ = solve_rows(robot, params, np.zeros((1, 3 * segments)))
    deflection = w * L ** 4 / (8 * EI)
    assert np.all(tau == 0.0)
    assert np.linalg.norm(tip[0] - cosserat) < tolerance * abs(cosserat[0])
    assert -tip[0, 0] == pytest.approx(deflection, rel=0.02)
    assert tip[0, 1] == pytest.approx(0.0, abs=1e-15)


def _bends(mu, rows, n_segments=2):
    robot, params = _robot(n_segments, friction=mu)
    q = np.full((len(rows), 3 * n_segments), -5e-3)
    q[:, 3 * (n_segments - 1)] = rows                   # the last segment's first tendon
    return robot, params, solve_rows(robot, params, q)


@pytest.mark.parametrize("rows, sign", [([0.0, 3e-3], 1.0), ([6e-3, 3e-3], -1.0)])
def test_capstan_ratio_of_a_known_wrap(rows, sign):
    """A tendon of segment 2 pulled (its command grew) or released: its tension in segment 2 over
    that in segment 1 is exp(-+ mu phi), phi the wrap between the segments' middles (half of each
    one's bending angle); frictionless, the two segments bend alike."""
    mu, L = 0.3, 0.1
    _, _, (_, _, bend, _, _) = _bends(mu, rows)
    kappa = np.linalg.norm(bend[-1], axis=1)
    wrap = 0.5 * (kappa[0] + kappa[1]) * L
    assert wrap > 0.1
    np.testing.assert_allclose(kappa[1] / kappa[0], np.exp(-sign * mu * wrap), rtol=1e-7)
    _, _, (_, _, still, _, _) = _bends(0.0, rows)
    np.testing.assert_allclose(*np.linalg.norm(still[-1], axis=1), rtol=1e-9)


def test_pull_and_release_of_one_command_differ_and_bracket_the_frictionless_tip():
    """Hysteresis: the same command reached by a pull bends the robot less than reached by a
    release; the frictionless robot lies between; a held command keeps the last direction."""
    base = []
    for mu in (0.0, 0.2):
        robot, params, (tip_pull, *_) = _bends(mu, [0.0, 3e-3, 3e-3])
        _, _, (tip_release, *_) = _bends(mu, [6e-3, 3e-3])
        base.append((tip_pull[1], tip_release[1]))
        np.testing.assert_allclose(tip_pull[2], tip_pull[1], atol=1e-12)
    (free, free_release), (pull, release) = base
    np.testing.assert_allclose(free, free_release, atol=1e-12)
    straight = tip_positions(*_robot(2), np.full((1, 6), -5e-3))[0][0]

    def reach(p):
        return np.linalg.norm(p - straight)

    assert reach(pull) < reach(free) < reach(release)
    assert np.linalg.norm(pull - release) > 0.005 * reach(free)


def test_a_session_start_resets_the_friction_direction():
    robot, params = _robot(1, friction=0.2)
    q = np.array([[0.0, -5e-3, -5e-3], [3e-3, -5e-3, -5e-3], [3e-3, -5e-3, -5e-3]])
    first = tip_positions(robot, params, q[2:])[0]
    joined = tip_positions(robot, params, q, session_resets([2, 1]))[0]
    np.testing.assert_allclose(joined[2], first[0], atol=1e-14)
    assert np.linalg.norm(tip_positions(robot, params, q)[0][2] - first[0]) > 1e-5


def test_options_and_parameters():
    assert CalibrationOptions().variant == "plain"
    assert CalibrationOptions(gravity=True, friction=True).variant == "gravity+friction"
    with pytest.raises(SoftrnnInputError, match="gravity"):
        CalibrationOptions(gravity="yes")
    with pytest.raises(SoftrnnInputError, match="friction_max"):
        CalibrationOptions(friction_max=-0.1)
    robot, params = _robot(2, gravity=np.array([1e-4, -2e-4, -5e-4]), friction=0.15)
    d = params.to_dict(robot)
    assert d["routing_friction"] == 0.15 and d["weight_over_series_stiffness"] == pytest.approx(np.sqrt(30) * 1e-4)
    back = TendonParameters.from_dict(d)
    np.testing.assert_allclose(back.gravity, params.gravity, rtol=1e-5)
    q = np.random.default_rng(0).uniform(-2e-3, 3e-3, (20, 6))
    np.testing.assert_allclose(tip_positions(robot, back, q)[0], tip_positions(robot, params, q)[0], atol=2e-6)
    assert "weight_over_series_stiffness" not in _robot(2)[1].to_dict(robot)


def test_calibration_recovers_gravity_and_friction():
    """Noise-free poses of a known robot with gravity (tilted base) and friction: refined from a
    perturbed start, the fit reproduces them and finds mu, the weight and (loosely: a tilt of gravity
    is nearly one of the base, and the fit settles anywhere along that valley) gravity's direction; its
    tips for commands it was not fitted on are the robot's."""
    truth_robot, plain = tendon_robot_truth(2)
    truth = dataclasses.replace(plain, gravity=2e-4 * np.array([0.3, 0.0, -0.95]) / np.hypot(0.3, 0.95),
                                friction=0.2)
    rng = np.random.default_rng(2)
    k = np.arange(200)
    q = 3e-3 * np.sin(0.09 * k[:, None] * (1 + 0.3 * np.arange(6)) + rng.uniform(0, 6, 6)) - 0.5e-3
    tip = tip_positions(truth_robot, truth, q)[0]
    start = dataclasses.replace(plain, offsets=plain.offsets + 0.2e-3, compliance=plain.compliance * 1.2,
                                base=plain.base + 1e-3)
    cal = calibrate(truth_robot, q, tip, CalibrationOptions(gravity=True, friction=True, variant_evaluations=200),
                    start=start)
    assert cal.rmse_m < 0.02e-3
    assert cal.params.friction == pytest.approx(0.2, abs=0.02)
    weight = np.linalg.norm(cal.params.gravity)
    assert weight == pytest.approx(2e-4, rel=0.05)
    assert np.degrees(np.arccos(cal.params.gravity @ truth.gravity / (weight * 2e-4))) < 30.0
    fresh = 3e-3 * np.cos(0.05 * k[:, None] * (1 + 0.2 * np.arange(6)) + rng.uniform(0, 6, 6)) - 0.5e-3
    np.testing.assert_allclose(cal.predict(fresh), tip_positions(truth_robot, truth, fresh)[0], atol=0.01e-3)


def test_the_hold_out_chooses_among_the_variants(tmp_path):
    tendon_recording(tmp_path / "a.csv", rows=120, noise_mm=0.0)
    rec = read_recording(tmp_path / "a.csv")
    fit_part = [dataclasses.replace(rec, time=rec.time[:90], inputs=rec.inputs[:90], tip=rec.tip[:90],
                                    labels=rec.labels[:90])]
    held = [dataclasses.replace(rec, time=rec.time[90:], inputs=rec.inputs[90:], tip=rec.tip[90:],
                                labels=rec.labels[90:])]
    pick = choose_physics(TendonRobot((0.08,), 3, 4.5e-3), CalibrationOptions(quick_evaluations=20, evaluations=100,
                                                                              variant_evaluations=30),
                          fit_part, held, [rec])
    assert set(pick.holdout_rmse_mm) == set(VARIANTS)
    assert pick.variant == min(pick.holdout_rmse_mm, key=pick.holdout_rmse_mm.get)
    assert pick.physics.options.variant == pick.variant == pick.physics.describe()["variant"]
    with pytest.raises(SoftrnnInputError, match="variants"):
        choose_physics(TendonRobot((0.08,), 3), CalibrationOptions(), fit_part, held, [rec], variants=("wind",))


@pytest.mark.parametrize("gravity", [(0.0, 0.0, -9.81), (-9.81, 0.0, 0.0), (9.81, 0.0, 0.0)])
def test_tendons_and_weight_together_follow_the_cosserat_statics(gravity):
    """A two-segment robot bent by displacement-driven tendons and its own weight (a heavy, soft
    backbone: the weight moves the tip by 2-18 mm): the model's tip moves by the weight within 5 %
    of that motion of the Cosserat statics' tip (the same tendons, a Kirchhoff rod)."""
    from softrnn.rod import Tendon
    from softrnn.statics import StaticRod, solve

    L2, r, E, radius, k, density = 0.2, 0.006, 2e6, 0.008, 3000.0, 1000.0
    EI, w = E * np.pi * radius ** 4 / 4, density * np.pi * radius ** 2 * 9.81
    angles = np.radians([0.0, 120.0, 240.0, 60.0, 180.0, 300.0])
    q = np.array([3e-3, -2e-3, -2e-3, -2e-3, 2e-3, 1.2e-3])
    tendons = tuple(Tendon(name=f"t{i}", offset=(r * np.cos(a), r * np.sin(a)), displacement=float(q[i]),
                           stiffness=k, end_s=0.1 if i < 3 else 0.2) for i, a in enumerate(angles))
    tips = []
    for g in ((0.0, 0.0, 0.0), gravity):
        sol = solve(StaticRod(length=L2, radius=radius, youngs_modulus=E, density=density, poisson_ratio=0.5,
                              gravity=g, tendons=tendons, extensible_shearable=False), tol=1e-12)
        sol.raise_for_status()
        tips.append(np.array([sol.positions[-1, 2], -sol.positions[-1, 1], sol.positions[-1, 0]]))
    robot = TendonRobot((0.1, 0.1), 3, r)
    plain = TendonParameters(angles=angles, offsets=np.zeros(6), routing_radius=r, compliance=np.full(2, k / EI),
                             marker=0.0, rotation=np.zeros(3), base=np.zeros(3))
    # the static rod's frame (d3 = +x, d1 = +z, d2 = -y) in the model's (+z, +x, +y)
    g_model = np.array([gravity[2], -gravity[1], gravity[0]]) / 9.81
    tip = solve_rows(robot, dataclasses.replace(plain, gravity=g_model * w / k), q[None])[0][0]
    motion = tips[1] - tips[0]
    assert np.linalg.norm(motion) > 1e-3
    assert np.linalg.norm(tip - tips[1]) < 0.05 * np.linalg.norm(motion)


def _fixed_point_misfit(robot, params, qk, bend_k, tau_k):
    """max |G(b) - b| [1/m] of one row's bending vectors b (``tendon_kernels._pass`` once from there)."""
    from softrnn.lab import tendon_kernels as tk

    n, S = robot.n_tendons, robot.n_segments
    rho = params.routing_radius * np.stack([np.cos(params.angles), np.sin(params.angles)], axis=1)
    work = tk.scratch(n, S)
    g = np.empty((S, 2))
    tk._pass(qk, robot.segment_of, np.asarray(robot.segment_lengths), np.asarray(params.compliance, float), rho,
             np.asarray(params.offsets, float), 0.0, np.asarray(params.gravity, float), True, bend_k.copy(),
             tau_k.copy(), np.zeros(n), np.ones((n, S)), np.zeros((2, S, 2)), np.empty((n, n)), np.empty(n), work, g)
    return np.abs(g - bend_k).max()


def test_a_row_the_accelerated_passes_leave_unsettled_is_solved_by_newton():
    """A heavy hanging robot pulled hard in one row: the Anderson-accelerated passes do not settle
    (the pass map overshoots), Newton's method does, to a true fixed point b = G(b); a heavy upright
    robot pulled hard (it buckles: no equilibrium near its start) is reported unsettled (passes < 0)."""
    from softrnn.lab.tendon_kernels import FIXED_POINT_PASSES

    robot, params = _robot(2, gravity=np.array([0.0, 0.0, 0.01]))
    q = np.zeros((2, 6))
    q[1, 0] = 10e-3
    tip, tau, bend, passes, _ = solve_rows(robot, params, q)
    assert passes[1] > FIXED_POINT_PASSES
    assert _fixed_point_misfit(robot, params, q[1], bend[1], tau[1]) < 1e-8
    assert np.linalg.norm(bend[1], axis=1).min() > 1.0            # it bends
    robot, params = _robot(3, gravity=np.array([0.0, 0.0, -0.01]))
    q = np.zeros((2, 9))
    q[1, 0] = 10e-3
    assert solve_rows(robot, params, q)[3][1] < 0


@pytest.mark.parametrize("gravity, friction", [(True, False), (False, True), (True, True)])
def test_the_implicit_jacobian_matches_central_differences_of_the_whole_solve(gravity, friction, monkeypatch):
    """The calibration's derivatives of a robot whose rows are fixed points solved by passes (weight,
    friction): from single passes at the rows' solution (implicit differentiation), each column within
    1e-5 of central differences of the whole solve with a step 600 times larger, as accurate as the
    optimiser's own forward differences of it, and so are the whole solve's forward differences it falls
    back on where a row's fixed point forks (a singular system); with creep the rows depend on each
    other, and the optimiser differences the solve itself."""
    from scipy.optimize._numdiff import approx_derivative

    from softrnn.lab.tendon_robot import PHYSICS_OPTIONS, _bounds, _TipResidual, pack

    robot, plain = tendon_robot_truth(2)
    params = dataclasses.replace(plain, gravity=np.array([1e-4, -2e-4, 3e-4]) if gravity else None,
                                 friction=0.15 if friction else None)
    k = np.arange(60)
    q = 3e-3 * np.sin(0.11 * k[:, None] * (1 + 0.3 * np.arange(6)) + np.arange(6)) - 0.5e-3
    tip = tip_positions(robot, params, q)[0] + 1e-4
    options = CalibrationOptions(gravity=gravity, friction=friction)
    flags = tuple((name, getattr(options, name)) for name in PHYSICS_OPTIONS)
    residual = _TipResidual(robot, q, tip, None, flags, upper=_bounds(robot, options)[1])
    assert residual.implicit
    x = pack(params)
    reference = approx_derivative(residual, x, method="3-point", rel_step=1e-5)
    column = np.linalg.norm(reference, axis=0)
    assert np.all(column > 0)
    for J in (residual.jacobian(x), approx_derivative(residual, x, method="2-point")):
        assert np.max(np.linalg.norm(J - reference, axis=0) / column) < 1e-5

    def singular(*args):
        raise np.linalg.LinAlgError("Singular matrix")
    monkeypatch.setattr(np.linalg, "solve", singular)
    assert np.max(np.linalg.norm(residual.jacobian(x) - reference, axis=0) / column) < 1e-5
    crept = CalibrationOptions(gravity=gravity, friction=friction, creep=True)
    assert not _TipResidual(robot, q, tip, None, tuple((n, getattr(crept, n)) for n in PHYSICS_OPTIONS)).implicit
