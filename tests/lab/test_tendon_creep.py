"""The tendons' creep in the tendon robot's physics: the slack's closed form under a held pull, the
equivalence with the plain model shifted by the slack each row saw, no creep across the gap
between sessions, the timeline a prediction starts from, the calibration recovering a known
creep rate (with rows that run but are not fitted), and its errors."""

import dataclasses
from types import SimpleNamespace

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from softrnn.errors import SoftrnnInputError
from softrnn.lab.families import Physics, displacements, masked
from softrnn.lab.recording import Recording
from softrnn.lab.synthetic import _after_calibration
from softrnn.lab.tendon_robot import (
    CalibrationOptions,
    CreepTimeline,
    TendonParameters,
    TendonRobot,
    calibrate,
    session_resets,
    solve_rows,
    tip_positions,
)

L, R = 0.1, 4e-3


def _robot(n_segments=1, creep=None, offsets=None):
    robot = TendonRobot(tuple([L] * n_segments), 3, R)
    angles = np.radians(np.tile([0.0, 120.0, 240.0], n_segments) + np.repeat(np.arange(n_segments) * 40.0, 3))
    params = TendonParameters(angles=angles, offsets=np.zeros(3 * n_segments) if offsets is None else offsets,
                              routing_radius=R, compliance=np.full(n_segments, 1.0 / (R ** 2 * L)), marker=2e-3,
                              rotation=np.array([0.1, -0.2, 0.3]), base=np.array([0.01, 0.0, 0.02]), creep=creep)
    return robot, params


def test_a_held_pull_creeps_as_the_closed_form():
    """One tendon of one segment held at q (the others slack): tau' = (q - s) / (1 + a), a = beta r^2 L
    with beta = k / EI, and s_{k+1} = s_k + gamma dt tau'_k / n, so s_k = q (1 - (1 - h)^k) with
    h = gamma dt / (n (1 + a)): the slack each row sees, and the tension that follows it."""
    gamma, dt, rows, q = 2e-2, 0.5, 400, 3e-3
    robot, params = _robot(creep=gamma)
    a = params.compliance[0] * R ** 2 * L
    command = np.tile([q, -5e-3, -5e-3], (rows, 1))
    _, tau, _, _, slack = solve_rows(robot, params, command, times=np.arange(rows) * dt)
    h = gamma * dt / (3 * (1 + a))
    expected = q * (1 - (1 - h) ** np.arange(rows))
    np.testing.assert_allclose(slack, expected, rtol=1e-12, atol=1e-18)
    np.testing.assert_allclose(tau[:, 0], (q - expected) / (1 + a), rtol=1e-9)
    assert slack[-1] > 0.1 * q                                  # it crept a good part of the pull


def test_creep_is_the_plain_model_with_the_slack_each_row_saw():
    """Two segments, random commands and intervals: each row of the creeping model equals the plain model
    with every offset grown by that row's slack, and the slack grows by gamma x the mean tension x the
    time to the next row."""
    rng = np.random.default_rng(4)
    robot, params = _robot(2, creep=5e-3, offsets=rng.uniform(-1e-3, 0.5e-3, 6))
    q = rng.uniform(-2e-3, 4e-3, (50, 6))
    times = np.cumsum(rng.uniform(0.2, 3.0, 50))
    tip, tau, _, _, slack = solve_rows(robot, params, q, times=times, slack=1e-4)
    assert slack[0] == 1e-4
    plain = dataclasses.replace(params, creep=None)
    for k in (0, 17, 49):
        shifted = dataclasses.replace(plain, offsets=params.offsets + slack[k])
        tip_k, tau_k = tip_positions(robot, shifted, q[k:k + 1])
        np.testing.assert_allclose(tip[k], tip_k[0], atol=1e-12)
        np.testing.assert_allclose(tau[k], tau_k[0], atol=1e-12)
    np.testing.assert_allclose(np.diff(slack), 5e-3 * tau[:-1].mean(axis=1) * np.diff(times), rtol=1e-10, atol=1e-18)


def test_no_creep_rate_is_the_plain_model():
    robot, params = _robot(2, creep=0.0)
    q = np.random.default_rng(2).uniform(-3e-3, 4e-3, (40, 6))
    tip, _ = tip_positions(robot, params, q, times=np.arange(40.0))
    np.testing.assert_allclose(tip, tip_positions(robot, dataclasses.replace(params, creep=None), q)[0], atol=1e-13)


