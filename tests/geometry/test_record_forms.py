"""The shared geometry's record form: every obstacle and time function written as a JSON-ready
record and built back equal (the same gaps, the same values), one form for the kernels' packing, the
data files, the pictures and the learned models; the obstacles' blend width the kernels' own."""

import json

import numpy as np
import pytest

from softrnn.errors import SoftrnnInputError
from softrnn.geometry import Contact, Obstacle, function_from_record, function_record
from softrnn.geometry import obstacles as geometry_obstacles
from softrnn.geometry.contact import contact_from_record, contact_record
from softrnn.geometry.paths import (
    CirclePath,
    Constant,
    Figure8Path,
    RandomSmoothPath,
    Sampled,
    Scheduled,
    Sinusoid,
    SquarePath,
    Sum,
    Window,
)
from softrnn.rod import contact as rod_contact
from softrnn.rod import kernels
from softrnn.rod import loads as rod_loads

OBSTACLES = (
    geometry_obstacles.Plane((0.0, 0.0, -0.01), (0.0, 0.0, 2.0), friction=0.3),
    geometry_obstacles.Sphere((0.1, 0.0, 0.05), 0.03),
    geometry_obstacles.Cylinder((0.0, 0.2, 0.0), (0.0, 0.0, 1.0), 0.01, friction=0.8),
    geometry_obstacles.Vessel([[0, 0, 0], [0.1, 0.02, 0], [0.2, 0, 0]], 0.004),
    geometry_obstacles.Bifurcation([[-0.1, 0, 0], [0.0, 0, 0]], [[0.04, 0.03, 0], [0.08, 0.05, 0]],
                                   [[0.04, -0.03, 0], [0.08, -0.05, 0]], 0.004, left_radius=0.003),
)


@pytest.mark.parametrize("obstacle", OBSTACLES, ids=lambda o: o.kind)
def test_an_obstacle_is_built_back_from_its_record_with_the_same_gaps(obstacle):
    record = json.loads(json.dumps(obstacle.to_record()))
    back = Obstacle.from_record(record)
    assert type(back) is type(obstacle) and back.kind == obstacle.kind == record["kind"]
    assert back.friction == obstacle.friction
    x = np.random.default_rng(0).uniform(-0.2, 0.2, size=(50, 3))
    r = np.full(50, 0.001)
    for (g, n), (h, m) in [(obstacle.gap(x, r), back.gap(x, r))]:
        np.testing.assert_array_equal(g, h)
        np.testing.assert_array_equal(n, m)


def test_a_contact_record_holds_each_obstacles_record_with_the_friction_that_applies():
    contact = Contact(obstacles=OBSTACLES, friction=0.1)
    record = contact_record(contact)
    assert [o["kind"] for o in record["obstacles"]] == ["plane", "sphere", "cylinder", "vessel", "bifurcation"]
    assert [o["friction"] for o in record["obstacles"]] == [0.3, 0.1, 0.8, 0.1, 0.1]
    assert contact.to_record() == record and contact_record(Contact.from_record(record)) == record
    assert contact_record(contact_from_record(json.loads(json.dumps(record)))) == record


def test_a_malformed_record_is_one_line():
    for entry, words in (({"kind": "cone"}, "kind one of"), ({"kind": "sphere", "center": [0, 0, 0]}, "missing")):
        with pytest.raises(SoftrnnInputError) as info:
            Obstacle.from_record(entry)
        assert "\n" not in str(info.value) and words in str(info.value)
    with pytest.raises(SoftrnnInputError, match="kind one of"):
        function_from_record({"kind": "spiral"})
    with pytest.raises(SoftrnnInputError, match="time function"):
        function_record(lambda t: t)


FUNCTIONS = (
    Constant((1.0, 2.0, 3.0)),
    Sinusoid((0.1, 0.0, 0.2), 1.5, phase=0.3, offset=(0.0, 0.01, 0.0)),
    Sampled([0.0, 0.5, 2.0], [[0, 0, 0], [1, 2, 3], [0, 1, 0]], interpolation="hold"),
    Window(Constant((0.0, 0.0, 1.0)), 0.2, 1.1),
    Sum((Constant((0.0, 0.0, 0.5)), Sinusoid((0.0, 0.1, 0.0), 2.0))),
    Scheduled(SquarePath((0.2, 0.0, 0.0), 0.1, 4.0), start=0.5, ramp=0.3, release=2.5, shape="linear"),
    CirclePath((0.0, 0.1, 0.0), 0.05, 3.0, u=(1.0, 0.0, 0.0), ramp=0.0),
    Figure8Path((0.0, 0.0, 0.2), 0.1, 0.05, 5.0),
    RandomSmoothPath((0.3, 0.0, 0.0), 0.05, 2.0, 17, n_modes=4),
)


@pytest.mark.parametrize("function", FUNCTIONS, ids=lambda f: type(f).__name__)
def test_a_time_function_is_built_back_from_its_record_with_the_same_values(function):
    record = json.loads(json.dumps(function_record(function)))
    back = function_from_record(record)
    assert type(back) is type(function)
    t = np.linspace(0.0, 3.0, 61)
    np.testing.assert_array_equal(back(t), function(t))


def test_the_simulators_names_are_the_shared_ones():
    assert rod_loads.SquarePath is SquarePath and rod_loads.Scheduled is Scheduled
    assert rod_contact.Vessel is geometry_obstacles.Vessel and rod_contact.Contact is Contact
    # the kernels freeze their own blend width into the compiled code: the same as the NumPy gaps'
    assert kernels.UNION_BLEND == geometry_obstacles.UNION_BLEND
