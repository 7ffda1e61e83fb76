"""The material table (``[[rod.sections]]``) and the bends of a pre-shaped reference
(``[[reference.bends]]``) in scenario files: they build the rod and shape of the Python API, and a
table that does not tile the rod is a one-line error naming the key and the fix (exit 2 from the
command line, nothing written)."""

import math

import numpy as np
import pytest

from softrnn.errors import SoftrnnInputError
from softrnn.rod import Bend, MaterialSection, curved
from softrnn.scenarios import load_scenario

from helpers import run_cli

DEVICE = """
name = "device"
[rod]
length = 0.2
radius = 0.002
youngs_modulus = 2e6
density = 1000.0
n_nodes = 21
[[rod.sections]]
from = 0.0
to = 0.15
[[rod.sections]]
from_fraction = 0.75
to_fraction = 1.0
youngs_modulus = 5e5
density = 600.0
inner_radius = 0.001
[reference]
kind = "straight"
direction = [1.0, 0.0, 0.0]
normal = [0.0, 0.0, 1.0]
[[reference.bends]]
from = 0.17
to = 0.2
angle_deg = 90.0
toward_deg = 90.0
[[boundary]]
kind = "clamp"
node = 0
[run]
dt = 1e-3
n_samples = 3
substeps = "auto"
nodes_of_interest = [-1]
"""


def _write(tmp_path, text):
    path = tmp_path / "device.toml"
    path.write_text(text)
    return path


def test_sections_and_bends_build_the_rod_and_its_shape(tmp_path):
    sc = load_scenario(_write(tmp_path, DEVICE))
    rod = sc.setup.rod
    assert rod.sections[0] == MaterialSection(start=0.0, end=0.15)
    assert rod.sections[1] == MaterialSection(start=0.75 * 0.2, end=0.2, youngs_modulus=5e5, density=600.0,
                                              inner_radius=0.001)
    expected = curved(21, 0.2, (Bend(0.17, 0.2, math.radians(90.0) / 0.03, 90.0),), direction=(1, 0, 0),
                      normal=(0, 0, 1))
    np.testing.assert_array_equal(sc.setup.reference.positions, expected.positions)
    assert sc.setup.initial is sc.setup.reference


@pytest.mark.parametrize("old, new, words", [
    ("to = 0.15", "to = 0.16", ["rod.sections.1.from_fraction * rod.length=0.15", "overlap"]),
    ("to = 0.15", "to = 0.12", ["rod.sections.1.from_fraction * rod.length=0.15", "gap [0.12, 0.15]"]),
    ("from = 0.0\nto = 0.15", "from = 0.01\nto = 0.15", ["rod.sections.0.from=0.01", "uncovered"]),
    ("to_fraction = 1.0", "to_fraction = 0.9",
     ["rod.sections.1.to_fraction * rod.length=0.18", "[0.18, 0.2] m uncovered"]),
    ("from_fraction = 0.75\n", "from_fraction = 0.75\nfrom = 0.15\n", ["give exactly one of from (m) or "
                                                                      "from_fraction"]),
    ("to_fraction = 1.0", "to_fraction = 1.5", ["rod.sections.1.to_fraction = 1.5", "[0, 1]"]),
    ("youngs_modulus = 5e5", "youngs_modulus = -5e5", ["rod.sections.1.youngs_modulus"]),
    ("inner_radius = 0.001", "inner_radius = 0.003",
     ["rod.sections.1.inner_radius = 0.003", "below the outer radius 0.002 m"]),
    ("angle_deg = 90.0", "curvature = 50.0\nangle_deg = 90.0", ["exactly one of curvature"]),
    ("from = 0.17\nto = 0.2\n", "from = 0.17\nto = 0.25\n", ["reference.bends.0.to = 0.25", "<= the shape's"]),
])
def test_a_bad_material_table_or_bend_is_one_line_naming_the_key(tmp_path, old, new, words):
    assert old in DEVICE
    path = _write(tmp_path, DEVICE.replace(old, new, 1))
    with pytest.raises(SoftrnnInputError) as info:
        load_scenario(path)
    message = str(info.value)
    assert "\n" not in message and message.startswith(f"{path}: "), message
    assert all(w in message for w in words), message


def test_the_command_line_refuses_a_gap_with_exit_2_and_writes_nothing(tmp_path, capsys):
    path = _write(tmp_path, DEVICE.replace("to = 0.15", "to = 0.12", 1))
    target = tmp_path / "summary.json"
    assert run_cli(["simulate", str(path), "--json", str(target), "--quiet"]) == 2
    assert "rod.sections.1" in capsys.readouterr().err
    assert sorted(p.name for p in tmp_path.iterdir()) == ["device.toml"]


def test_the_scenario_summary_counts_the_sections(tmp_path, capsys):
    assert run_cli(["scenario", "show", str(_write(tmp_path, DEVICE)), "--summary"]) == 0
    assert "2 material sections" in capsys.readouterr().out


def test_a_sweep_varies_a_section_and_a_bend(tmp_path):
    text = DEVICE + ('[randomize]\n"rod.sections.1.youngs_modulus" = { uniform = [1e5, 1e6] }\n'
                     '"reference.bends.0.angle_deg" = { uniform = [30.0, 180.0] }\n')
    sc = load_scenario(_write(tmp_path, text))
    v = sc.variant(2)
    assert v.setup.rod.sections[1].youngs_modulus == v.sampled["rod.sections.1.youngs_modulus"] != 5e5
    K0 = np.abs(np.diff(v.setup.reference.rotations[-7:, :, 2], axis=0)).sum()
    assert K0 != np.abs(np.diff(sc.setup.reference.rotations[-7:, :, 2], axis=0)).sum()  # another tip angle