def test_no_creep_across_the_gap_between_sessions():
    """Two sessions an hour apart: the second's first row sees the slack the first's last row saw (its
    load acts for no time), and the slack carries on from there."""
    robot, params = _robot(creep=4e-3)
    q = np.tile([3e-3, -5e-3, -5e-3], (20, 1))
    times = np.concatenate([np.arange(10.0), 3600.0 + np.arange(10.0)])
    slack = solve_rows(robot, params, q, session_resets([10, 10]), times)[4]
    assert slack[10] == slack[9] > 0.0
    assert slack[11] > slack[10]


def test_synthetic_sessions_run_on_the_robot_as_the_training_left_it():
    """The physics' synthetic sessions start a recorded interval after the last row of its calibration
    (``synthetic._after_calibration``): the timeline gives them the slack the training left, not that of
    its first row, which a session timed from zero, before the training's Unix times, would get."""
    line = CreepTimeline(times=1.7e9 + np.arange(50.0), q=np.zeros((50, 1)), slack=np.linspace(0.0, 1e-3, 50),
                         end=1.1e-3)
    stats = SimpleNamespace(intervals=np.array([0.5, 0.7]))
    start = _after_calibration(SimpleNamespace(calibration=SimpleNamespace(timeline=line)), stats)
    assert start == pytest.approx(1.7e9 + 49.6)
    assert line.at(start + np.arange(3.0), np.ones((3, 1))) == 1.1e-3
    assert line.at(np.arange(3.0), np.ones((3, 1))) == 0.0
    assert _after_calibration(SimpleNamespace(calibration=SimpleNamespace(timeline=None)), stats) == 0.0


def test_the_timeline_gives_a_session_the_slack_it_had():
    q = np.array([[0.0], [1.0], [2.0], [3.0]])
    line = CreepTimeline(times=np.array([10.0, 11.0, 12.0, 20.0]), q=q, slack=np.array([0.0, 1.0, 2.0, 3.0]), end=3.5)
    assert line.at([11.0, 12.0], [[1.0], [2.0]]) == 1.0     # rows of the timeline
    assert line.at([15.0], [[9.0]]) == 3.0                   # in a gap: the slack the next known row saw
    assert line.at([13.0, 19.5], [[9.0], [9.0]]) == 3.0
    assert line.at([11.5, 12.5], [[9.0], [9.0]]) == 3.5      # a row of the calibration within: a clock of its own
    one = CreepTimeline(times=np.arange(100.0), q=np.zeros((100, 1)), slack=np.linspace(0.0, 5.0, 100), end=5.5)
    assert one.at(np.arange(30.0), np.ones((30, 1))) == 5.5  # a session timed from zero, as the training was
    assert line.at([25.0], [[1.0]]) == 3.5                   # after: as the training left it
    assert line.at([0.0, 9.0], [[0.0], [0.0]]) == 0.0         # before: as at the first row (creep only grows)
    relative = CreepTimeline(times=np.array([0.0, 1.0, 0.0, 1.0]), q=np.array([[0.0], [1.0], [0.0], [3.0]]),
                             slack=np.array([0.0, 1.0, 2.0, 3.0]), end=4.0)
    assert relative.at([0.0, 1.0], [[0.0], [3.0]]) == 2.0     # sessions on clocks of their own: the rows that match
    assert relative.at([0.0, 1.0], [[0.0], [1.0]]) == 0.0
    assert relative.at([0.5], [[0.0]]) == 4.0 and relative.at([0.0, 1.0], [[0.0], [7.0]]) == 4.0   # none: the end


def _recording(robot, params, q, times, path="a.csv"):
    tip = tip_positions(robot, params, q, times=times)[0]
    names = tuple(f"t{i}" for i in range(q.shape[1]))
    return Recording(path=path, time=times, inputs=q * 1e3, names=names, units=("mm",) * q.shape[1], tip=tip)


def _pulls(rows, seed):
    """Ramps of one tendon at a time from slack, as a lab records them: a common slack shows where each pull
    starts to bend the robot."""
    rng = np.random.default_rng(seed)
    q = np.full((rows, 3), -1e-3)
    for start in range(0, rows, 20):
        q[start:start + 20, rng.integers(3)] += np.linspace(0.0, rng.uniform(3e-3, 5e-3), 20)[:rows - start]
    return q, np.cumsum(rng.uniform(0.5, 2.0, rows))


