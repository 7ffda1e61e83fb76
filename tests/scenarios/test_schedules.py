"""Scenario schedules: every profile table (loads, boundary motions, tendon tensions and
displacements, gravity) takes a ``schedule = {start, ramp, release, shape}`` sub-table read into
``softrnn.rod.loads.Scheduled``; gravity may be a profile table; bad schedules give one-line errors
naming the key."""

import numpy as np
import pytest

from softrnn.errors import SoftrnnInputError
from softrnn.rod import RunConfig, simulate
from softrnn.rod.loads import Constant, Scheduled, Sinusoid
from softrnn.rod.tendons import Scalar
from softrnn.scenarios.scenario import load_scenario, parse_scenario

BASE = """
name = "scheduled"
gravity = [0.0, 0.0, -9.81]
[rod]
length = 0.3
radius = 0.005
youngs_modulus = 1e6
density = 1000.0
n_nodes = 11
[reference]
kind = "straight"
direction = [1.0, 0.0, 0.0]
normal = [0.0, 0.0, 1.0]
[[boundary]]
kind = "clamp"
node = 0
[[loads]]
kind = "force"
node = -1
profile = { kind = "constant", value = [0.0, 0.0, 0.01], schedule = { start = 0.1, ramp = 0.2, release = 0.5 } }
[[tendons]]
name = "left"
offset = [0.004, 0.0]
tension = { kind = "constant", value = 2.0, schedule = { ramp = 0.4, shape = "linear", release = 1.0 } }
[[tendons]]
name = "servo"
offset = [-0.004, 0.0]
stiffness = 500.0
displacement = { kind = "sinusoid", amplitude = 0.001, frequency = 1.0, schedule = { start = 0.2 } }
[run]
dt = 1e-3
duration = 0.02
nodes_of_interest = [-1]
"""
GRAVITY_TABLE = """[gravity]
kind = "constant"
value = [0.0, 0.0, -9.81]
schedule = { ramp = 0.5 }
"""


def _parse(text):
    return parse_scenario(text, "<test>")


def test_schedules_on_loads_and_tendons_read_into_scheduled():
    setup = _parse(BASE).setup
    force = setup.loads[0].force
    assert force == Scheduled(Constant((0.0, 0.0, 0.01)), start=0.1, ramp=0.2, release=0.5)
    t = np.array([0.0, 0.2, 0.3, 0.49, 0.5])
    np.testing.assert_allclose(force(t)[:, 2], [0.0, 0.005, 0.01, 0.01, 0.0])
    left, servo = setup.tendons
    assert isinstance(left.tension, Scheduled) and isinstance(left.tension.function, Scalar)
    np.testing.assert_allclose(left.tensions(np.array([0.0, 0.1, 0.4, 0.99, 1.0])), [0.0, 0.5, 2.0, 2.0, 0.0])
    assert servo.displacement.start == 0.2 and servo.displacement.release is None
    np.testing.assert_allclose(servo.displacements(np.array([0.1, 0.25])),
                               [0.0, 0.001 * np.sin(2 * np.pi * 0.25)])
    assert setup.gravity == (0.0, 0.0, -9.81)  # a vector stays a constant


def test_a_schedule_on_a_boundary_motion_and_inside_a_sum():
    text = BASE.replace('node = 0\n', 'node = 0\ndisplacement = { kind = "constant", value = [0.0, 0.01, 0.0], '
                                      'schedule = { ramp = 0.1, shape = "linear" } }\n', 1)
    text = text.replace('profile = { kind = "constant", value = [0.0, 0.0, 0.01], schedule = { start = 0.1, '
                        'ramp = 0.2, release = 0.5 } }',
                        'profile = { kind = "sum", terms = [{ kind = "constant", value = [0.0, 0.0, 0.01], '
                        'schedule = { release = 0.3 } }, { kind = "constant", value = [0.0, 0.0, 0.02] }] }')
    setup = _parse(text).setup
    pos, _ = setup.boundary[0].motion(np.array([0.0, 0.05, 0.2]))
    np.testing.assert_allclose(pos[:, 1], [0.0, 0.005, 0.01], atol=1e-15)
    np.testing.assert_allclose(setup.loads[0].force(np.array([0.1, 0.3]))[:, 2], [0.03, 0.02])


