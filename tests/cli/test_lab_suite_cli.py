"""``softrnn lab benchmark --suite`` on synthetic stand-ins: the suite's table (JSON, Markdown) and each
robot's report written; a second run refused, resumed or rerun; bad input one line naming the suite
file's entry, exit 2, nothing written."""

import dataclasses
import json

import pytest

import softrnn.lab.benchmark as lab_benchmark
from softrnn.lab.tendon_robot import CalibrationOptions

from helpers import run_cli, tendon_recording

SMALL_SEARCH = CalibrationOptions(twists=4, quick_evaluations=15, evaluations=60, variant_evaluations=30)
"""The physics' calibration with a small search: these tests check the command's files, lines and errors,
not how well it fits (tests/lab/test_tendon_robot.py does)."""


@dataclasses.dataclass(frozen=True)
class _SmallSearch(lab_benchmark.BenchmarkOptions):
    calibration: CalibrationOptions = SMALL_SEARCH


@pytest.fixture(autouse=True)
def _small_search(monkeypatch):
    """The options the command builds (``softrnn.cli._lab`` imports the class when it runs) search less."""
    monkeypatch.setattr(lab_benchmark, "BenchmarkOptions", _SmallSearch)

SUITE = """title = "stand-ins"
[robots.one]
train = ["one/train.csv"]
validate = "one/val.csv"
length = 0.08
lag = 0
families = ["physics"]

[robots.two]
train = ["two/train.csv", "two/train2.csv"]
validate = "two/val.csv"
length = 0.08
families = ["physics"]
"""


@pytest.fixture(scope="module")
def folder(tmp_path_factory):
    d = tmp_path_factory.mktemp("suite")
    for robot, sessions in (("one", (("train", 90, 0), ("val", 40, 1))),
                            ("two", (("train", 70, 2), ("train2", 40, 3), ("val", 40, 4)))):
        (d / robot).mkdir()
        for name, rows, seed in sessions:
            tendon_recording(d / robot / f"{name}.csv", rows=rows, seed=seed)
    tendon_recording(d / "one" / "other.csv", rows=40, seed=6, header=[
        "timestamp", "pattern_label", "servo_1_mm", "servo_20_mm", "servo_99_mm", "tip_x", "tip_y", "tip_z"])
    tendon_recording(d / "one" / "far.csv", rows=40, seed=7, scale_mm=80.0)
    return d


def _write(folder, name, text):
    (folder / name).write_text(text)
    return str(folder / name)


def test_suite_writes_one_table_and_resumes(folder, tmp_path, capsys):
    suite = _write(folder, "suite.toml", SUITE)
    out = tmp_path / "s.json"
    args = ["lab", "benchmark", "--suite", suite, "--json", str(out), "--markdown", str(tmp_path / "s.md"), "--quiet",
            "--workers", "1"]   # in this process: the figures do not depend on it (tests/lab/test_worker_pool.py)
    assert run_cli(args) == 0
    table = json.loads(out.read_text())
    assert table["title"] == "stand-ins" and list(table["robots"]) == ["one", "two"]
    for entry in table["robots"].values():
        assert set(entry["models"]["physics"]) >= {"tip_rmse_aligned_mm", "tip_mean_aligned_mm",
                                                   "tip_mean_aligned_pct_of_length"}
        assert entry["chosen_on_training"]["family"] == "physics"
    assert sorted(p.name for p in (tmp_path / "s-robots").iterdir()) == ["one.json", "two.json"]
    report = json.loads((tmp_path / "s-robots" / "two.json").read_text())
    assert len(report["robot"]["training_sessions"]) == 2 and report["robot"]["estimated"]
    assert "| two | `physics` |" in (tmp_path / "s.md").read_text()
    assert "wrote" in capsys.readouterr().out

    assert run_cli(args) == 2                                                     # the outputs exist
    assert "--json" in capsys.readouterr().err
    assert run_cli([*args, "--resume"]) == 0
    assert "kept from an earlier run: one, two" in capsys.readouterr().out
    assert json.loads(out.read_text())["robots"]["one"]["models"] == table["robots"]["one"]["models"]


