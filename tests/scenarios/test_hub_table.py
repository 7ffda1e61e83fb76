"""The [hub] table of scenario files: a prescribed hub (insertion and rotation profiles) and a driven
one (force, torque, mass, inertia) build the ``softrnn.rod.hub.Hub`` the Python API builds; a run
stores the hub's channels in its data set and ``read_dataset`` gives them back; the shipped
vessel-guidewire-twist inserts and turns its wire inside the vessel; bad tables are one-line errors
naming the file and the key."""

import math

import numpy as np
import pytest

from softrnn.io import read_dataset
from softrnn.rod import RunConfig, Simulator
from softrnn.rod.contact import closest_segments
from softrnn.rod.hub import Hub
from softrnn.scenarios.scenario import ScenarioError, load_scenario, parse_scenario

from helpers import run_cli

HEAD = """
format = 1
name = "hub-test"
gravity = [0.0, 0.0, 0.0]
[rod]
length = 0.2
radius = 0.001
n_nodes = 11
youngs_modulus = 1e7
density = 1000.0
[reference]
kind = "straight"
origin = [0.0, 0.0, 0.0]
direction = [1.0, 0.0, 0.0]
normal = [0.0, 0.0, 1.0]
[damping]
translational = 0.05
[run]
dt = 0.005
n_samples = 21
nodes_of_interest = [-1]
"""

PRESCRIBED = """
[hub]
insertion = { kind = "sampled", times = [0.0, 0.1], values = [0.0, 0.01] }
rotation = { kind = "sinusoid", amplitude = 0.5, frequency = 5.0 }
"""

DRIVEN = """
[hub]
force = 0.01
mass = 0.002
torque = { kind = "constant", value = 2e-7, schedule = { start = 0.02 } }
inertia = 1e-9
"""


def test_a_prescribed_hub_table_builds_the_hub_and_its_data_set_stores_it(tmp_path, capsys):
    sc = parse_scenario(HEAD + PRESCRIBED)
    hub = sc.setup.boundary[0].motion
    assert isinstance(hub, Hub) and not hub.driven and sc.setup.boundary[0].node == 0
    assert np.array_equal(hub.axis, [1.0, 0.0, 0.0]) and hub.entry == (0.0, 0.0, 0.0)
    assert sc.record.moving_clamps == (0,)                      # a prescribed hub's node is a path
    path = tmp_path / "hub.toml"
    path.write_text(HEAD + PRESCRIBED, encoding="utf-8")
    assert run_cli(["simulate", str(path), "-o", str(tmp_path / "run.h5"), "--quiet"]) == 0
    data = read_dataset(tmp_path / "run.h5")
    assert data.actuation_units == {"hub_insertion": "m", "hub_rotation": "rad"}
    d = np.interp(data.time, [0.0, 0.1], [0.0, 0.01])
    theta = 0.5 * np.sin(2 * math.pi * 5.0 * data.time)
    np.testing.assert_allclose(data.hub["hub_insertion"], d, rtol=1e-6, atol=1e-9)
    np.testing.assert_allclose(data.hub["hub_rotation"], theta, rtol=1e-6, atol=1e-7)
    np.testing.assert_allclose(data.positions[:, 0, 0], d, atol=1e-8)
    assert data.record.moving_clamps == (0,)


def test_a_driven_hub_table_stores_its_force_torque_and_measured_pose(tmp_path):
    sc = parse_scenario(HEAD + DRIVEN)
    hub = sc.setup.boundary[0].motion
    assert hub.pushed and hub.twisted and (hub.mass, hub.inertia) == (0.002, 1e-9)
    assert sc.record.moving_clamps == ()                        # its node is the rod's state
    path = tmp_path / "driven.toml"
    path.write_text(HEAD + DRIVEN.replace("[hub]", "[hub]\nnode = 0") + "", encoding="utf-8")
    assert run_cli(["simulate", str(path), "-o", str(tmp_path / "run.h5"), "--quiet"]) == 0
    data = read_dataset(tmp_path / "run.h5")
    assert tuple(data.hub) == ("hub_insertion", "hub_rotation", "hub_force", "hub_torque")
    np.testing.assert_allclose(data.hub["hub_force"], 0.01)
    np.testing.assert_allclose(data.hub["hub_torque"], np.where(data.time >= 0.02, 2e-7, 0.0))
    np.testing.assert_allclose(data.hub["hub_insertion"], data.positions[:, 0, 0], rtol=1e-6, atol=1e-9)
    assert data.hub["hub_insertion"][-1] > 0.001 and data.hub["hub_rotation"][-1] > 0.01
    assert data.hub["hub_rotation"][0] == 0.0


