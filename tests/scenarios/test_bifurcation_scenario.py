"""A bifurcation in a scenario's [contact] table: kind = "bifurcation" builds the Bifurcation the
Python API builds, bad keys and values are one-line errors naming the file, the key and the fix,
and ``softrnn scenario show`` describes it."""

import numpy as np
import pytest

from softrnn.rod import Bifurcation
from softrnn.scenarios.scenario import ScenarioError, load_scenario, parse_scenario

from helpers import run_cli

HEAD = """
format = 1
name = "bifurcation-test"
gravity = [0.0, 0.0, -9.81]
[rod]
length = 0.1
radius = 0.001
n_nodes = 11
youngs_modulus = 1e6
density = 1000.0
[reference]
kind = "straight"
origin = [-0.04, 0.0, 0.0]
direction = [1.0, 0.0, 0.0]
normal = [0.0, 0.0, 1.0]
[run]
dt = 0.001
n_samples = 3
nodes_of_interest = [-1]
"""

CONTACT = """
[contact]
friction = 0.1
[[contact.obstacles]]
kind = "bifurcation"
trunk = [[-0.05, 0.0, 0.0], [0.0, 0.0, 0.0], [0.06, 0.0, 0.0]]
left = [[0.09, 0.01, 0.0], [0.12, 0.03, 0.0]]
right = [[0.09, -0.01, 0.0], [0.12, -0.03, 0.0]]
radius = [0.004, 0.004, 0.0035]
left_radius = 0.003
friction = 0.2
"""


def test_the_bifurcation_entry_builds_the_python_bifurcation():
    ob = parse_scenario(HEAD + CONTACT).setup.contact.obstacles[0]
    expected = Bifurcation([[-0.05, 0.0, 0.0], [0.0, 0.0, 0.0], [0.06, 0.0, 0.0]],
                           [[0.09, 0.01, 0.0], [0.12, 0.03, 0.0]], [[0.09, -0.01, 0.0], [0.12, -0.03, 0.0]],
                           [0.004, 0.004, 0.0035], left_radius=0.003, friction=0.2)
    assert isinstance(ob, Bifurcation) and ob.friction == 0.2 and ob.right_radius == 0.0035
    for name in ("trunk", "left", "right", "radius", "left_radius", "right_radius"):
        np.testing.assert_array_equal(getattr(ob, name), getattr(expected, name), err_msg=name)
    for v, w in zip(ob.vessels, expected.vessels):
        np.testing.assert_array_equal(v.points, w.points)


_BAD = {
    "one-point trunk": (("trunk = [[-0.05, 0.0, 0.0], [0.0, 0.0, 0.0], [0.06, 0.0, 0.0]]\nleft",
                         "trunk = [[0.06, 0.0, 0.0]]\nleft"), "contact.obstacles.0.trunk", "at least 2 points"),
    "no right": (("right = [[0.09, -0.01, 0.0], [0.12, -0.03, 0.0]]\n", ""), "contact.obstacles.0.right",
                 "missing key"),
    "flat left": (("left = [[0.09, 0.01, 0.0], [0.12, 0.03, 0.0]]", "left = [0.09, 0.01, 0.0]"),
                  "contact.obstacles.0.left", "[x, y, z] rows"),
    "repeated point": (("right = [[0.09, -0.01, 0.0], [0.12, -0.03, 0.0]]", "right = [[0.09, -0.01, 0.0], "
                        "[0.09, -0.01, 0.0]]"), "contact.obstacles.0.right", "distinct consecutive points"),
    "trunk radii count": (("radius = [0.004, 0.004, 0.0035]", "radius = [0.004, 0.004]"),
                          "contact.obstacles.0.radius", "a list of 3 radii"),
    "negative branch radius": (("left_radius = 0.003", "left_radius = -0.003"), "contact.obstacles.0.left_radius",
                               "a positive number in m"),
    "misspelt key": (("left_radius = 0.003", "left_radii = 0.003"), "contact.obstacles.0.left_radii", "left_radius"),
    "only the junction": (("left = [[0.09, 0.01, 0.0], [0.12, 0.03, 0.0]]", "left = [[0.06, 0.0, 0.0]]"),
                          "contact.obstacles.0", "after the junction"),
    "too narrow": (("left_radius = 0.003", "left_radius = 0.0008"), "contact", "wider than the rod"),
}


@pytest.mark.parametrize("case", list(_BAD))
def test_bad_bifurcation_entries_are_one_line_errors_naming_the_file_and_key(case, tmp_path):
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
    assert fragment in message, message


def test_scenario_show_describes_the_bifurcation(tmp_path, capsys):
    path = tmp_path / "bif.toml"
    path.write_text(HEAD + CONTACT)
    assert run_cli(["scenario", "show", str(path), "--summary"]) == 0
    text = capsys.readouterr().out
    assert ("0: bifurcation: trunk from [-0.05, 0, 0] to the junction [0.06, 0, 0] m, length 0.11 m, radius "
            "0.0035-0.004 m; left branch to [0.12, 0.03, 0] m, length 0.06") in text
    assert "radius 0.003 m; right branch to [0.12, -0.03, 0] m" in text and ", friction 0.2" in text