@pytest.mark.parametrize("old, new, words", [
    ('validate = "one/val.csv"', 'validate = "one/gone.csv"', (": robots.one.validate: no session file",)),
    ('validate = "one/val.csv"', 'validate = "one/other.csv"',
     (": robots.one: ", "every session of a robot needs the same input columns")),
    ('validate = "one/val.csv"', 'validate = "one/train.csv"',
     (": robots.one: ", "train.csv: repeats 90 of its 90 rows of", "pass each recorded row once")),
    ("lag = 0\n", "lagg = 0\n", (": unknown key 'robots.one.lagg'",)),
    ('validate = "one/val.csv"', 'validate = "one/far.csv"', (": robots.one: ", "beyond what the routing allows")),
    ('families = ["physics"]\n\n', 'families = ["oracle"]\n\n', (": robots.one: families='oracle' is invalid",)),
    ('validate = "two/val.csv"', 'validate = "one/far.csv"', (": robots.two: ", "beyond what the routing allows")),
])
def test_bad_suite_one_line_naming_the_entry_exit_2_nothing_written(folder, tmp_path, capsys, old, new, words):
    assert old in SUITE
    suite = _write(folder, "bad.toml", SUITE.replace(old, new))
    code = run_cli(["lab", "benchmark", "--suite", suite, "--json", str(tmp_path / "s.json"),
                    "--markdown", str(tmp_path / "s.md"), "--quiet"])
    err = capsys.readouterr().err.strip()
    assert code == 2 and "\n" not in err and "Traceback" not in err
    assert err.startswith(f"softrnn: error: {suite}: ") and all(w in err for w in words), err
    assert list(tmp_path.iterdir()) == []


def test_suite_options_belong_in_the_file(folder, tmp_path, capsys):
    suite = _write(folder, "suite.toml", SUITE)
    code = run_cli(["lab", "benchmark", "--suite", suite, "--json", str(tmp_path / "s.json"), "--length", "0.1",
                    "--lag", "0", "--quiet"])
    assert code == 2 and "leave out --length, --lag" in capsys.readouterr().err
    code = run_cli(["lab", "benchmark", "--json", str(tmp_path / "s.json"), "--quiet"])
    assert code == 2 and "required: --train, --validate, --length" in capsys.readouterr().err
    code = run_cli(["lab", "benchmark", "--suite", suite, "--json", str(tmp_path / "s.json"), "--figure",
                    str(tmp_path / "f.png"), "--quiet"])
    assert code == 2 and "leave out --figure" in capsys.readouterr().err
    code = run_cli(["lab", "benchmark", "--train", str(folder / "one" / "train.csv"), "--validate",
                    str(folder / "one" / "val.csv"), "--length", "0.08", "--json", str(tmp_path / "s.json"),
                    "--resume", "--quiet"])
    assert code == 2 and "without --suite there is nothing to resume" in capsys.readouterr().err
    assert list(tmp_path.iterdir()) == []


def test_one_robot_prints_and_writes_the_aligned_figures(folder, tmp_path, capsys):
    out = tmp_path / "b.json"
    assert run_cli(["lab", "benchmark", "--train", str(folder / "one" / "train.csv"), "--validate",
                    str(folder / "one" / "val.csv"), "--length", "0.08", "--lag", "0", "--families", "physics",
                    "--json", str(out), "--markdown", str(tmp_path / "b.md"), "--quiet", "--workers", "1"]) == 0
    report = json.loads(out.read_text())
    physics = report["models"]["physics"]
    text = capsys.readouterr().out
    assert "aligned mean [mm]" in text and f"{physics['tip_mean_aligned_mm']:.2f}" in text
    assert f"physics (validation tip RMSE {physics['tip_rmse_mm']:.2f} mm)" in text
    md = (tmp_path / "b.md").read_text()
    assert f"| one | `physics` | {physics['tip_rmse_mm']:.2f} |" in md