def test_the_shipped_twisting_guidewire_is_inserted_and_turned_inside_its_vessel():
    """The first 0.4 s of vessel-guidewire-twist: node 0 sits on the hub's path (0.2 m smoothstep
    over 2 s, one turn over 2 s at a steady rate), the tip turns with it, the wire stays in the
    vessel to 1 % of its radius."""
    sc = load_scenario("vessel-guidewire-twist")
    hub = sc.setup.boundary[0].motion
    assert isinstance(hub, Hub) and sc.randomized and sc.config.integrator.name == "implicit"
    traj = Simulator(sc.setup).run(RunConfig(dt=sc.config.dt, n_samples=81, integrator=sc.config.integrator))
    s = traj.time / 2.0
    d = 0.2 * s ** 3 * (s * (6 * s - 15) + 10)
    np.testing.assert_allclose(traj.positions[:, 0], np.asarray(hub.entry) + d[:, None] * hub.axis, atol=1e-12)
    np.testing.assert_allclose(hub.twist_angle(traj.rotations()[:, 0]), math.pi * traj.time, atol=1e-8)
    tip = hub.twist_angle(traj.rotations()[:, -1])
    assert abs(tip[-1] - math.pi * traj.time[-1]) < 0.2               # the tip turns too (0.4 pi rad)
    vessel = sc.setup.contact.obstacles[0]
    r, big = sc.setup.rod.radius, float(vessel.radii.min())
    for p in traj.positions:
        assert closest_segments(vessel.points, p)[1].max() < big - r + 0.01 * r


@pytest.mark.parametrize("table, key, words", [
    ("[hub]\ninsertion = 0.1\nforce = 1.0", "hub.force", "give insertion or force, not both"),
    ("[hub]\ninsertion = 0.1\nmass = 1.0", "hub.mass", "only a hub driven by a force"),
    ("[hub]\ninsertoin = 0.1", "hub.insertoin", "did you mean 'insertion'"),
    ("[hub]\naxis = [0.0, 0.0, 0.0]", "hub.axis", "nonzero 3-vector"),
    ("[hub]\nrotation = { kind = \"sampled\", times = [0.0, 1.0, 0.5], values = [0.0, 1.0, 2.0] }",
     "hub.rotation.times", "strictly increasing"),
    ("[hub]\nrotation = { kind = \"sampled\", times = [0.0, 1.0], values = [0.0, nan] }", "hub.rotation.values",
     "a list of at least 1 number in rad"),
    ("[hub]\ninsertion = inf", "hub.insertion", "a number in m"),
    ("[hub]\nnode = 0\n[[boundary]]\nkind = \"clamp\"\nnode = 0", "hub.node", "not already constrained by boundary.0"),
    ("[hub]\nforce = 1.0\n", "run.integrator", "'explicit' with a hub driven"),
    ("[hub]\naxis = [0.0, 1.0, 0.0]\ntorque = 1e-6", "hub", "a frame whose d3 is the axis"),
])
def test_bad_hub_tables_are_one_line_errors_naming_the_file_and_key(table, key, words):
    text = HEAD + table
    if key == "run.integrator":
        text = text.replace("nodes_of_interest", "integrator = \"implicit\"\nnodes_of_interest")
    with pytest.raises(ScenarioError) as err:
        parse_scenario(text, "hub.toml")
    msg = str(err.value)
    assert "\n" not in msg and msg.startswith("hub.toml: ") and err.value.key == key and words in msg, msg


def test_a_magnetic_scenario_refuses_a_hub_table():
    text = load_scenario("magnetic-bifurcation").text + "\n[hub]\ninsertion = 0.01\n"
    with pytest.raises(ScenarioError, match="hub: not allowed in a magnetic scenario"):
        parse_scenario(text, "m.toml")


def test_a_sweep_stores_each_variants_hub(tmp_path):
    """A sweep over the hub's rotation amplitude: every variant's data set holds its own turn."""
    text = HEAD + PRESCRIBED + '[randomize]\n"hub.rotation.amplitude" = { uniform = [0.1, 1.0] }\n'
    (tmp_path / "hub.toml").write_text(text, encoding="utf-8")
    out = tmp_path / "sweep"
    assert run_cli(["sweep", str(tmp_path / "hub.toml"), "--count", "2", "-o", str(out), "--samples", "11",
                    "--workers", "1", "--quiet"]) == 0
    for i in range(2):
        data = read_dataset(out / f"traj-{i:05d}.h5")
        amplitude = parse_scenario(text).variant(i).sampled["hub.rotation.amplitude"]
        np.testing.assert_allclose(data.hub["hub_rotation"], amplitude * np.sin(2 * math.pi * 5.0 * data.time),
                                   rtol=1e-6, atol=1e-7)
        assert data.record.moving_clamps == (0,)
