"""The physics' synthetic sessions (``softrnn.lab.synthetic``) on a known tendon robot: the command
space the recordings span and combinations they never hold, the recorded steps and intervals, the
routing's limit, the physics' tips, determinism, and the options refused."""

import numpy as np
import pytest

from softrnn.errors import SoftrnnInputError
from softrnn.lab.families import Physics
from softrnn.lab.recording import read_recording
from softrnn.lab.synthetic import CommandStatistics, SyntheticOptions, pull_limits, synthetic_sessions
from softrnn.lab.tendon_robot import Calibration

from helpers import tendon_recording, tendon_robot_truth


@pytest.fixture(scope="module")
def recorded(tmp_path_factory):
    d = tmp_path_factory.mktemp("syn")
    tendon_recording(d / "train.csv", rows=150, seed=0, n_segments=2)
    robot, params = tendon_robot_truth(2)
    physics = Physics(robot, calibration=Calibration(robot, params, 0.0, (), 0.0))
    return read_recording(d / "train.csv"), physics


def test_amount_channels_and_the_physics_tips(recorded):
    train, physics = recorded
    sessions = synthetic_sessions(physics, [train], SyntheticOptions(amount=3.0))
    assert sum(s.n_rows for s in sessions) == 3 * train.n_rows
    for s in sessions:
        assert s.names == train.names and s.units == train.units and s.path.startswith("synthetic:")
        np.testing.assert_array_equal(s.tip, physics.predict(s))
        assert np.all(np.diff(s.time) > 0)
    assert synthetic_sessions(physics, [train], SyntheticOptions(amount=0.0)) == []


def test_commands_cover_the_pooled_range_with_unrecorded_combinations(recorded):
    train, physics = recorded
    u = np.vstack([s.inputs for s in synthetic_sessions(physics, [train], SyntheticOptions(amount=5.0))])
    low, high = train.inputs.min(), train.inputs.max()
    assert np.all(u >= low - 1e-12) and np.all(u <= high + 1e-12)
    # an input recorded over a third of the range reaches the pooled range (its own: shared_range=False)
    narrow = type(train)(**{**vars(train), "inputs": train.inputs * np.r_[0.3, np.ones(5)]})
    for shared, reach in ((True, 0.6 * high), (False, 0.3 * high + 1e-9)):
        v = np.vstack([s.inputs for s in synthetic_sessions(physics, [narrow], SyntheticOptions(shared_range=shared))])
        assert bool(v[:, 0].max() > reach) is shared and v[:, 0].max() <= max(0.3 * high, high * shared) + 1e-9
    # rows far from every recorded row: targets of several inputs at once never recorded
    d = np.min(np.linalg.norm(u[:, None, :] - train.inputs[None, :, :], axis=2), axis=1)
    assert np.mean(d > 0.2 * (high - low)) > 0.2
    moved = np.sum(np.abs(np.diff(u, axis=0)) > 1e-9, axis=1)
    assert np.any(moved >= 4)


def test_steps_and_intervals_follow_the_recordings(recorded):
    train, physics = recorded
    stats = CommandStatistics.of([train])
    sessions = synthetic_sessions(physics, [train], SyntheticOptions(amount=5.0))
    steps = np.concatenate([np.max(np.abs(np.diff(s.inputs, axis=0)), axis=1) for s in sessions])
    assert steps.max() <= stats.steps.max() + 1e-9
    intervals = np.concatenate([s.intervals for s in sessions])
    assert np.all(np.isin(intervals, train.intervals))          # drawn from the recorded intervals
    assert np.any(intervals > 10.0)                               # the recorded pause included


def test_pulls_stay_within_the_routing(recorded):
    train, physics = recorded
    far = SyntheticOptions(amount=10.0, limits=((-5.0, 50.0),))
    u = np.vstack([s.inputs for s in synthetic_sessions(physics, [train], far)])
    limit_mm = pull_limits(physics.robot) * 1e3
    assert np.all(u <= limit_mm + 1e-9)
    assert np.any(u[:, :3] > 0.8 * limit_mm[0]) and np.any(u[:, 3:] > 1.2 * limit_mm[0])    # each its own limit


def test_deterministic_for_a_seed_and_noise_at_the_residual_level(recorded):
    train, physics = recorded
    a, b = (synthetic_sessions(physics, [train], SyntheticOptions(amount=1.0, seed=3)) for _ in range(2))
    assert all(np.array_equal(x.inputs, y.inputs) and np.array_equal(x.tip, y.tip) for x, y in zip(a, b))
    c = synthetic_sessions(physics, [train], SyntheticOptions(amount=1.0, seed=4))
    assert not np.array_equal(a[0].inputs, c[0].inputs)
    noisy = synthetic_sessions(physics, [train], SyntheticOptions(amount=4.0, noise=1.0))
    residual = np.sqrt(np.mean((physics.predict(train) - train.tip) ** 2, axis=0))     # ~0.1 mm marker noise
    noise = np.sqrt(np.mean(np.vstack([s.tip - physics.predict(s) for s in noisy]) ** 2, axis=0))
    np.testing.assert_allclose(noise, residual, rtol=0.15)


@pytest.mark.parametrize("options, words", [
    (dict(amount=-1.0), "amount=-1.0 is invalid"),
    (dict(weight=float("nan")), "weight=nan is invalid"),
    (dict(seed=1.5), "seed=1.5 is invalid"),
    (dict(limits=((3.0, 1.0),)), "limits=((3.0, 1.0),) is invalid"),
    (dict(limits="wide"), "limits='wide' is invalid"),
])
def test_bad_options_are_refused(options, words):
    with pytest.raises(SoftrnnInputError, match=words.replace("(", r"\(").replace(")", r"\)")):
        SyntheticOptions(**options)


def test_a_calibration_computes_its_predictions_and_sessions_once(recorded):
    """``Physics.memo``: the same sessions give the same (copied) tips and the same synthetic sessions;
    another calibration (``dataclasses.replace``) starts with its own memo; other tips of the recorded
    sessions, or other options, are another entry."""
    from dataclasses import replace

    train, physics = recorded
    fresh = replace(physics)
    assert fresh.memo == {} and fresh.memo is not physics.memo
    tip = fresh.predict(train)
    tip[:] = 0.0                                              # a caller's change never reaches the memo
    np.testing.assert_array_equal(fresh.predict(train), physics.calibration.predict(train.inputs * 1e-3))
    first = synthetic_sessions(fresh, [train], SyntheticOptions(amount=1.0))
    again = synthetic_sessions(fresh, [train], SyntheticOptions(amount=1.0))
    assert [s is t for s, t in zip(first, again)] == [True] * len(first)
    assert synthetic_sessions(fresh, [train], SyntheticOptions(amount=1.0, seed=1))[0] is not first[0]
    moved = replace(train, tip=train.tip + 1e-3)
    assert synthetic_sessions(fresh, [moved], SyntheticOptions(amount=1.0))[0] is not first[0]
    assert train.commands_key() == moved.commands_key() != replace(train, inputs=train.inputs + 1.0).commands_key()
