"""The suite file of ``softrnn lab benchmark --suite`` (``softrnn.scenarios.suite``): robots in the
file's order, paths against the file's folder, the benchmark's defaults left to it; every mistake one
line naming the file and the robot's entry."""

import shutil
from pathlib import Path

import pytest

from softrnn.scenarios import ScenarioError
from softrnn.scenarios.suite import read_suite

GOOD = """title = "two arms"
[robots.arm-b]
train = ["data/b1.csv", "data/b2.csv"]
validate = "data/bv.csv"
length = 0.2
segments = [0.1, 0.1]
lag = "auto"
families = ["physics", "hybrid"]
inputs = ["servo_*"]
tip = ["tip_x", "tip_y", "tip_z"]
position_unit = "mm"
tendons_per_segment = 3
routing_radius = 0.004
synthetic = 2.5
scenario = "tendon-spatial"

[robots.arm_a]
train = ["data/a.csv"]
validate = "data/av.csv"
length = 0.1
"""


@pytest.fixture
def folder(tmp_path) -> Path:
    (tmp_path / "data").mkdir()
    for name in ("b1", "b2", "bv", "a", "av"):
        (tmp_path / "data" / f"{name}.csv").write_text("time\n")
    return tmp_path


def _suite(folder, text):
    (folder / "suite.toml").write_text(text)
    return read_suite(folder / "suite.toml")


def test_a_suite_reads_in_order_with_paths_against_its_folder(folder):
    suite = _suite(folder, GOOD)
    assert suite.title == "two arms" and [r.name for r in suite.robots] == ["arm-b", "arm_a"]
    b, a = suite.robots
    assert b.train == (str(folder / "data/b1.csv"), str(folder / "data/b2.csv"))
    assert b.validate == str(folder / "data/bv.csv") and b.key == "robots.arm-b"
    assert b.segments == (0.1, 0.1) and b.lag == "auto" and b.families == ("physics", "hybrid")
    assert b.tip == ("tip_x", "tip_y", "tip_z") and b.routing_radius == 0.004 and b.tendons_per_segment == 3
    assert b.synthetic == 2.5 and b.scenario == "tendon-spatial" and a.scenario is None
    assert (a.segments, a.lag, a.families, a.inputs, a.tip, a.position_unit, a.tendons_per_segment, a.synthetic) == \
        (None, None, None, (), None, None, None, None)


@pytest.mark.parametrize("change, words", [
    (("length = 0.1\n", "lenght = 0.1\n"), "unknown key 'robots.arm_a.lenght'"),
    (('validate = "data/av.csv"', 'validate = "data/nothere.csv"'), "robots.arm_a.validate: no session file"),
    (('"data/b2.csv"', '"data/b3.csv"'), "robots.arm-b.train[1]: no session file"),
    (("length = 0.1\n", "length = -0.1\n"), "robots.arm_a.length = -0.1 is invalid"),
    (('lag = "auto"', 'lag = "soon"'), "robots.arm-b.lag = 'soon' is invalid"),
    (('scenario = "tendon-spatial"', 'scenario = "arm.toml"'), "robots.arm-b.scenario: no scenario file"),
    (("synthetic = 2.5", "synthetic = -1"), "robots.arm-b.synthetic = -1 is invalid: expected a number >= 0"),
    (('tip = ["tip_x", "tip_y", "tip_z"]', 'tip = ["tip_x"]'), "robots.arm-b.tip = ['tip_x'] is invalid"),
    (("[robots.arm_a]", "[robots.'arm a']"), "the robot name 'arm a' is invalid"),
    (('validate = "data/av.csv"\n', ""), "missing key 'robots.arm_a.validate'"),
    (('title = "two arms"', 'titel = "x"'), "unknown key 'titel'"),
])
def test_a_bad_suite_is_one_line_naming_the_entry(folder, change, words):
    assert change[0] in GOOD
    with pytest.raises(ScenarioError) as err:
        _suite(folder, GOOD.replace(*change))
    assert words in str(err.value) and str(err.value).startswith(str(folder / "suite.toml"))
    assert "\n" not in str(err.value)


def test_a_suite_without_robots_or_file_is_refused(folder):
    with pytest.raises(ScenarioError, match=r"no robots: give one \[robots.NAME\] table"):
        _suite(folder, 'title = "empty"\n')
    with pytest.raises(ScenarioError, match="malformed TOML"):
        _suite(folder, "[robots.a\n")
    with pytest.raises(ScenarioError, match="cannot read the suite file"):
        read_suite(folder / "none.toml")


def test_the_shipped_suite_of_the_shared_robot_reads(tmp_path):
    """docs/results/real-robot/suite.toml, with stand-in files where it expects the recordings."""
    shipped = Path(__file__).resolve().parents[2] / "docs" / "results" / "real-robot" / "suite.toml"
    (tmp_path / "docs" / "results" / "real-robot").mkdir(parents=True)
    shutil.copy(shipped, tmp_path / "docs" / "results" / "real-robot" / "suite.toml")
    (tmp_path / "data" / "opencr-tdcr-v6").mkdir(parents=True)
    for name in ("train", "val"):
        (tmp_path / "data" / "opencr-tdcr-v6" / f"{name}.csv").write_text("time\n")
    (robot,) = read_suite(tmp_path / "docs" / "results" / "real-robot" / "suite.toml").robots
    assert robot.name == "opencr-tdcr-v6" and robot.length == 0.222 and robot.segments == (0.1, 0.1, 0.022)
    assert robot.train == (str(tmp_path / "data" / "opencr-tdcr-v6" / "train.csv"),)