def test_calibration_recovers_a_known_creep_rate_with_held_rows_run_but_not_fitted():
    """Noise-free poses of a creeping robot with a quarter of the rows' tips hidden (NaN): the fit from a
    plain start recovers the creep rate, and a held stretch predicted on its own starts from the slack
    the timeline kept for it, where the robot was."""
    robot, truth = _robot(creep=3e-3, offsets=np.array([-0.5e-3, -0.4e-3, -0.6e-3]))
    q, times = _pulls(240, 1)
    rec = _recording(robot, truth, q, times)
    held = [rec.rows(120, 180)]
    physics = Physics(robot, CalibrationOptions(creep=True, variant_evaluations=200),
                      start=dataclasses.replace(truth, creep=None, offsets=truth.offsets + 0.2e-3)).fit(
        masked([rec], held))
    cal = physics.calibration
    assert cal.params.creep == pytest.approx(3e-3, rel=0.02)
    assert cal.timeline.end > 0.0 and np.all(np.diff(cal.timeline.slack) >= 0.0)
    np.testing.assert_allclose(physics.predict(held[0]), held[0].tip, atol=0.05e-3)
    no_creep = Physics(robot, CalibrationOptions(), start=truth).fit(masked([rec], held))
    assert np.abs(no_creep.predict(held[0]) - held[0].tip).max() > 10 * np.abs(
        physics.predict(held[0]) - held[0].tip).max()


def test_sessions_on_clocks_of_their_own_start_where_they_were():
    """Two sessions whose clocks both start at 0 (the same times, other commands): the creep carries from
    the first into the second, and a held stretch of the second, predicted on its own, starts from the
    slack the second session had there, told apart from the first by its commands."""
    robot, truth = _robot(creep=3e-3, offsets=np.array([-0.5e-3, -0.4e-3, -0.6e-3]))
    qa, times = _pulls(80, 5)
    qb = _pulls(80, 6)[0]
    tips = tip_positions(robot, truth, np.vstack([qa, qb]), session_resets([80, 80]), np.concatenate([times, times]))[0]
    names = ("t0", "t1", "t2")
    a, b = (Recording(path=p, time=times, inputs=q * 1e3, names=names, units=("mm",) * 3, tip=t)
            for p, q, t in (("a.csv", qa, tips[:80]), ("b.csv", qb, tips[80:])))
    held = b.rows(40, 60)
    physics = Physics(robot, CalibrationOptions(creep=True), start=truth).fit(masked([a, b], [held]))
    np.testing.assert_allclose(physics.predict(held), held.tip, atol=1e-9)
    line, other = physics.calibration.timeline, a.rows(40, 60)
    assert line.at(held.time, displacements(held)) > line.at(other.time, displacements(other)) > 0.0


def test_masked_hides_the_held_rows_tips_only():
    robot, truth = _robot()
    q, times = _pulls(30, 2)
    rec = _recording(robot, truth, q, times)
    other = dataclasses.replace(rec, path="b.csv")
    out = masked([rec, other], [rec.rows(5, 9)])
    hidden = np.isnan(out[0].tip).all(axis=1)
    assert hidden.tolist() == [5 <= k < 9 for k in range(30)]
    np.testing.assert_array_equal(out[0].tip[~hidden], rec.tip[~hidden])
    np.testing.assert_array_equal(out[1].tip, other.tip)          # another session, though its times match
    unnamed = [dataclasses.replace(rec, path=""), dataclasses.replace(rec, path="", inputs=rec.inputs + 1.0)]
    out = masked(unnamed, [unnamed[1].rows(5, 9)])               # sessions built in memory: told by their inputs
    assert not np.isnan(out[0].tip).any() and np.isnan(out[1].tip).all(axis=1).sum() == 4


def test_the_parameters_round_trip_with_the_creep_rate():
    robot, params = _robot(creep=1.25e-3)
    back = TendonParameters.from_dict(params.to_dict(robot))
    assert back.creep == pytest.approx(1.25e-3)
    assert TendonParameters.from_dict(dataclasses.replace(params, creep=None).to_dict(robot)).creep is None


def test_creep_without_the_rows_times_is_refused():
    robot, params = _robot(creep=1e-3)
    q = np.zeros((5, 3))
    with pytest.raises(SoftrnnInputError, match="times=None is invalid: the rows' times"):
        tip_positions(robot, params, q)
    with pytest.raises(SoftrnnInputError, match="times=None is invalid: the 5 rows' times"):
        calibrate(robot, q, np.zeros((5, 3)), CalibrationOptions(creep=True), start=params)
    with pytest.raises(SoftrnnInputError, match="tip='no finite row' is invalid"):
        calibrate(robot, q, np.full((5, 3), np.nan), CalibrationOptions(), start=params)