def test_gravity_as_a_profile_table_simulates_as_the_vector():
    ramped = _parse(BASE.replace('gravity = [0.0, 0.0, -9.81]\n', GRAVITY_TABLE, 1))
    assert ramped.setup.gravity == Scheduled(Constant((0.0, 0.0, -9.81)), ramp=0.5)
    steady = BASE.replace('gravity = [0.0, 0.0, -9.81]\n', '[gravity]\nkind = "constant"\nvalue = [0.0, 0.0, -9.81]\n')
    vector, table = _parse(BASE), _parse(steady)
    assert table.setup.gravity == Constant((0.0, 0.0, -9.81))
    config = RunConfig(dt=1e-3, n_samples=21)
    a, b = simulate(vector.setup, config), simulate(table.setup, config)
    np.testing.assert_allclose(b.positions, a.positions, rtol=0, atol=1e-13)
    shaking = BASE.replace('gravity = [0.0, 0.0, -9.81]\n',
                           'gravity = { kind = "sinusoid", amplitude = [0.0, 0.5, 0.0], frequency = 2.0, '
                           'offset = [0.0, 0.0, -9.81] }\n')
    assert _parse(shaking).setup.gravity == Sinusoid((0.0, 0.5, 0.0), 2.0, offset=(0.0, 0.0, -9.81))


def test_a_sweep_varies_a_release_time(tmp_path):
    text = BASE + '[randomize]\n"loads.0.profile.schedule.release" = { uniform = [0.4, 0.8] }\n'
    path = tmp_path / "release.toml"
    path.write_text(text)
    v = load_scenario(path).variant(3)
    assert 0.4 <= v.setup.loads[0].force.release < 0.8
    assert v.setup.loads[0].force.release == v.sampled["loads.0.profile.schedule.release"]


def _error(text) -> str:
    with pytest.raises(SoftrnnInputError) as info:
        _parse(text)
    message = str(info.value)
    assert len(message.splitlines()) == 1 and message.startswith("<test>: "), message
    return message


@pytest.mark.parametrize("old, new, words", [
    ("ramp = 0.2, release = 0.5", "ramp = -0.2, release = 0.5",
     ["loads.0.profile.schedule.ramp = -0.2 is invalid", "a number >= 0 in s"]),
    ("start = 0.1, ramp = 0.2, release = 0.5", "start = 0.6, ramp = 0.2, release = 0.5",
     ["loads.0.profile.schedule.release = 0.5 is invalid", "after loads.0.profile.schedule.start = 0.6 s"]),
    ("start = 0.1, ramp = 0.2, release = 0.5", "start = 0.5, release = 0.5",
     ["loads.0.profile.schedule.release = 0.5 is invalid"]),
    ('shape = "linear"', 'shape = "cubic"', ["tendons.0.tension.schedule.shape = 'cubic'", "'smooth', 'linear'"]),
    ("schedule = { ramp = 0.4,", "schedule = { rampp = 0.4,",
     ["unknown key 'tendons.0.tension.schedule.rampp'", "did you mean 'ramp'"]),
    ("schedule = { start = 0.2 }", "schedule = 0.2", ["tendons.1.displacement.schedule = 0.2 is invalid", "a table"]),
    ("value = 2.0, schedule", "value = 2.0, ramp = 0.1, schedule",
     ["tendons.0.tension: give ramp or schedule, not both", "tendons.0.tension.schedule = {ramp = ...}"]),
    ("gravity = [0.0, 0.0, -9.81]", 'gravity = "down"', ["gravity = 'down' is invalid", "a profile table"]),
    ("gravity = [0.0, 0.0, -9.81]", "gravity = [0.0, -9.81]", ["gravity = [0.0, -9.81] is invalid", "3-vector"]),
    ("gravity = [0.0, 0.0, -9.81]", 'gravity = { kind = "constant", value = [0.0, 0.0, -9.81], '
                                    'schedule = { release = -1.0 } }',
     ["gravity.schedule.release = -1.0 is invalid", "after gravity.schedule.start = 0 s"]),
])
def test_bad_schedules_give_one_line_errors_naming_the_key(old, new, words):
    assert old in BASE
    message = _error(BASE.replace(old, new, 1))
    for w in words:
        assert w in message, message
