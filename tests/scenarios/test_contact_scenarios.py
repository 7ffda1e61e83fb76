"""The [contact] table of scenario files: it builds the Contact the Python API builds (inline and
CSV centrelines), bad keys and values are one-line errors naming the file and the key, it is
summarised and randomisable; the shipped contact-plane rod stays on the table and sticks before it
slips, the vessel-guidewire stays inside its vessel while its tip goes round the first bend."""

from dataclasses import fields, replace

import numpy as np
import pytest

from softrnn.rod import Contact, Cylinder, Plane, RunConfig, Simulator, Sphere, Vessel
from softrnn.rod.contact import closest_segments
from softrnn.scenarios.scenario import ScenarioError, load_scenario, parse_scenario

from helpers import run_cli

PENETRATION_TOL = 0.01  # of the rod radius: the deepest node at any saved sample

HEAD = """
format = 1
name = "contact-test"
gravity = [0.0, 0.0, -9.81]
[rod]
length = 0.2
radius = 0.005
n_nodes = 11
youngs_modulus = 1e6
density = 1000.0
[reference]
kind = "straight"
origin = [0.0, 0.0, 0.1]
direction = [1.0, 0.0, 0.0]
normal = [0.0, 0.0, 1.0]
[run]
dt = 0.001
n_samples = 3
nodes_of_interest = [-1]
"""

CONTACT = """
[contact]
friction = 0.3
slip_velocity = 2e-4
stiffness = 5e4
damping = 3.0
reference_acceleration = 20.0
[[contact.obstacles]]
kind = "plane"
point = [0.0, 0.0, 0.0]
normal = [0.0, 0.0, 2.0]
friction = 0.6
[[contact.obstacles]]
kind = "sphere"
center = [0.1, 0.0, 0.3]
radius = 0.05
[[contact.obstacles]]
kind = "cylinder"
point = [0.0, 0.5, 0.0]
axis = [0.0, 0.0, 1.0]
radius = 0.02
[[contact.obstacles]]
kind = "vessel"
centreline = [[1.0, 0.0, 0.1], [1.2, 0.0, 0.1], [1.3, 0.05, 0.1], [1.4, 0.1, 0.1]]
radius = [0.02, 0.02, 0.025, 0.03]
friction = 0.0
"""
CENTRELINE = np.array([[1.0, 0.0, 0.1], [1.2, 0.0, 0.1], [1.3, 0.05, 0.1], [1.4, 0.1, 0.1]])  # beyond the rod


def _expected() -> Contact:
    return Contact(obstacles=(Plane((0.0, 0.0, 0.0), (0.0, 0.0, 2.0), friction=0.6),
                              Sphere((0.1, 0.0, 0.3), 0.05), Cylinder((0.0, 0.5, 0.0), (0.0, 0.0, 1.0), 0.02),
                              Vessel(CENTRELINE, np.array([0.02, 0.02, 0.025, 0.03]), friction=0.0)),
                   friction=0.3, slip_velocity=2e-4, stiffness=5e4, damping=3.0, reference_acceleration=20.0)


def _assert_same(a, b):
    """Two contacts (or obstacles) with equal fields, arrays compared exactly."""
    assert type(a) is type(b)
    for f in fields(a):
        x, y = getattr(a, f.name), getattr(b, f.name)
        if isinstance(x, tuple) and x and not isinstance(x[0], (int, float)):
            assert len(x) == len(y)
            for u, v in zip(x, y):
                _assert_same(u, v)
        else:
            np.testing.assert_array_equal(np.asarray(x, dtype=float), np.asarray(y, dtype=float), err_msg=f.name)


def test_the_contact_table_builds_the_python_contact():
    sc = parse_scenario(HEAD + CONTACT)
    _assert_same(sc.setup.contact, _expected())
    np.testing.assert_array_equal(sc.setup.contact.obstacles[3].points, _expected().obstacles[3].points)
    assert parse_scenario(HEAD).setup.contact is None
    defaults = parse_scenario(HEAD + '[contact]\n[[contact.obstacles]]\nkind = "plane"\npoint = [0, 0, 0]\n'
                                     'normal = [0, 0, 1]\n').setup.contact
    _assert_same(defaults, Contact(obstacles=(Plane((0.0, 0.0, 0.0), (0.0, 0.0, 1.0)),)))
    with pytest.raises(ScenarioError, match="missing key 'contact.obstacles'") as info:
        parse_scenario(HEAD + "[contact]\nfriction = 0.3\n")
    assert info.value.key == "contact.obstacles"


def test_a_vessel_centreline_from_a_csv_file(tmp_path):
    rows = "\n".join(",".join(f"{v:g}" for v in p) for p in CENTRELINE)
    (tmp_path / "centreline.csv").write_text("x,y,z\n" + rows + "\n")
    text = HEAD + CONTACT.replace(
        "centreline = [[1.0, 0.0, 0.1], [1.2, 0.0, 0.1], [1.3, 0.05, 0.1], [1.4, 0.1, 0.1]]",
        'file = "centreline.csv"')
    path = tmp_path / "s.toml"
    path.write_text(text)
    _assert_same(load_scenario(path).setup.contact, _expected())