def test_a_rigid_segment_refits_from_where_it_is():
    """A calibration that left a segment rigid (its compliance underflowed to 0, a segment its rows do not
    bend) is a finite start for a refit: the least squares would stop at a NaN step otherwise."""
    from softrnn.lab.tendon_robot import pack

    robot, params = _robot(2)
    x = pack(dataclasses.replace(params, compliance=np.array([0.0, 1.0 / (R ** 2 * L)])))
    assert np.all(np.isfinite(x))
    q, times = _pulls(40, 3)
    rigid = dataclasses.replace(params, compliance=np.array([0.0, 1.0 / (R ** 2 * L)]))
    tip = tip_positions(robot, rigid, np.hstack([q, q]))[0]
    cal = calibrate(robot, np.hstack([q, q]), tip, CalibrationOptions(), start=rigid)
    assert cal.rmse_m < 1e-9



def test_the_turn_with_creep_is_the_creeping_tip_turned_about_the_base_axis():
    """With a turn chi, each row's tip is the creeping model's tip turned about the base's axis (through
    the base) by chi x the slack that row saw: the distance from the axis and the height along it stay,
    the angle about it grows by chi s; chi = 0 is the creeping model."""
    rng = np.random.default_rng(7)
    robot, params = _robot(2, creep=5e-3, offsets=rng.uniform(-1e-3, 0.5e-3, 6))
    q = rng.uniform(-2e-3, 4e-3, (40, 6))
    times = np.cumsum(rng.uniform(0.2, 3.0, 40))
    tip, _, _, _, slack = solve_rows(robot, params, q, times=times, slack=2e-4)
    chi = 0.5 / 1e-3                                             # half a radian per mm of slack
    turned = solve_rows(robot, dataclasses.replace(params, twist=chi), q, times=times, slack=2e-4)[0]
    Rb = Rotation.from_rotvec(params.rotation).as_matrix()
    a, b = (tip - params.base) @ Rb, (turned - params.base) @ Rb   # in the base frame
    np.testing.assert_allclose(np.hypot(b[:, 0], b[:, 1]), np.hypot(a[:, 0], a[:, 1]), rtol=1e-12)
    np.testing.assert_allclose(b[:, 2], a[:, 2], atol=1e-15)
    angle = np.angle(np.exp(1j * (np.arctan2(b[:, 1], b[:, 0]) - np.arctan2(a[:, 1], a[:, 0]))))
    np.testing.assert_allclose(angle, chi * slack, atol=1e-9)
    assert angle.max() > 0.1
    still = solve_rows(robot, dataclasses.replace(params, twist=0.0), q, times=times, slack=2e-4)[0]
    np.testing.assert_allclose(still, tip, atol=1e-15)


def test_calibration_recovers_a_known_turn_with_creep():
    """Noise-free poses of a robot that turns as it creeps: the fit from a start without the turn recovers
    it and the creep rate; the parameters round-trip with it."""
    robot, truth = _robot(creep=3e-3, offsets=np.array([-0.5e-3, -0.4e-3, -0.6e-3]))
    truth = dataclasses.replace(truth, twist=0.2 / 1e-3)
    q, times = _pulls(240, 1)
    rec = _recording(robot, truth, q, times)
    physics = Physics(robot, CalibrationOptions(creep=True, twist=True, variant_evaluations=300),
                      start=dataclasses.replace(truth, twist=None)).fit([rec])
    assert physics.calibration.params.twist == pytest.approx(0.2 / 1e-3, rel=0.02)
    assert physics.calibration.params.creep == pytest.approx(3e-3, rel=0.02)
    assert physics.calibration.rmse_m < 1e-6
    assert "turn with its creep" in physics.calibration.to_dict()["model"]
    back = TendonParameters.from_dict(truth.to_dict(robot))
    assert back.twist == pytest.approx(truth.twist)


def test_a_turn_without_creep_is_refused():
    with pytest.raises(SoftrnnInputError, match="twist=True is invalid: twist=True with creep=True"):
        CalibrationOptions(twist=True)
    assert CalibrationOptions(creep=True, twist=True).variant == "creep+twist"