_BAD = {
    "unknown kind": (("kind = \"sphere\"", "kind = \"ball\""), "contact.obstacles.1.kind", "'plane', 'sphere'"),
    "missing radius": (("radius = 0.05\n", ""), "contact.obstacles.1.radius", "missing key"),
    "one-point vessel": (("centreline = [[1.0, 0.0, 0.1], [1.2, 0.0, 0.1], [1.3, 0.05, 0.1], [1.4, 0.1, 0.1]]\n"
                          "radius = [0.02, 0.02, 0.025, 0.03]", "centreline = [[0.0, 0.0, 0.1]]\nradius = 0.02"),
                         "contact.obstacles.3.centreline", "at least 2 centreline points"),
    "negative friction": (("friction = 0.3", "friction = -0.3"), "contact.friction", "a number >= 0"),
    "negative obstacle friction": (("friction = 0.6", "friction = -1"), "contact.obstacles.0.friction", ">= 0"),
    "missing file": (("centreline = [[1.0, 0.0, 0.1], [1.2, 0.0, 0.1], [1.3, 0.05, 0.1], [1.4, 0.1, 0.1]]",
                      'file = "nowhere.csv"'), "contact.obstacles.3.file", "nowhere.csv"),
    "unknown contact key": (("slip_velocity = 2e-4", "slip_speed = 2e-4"), "contact.slip_speed", "slip_velocity"),
    "unknown obstacle key": (("center = [0.1, 0.0, 0.3]", "centre = [0.1, 0.0, 0.3]"), "contact.obstacles.1.centre",
                             "'center'"),
    "radii count": (("radius = [0.02, 0.02, 0.025, 0.03]", "radius = [0.02, 0.02]"), "contact.obstacles.3.radius",
                    "a list of 4 radii"),
    "zero normal": (("normal = [0.0, 0.0, 2.0]", "normal = [0.0, 0.0, 0.0]"), "contact.obstacles.0.normal",
                    "nonzero"),
    "penetration": (("damping = 3.0", "damping = 3.0\npenetration = 1.5"), "contact.penetration", "(0, 1)"),
    "misspelt obstacles": (("[[contact.obstacles]]\nkind = \"plane\"", "[[contact.nothing]]\nkind = \"plane\""),
                     "contact.nothing", "unknown key"),
    "rod inside a sphere": (("center = [0.1, 0.0, 0.3]", "center = [0.1, 0.0, 0.1]"), "contact",
                            "inside obstacle 1"),
}


@pytest.mark.parametrize("case", list(_BAD))
def test_bad_contact_tables_are_one_line_errors_naming_the_file_and_key(case, tmp_path):
    (old, new), key, fragment = _BAD[case]
    text = HEAD + CONTACT
    assert old in text
    path = tmp_path / "bad.toml"
    path.write_text(text.replace(old, new, 1))
    with pytest.raises(ScenarioError) as info:
        load_scenario(path)
    message = str(info.value)
    assert "\n" not in message and message.startswith(f"{path}: ")
    assert info.value.key == key, message
    assert key in message and fragment in message, message


def test_the_summary_lists_the_obstacles_and_friction_is_randomisable(capsys):
    assert run_cli(["scenario", "show", "vessel-guidewire", "--summary"]) == 0
    text = capsys.readouterr().out
    assert "contact: 1 obstacle; friction 0.1" in text and "0: vessel of 50 centreline points" in text
    assert run_cli(["scenario", "show", "contact-plane", "--summary"]) == 0
    assert "0: plane through [0, 0, 0] m, normal [0, 0, 1]" in capsys.readouterr().out
    for name in ("contact-plane", "vessel-guidewire"):
        v = load_scenario(name).variant(2)
        assert v.setup.contact.friction == v.sampled["contact.friction"] != load_scenario(name).setup.contact.friction


def test_the_plane_rod_stays_on_the_table_and_sticks_then_slips():
    """The first 2.5 s of 4: the clamp lifts 5 cm and drags 0.13 m sideways; no node sinks 1 % of r
    into the table, the lying part holds while the clamp moves the first 15 mm, then slides."""
    sc = load_scenario("contact-plane")
    r, n = sc.setup.rod.radius, sc.setup.rod.n_nodes
    traj = Simulator(sc.setup).run(replace(sc.config, n_samples=1251))
    gaps = np.array([sc.setup.contact.gaps(p, np.full(n, r))[:, 0] for p in traj.positions])
    assert gaps.min() > -PENETRATION_TOL * r
    assert np.sum(gaps[-1] < 0) >= n // 3  # a third of the rod lies on the table
    t = traj.time
    stick, end = np.searchsorted(t, 1.5), -1
    clamp_y, mid_y = traj.positions[:, 0, 1], traj.positions[:, n // 2, 1]
    assert clamp_y[stick] > 0.015 and abs(mid_y[stick]) < 0.003        # stuck while the clamp moved
    assert clamp_y[end] > 0.12 and mid_y[end] > 0.04                   # then slid after it
    assert np.abs(traj.contact_forces).max() > 0


def test_the_guidewire_stays_inside_the_vessel():
    """The first 1.2 s of 2.5 (the clamp pushes 0.13 m): every node's distance to the vessel's
    centreline stays below R - r + 1 % of r, no node leaves through an open end, and the tip goes
    round the first bend."""
    sc = load_scenario("vessel-guidewire")
    vessel = sc.setup.contact.obstacles[0]
    r, big = sc.setup.rod.radius, float(vessel.radii.min())
    config = RunConfig(dt=sc.config.dt, n_samples=241, integrator=sc.config.integrator)
    traj = Simulator(sc.setup).run(config)
    last = len(vessel.points) - 2
    for p in traj.positions:
        index, distance, t = closest_segments(vessel.points, p)
        assert distance.max() < big - r + PENETRATION_TOL * r
        assert not np.any((index == 0) & (t < 0)) and not np.any((index == last) & (t > 1))
    tip = traj.positions[-1, -1]
    assert tip[0] > 0.04 and tip[1] > 0.02  # past the first bend's turn toward +y
