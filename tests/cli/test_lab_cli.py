"""``softrnn lab benchmark`` and ``softrnn lab calibrate`` on synthetic stand-ins of a robot's
recordings: the JSON and figure written; bad input one line, exit 2, nothing written."""

import json
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

from helpers import run_cli, tendon_recording


@pytest.fixture(scope="module")
def folder(tmp_path_factory):
    d = tmp_path_factory.mktemp("lab")
    tendon_recording(d / "train.csv", rows=120, seed=0)
    tendon_recording(d / "train2.csv", rows=60, seed=2)
    tendon_recording(d / "val.csv", rows=50, seed=1)
    return d


def test_benchmark_writes_its_json_and_figure(folder, tmp_path, capsys):
    out = tmp_path / "b.json"
    code = run_cli(["lab", "benchmark", "--train", str(folder / "train.csv"), str(folder / "train2.csv"),
                    "--validate", str(folder / "val.csv"), "--length", "0.08", "--families", "physics",
                    "--json", str(out), "--figure", str(tmp_path / "b.png"), "--quiet", "--workers", "1"])
    assert code == 0
    report = json.loads(out.read_text())
    assert set(report["models"]) == {"physics"} and report["best_model"] == "physics"
    assert len(report["robot"]["training_sessions"]) == 2
    assert report["chosen_on_training"]["holdout"] == "the training session farthest in command space from the others"
    assert (tmp_path / "b.png").stat().st_size > 10_000
    text = capsys.readouterr().out
    assert "tip RMSE [mm]" in text and "linear_arx" in text and "wrote" in text


def test_calibrate_writes_the_robot(folder, tmp_path, capsys):
    out = tmp_path / "robot.json"
    assert run_cli(["lab", "calibrate", str(folder / "train.csv"), "--validate", str(folder / "val.csv"),
                    "--length", "0.08", "--lag", "0", "-o", str(out), "--quiet"]) == 0
    robot = json.loads(out.read_text())
    assert robot["validation"]["tip_rmse_mm"] < 0.5 and robot["lag_rows"] == 0
    assert len(robot["parameters"]["tendon_angles_deg"]) == 3


def test_calibrate_with_gravity_and_friction(folder, tmp_path):
    """``--gravity --friction``: the physics with the weight and the routing friction, their
    parameters fitted (a frictionless, weightless robot's data: both come out small) and named."""
    out = tmp_path / "robot.json"
    assert run_cli(["lab", "calibrate", str(folder / "train.csv"), "--validate", str(folder / "val.csv"),
                    "--length", "0.08", "--lag", "0", "--gravity", "--friction", "-o", str(out), "--quiet"]) == 0
    robot = json.loads(out.read_text())
    assert robot["variant"] == "gravity+friction"
    assert 0.0 <= robot["parameters"]["routing_friction"] <= 0.5
    assert len(robot["parameters"]["gravity_direction_base"]) == 3
    assert robot["validation"]["tip_rmse_mm"] < 1.0


def test_calibrate_with_play(folder, tmp_path):
    """``--play``: the physics with the tendons' play, its width fitted (a robot without play: it comes
    out small) and named."""
    out = tmp_path / "robot.json"
    assert run_cli(["lab", "calibrate", str(folder / "train.csv"), "--validate", str(folder / "val.csv"),
                    "--length", "0.08", "--lag", "0", "--play", "-o", str(out), "--quiet"]) == 0
    robot = json.loads(out.read_text())
    assert robot["variant"] == "play" and "tendon play" in robot["model"]
    assert 0.0 <= robot["parameters"]["tendon_play_mm"] < 0.1
    assert robot["validation"]["tip_rmse_mm"] < 0.5


def test_calibrate_with_creep(folder, tmp_path):
    """``--creep``: the physics with the tendons' creep over the rows' times, its rate fitted (a robot without
    creep: it comes out small) and named, with the slack the training left."""
    out = tmp_path / "robot.json"
    assert run_cli(["lab", "calibrate", str(folder / "train.csv"), "--validate", str(folder / "val.csv"),
                    "--length", "0.08", "--lag", "0", "--creep", "-o", str(out), "--quiet"]) == 0
    robot = json.loads(out.read_text())
    assert robot["variant"] == "creep" and "tendon creep" in robot["model"]
    assert 0.0 <= robot["parameters"]["creep_rate_per_s"] < 1e-4
    assert robot["creep_slack_first_row_mm"] == 0.0 and 0.0 <= robot["creep_slack_end_mm"] < 0.05
    assert robot["validation"]["tip_rmse_mm"] < 0.5


def test_calibrate_with_the_turn_with_creep(folder, tmp_path, capsys):
    """``--creep --twist``: the creeping physics that also turns about its axis as it creeps, the turn fitted
    and named; ``--twist`` alone is refused in one line, nothing written."""
    out = tmp_path / "robot.json"
    args = ["lab", "calibrate", str(folder / "train.csv"), "--length", "0.08", "--lag", "0", "-o", str(out), "--quiet"]
    assert run_cli([*args, "--creep", "--twist"]) == 0
    robot = json.loads(out.read_text())
    assert robot["variant"] == "creep+twist" and "turn with its creep" in robot["model"]
    assert "creep_turn_deg_per_mm" in robot["parameters"]
    out.unlink()
    code, err = _bad([*args, "--twist"], capsys)
    assert code == 2 and err.count("\n") == 0 and "--twist=True is invalid: give --creep with it" in err
    assert not out.exists()


def _bad(args, capsys):
    code = run_cli(args)
    err = capsys.readouterr().err.strip()
    return code, err


@pytest.mark.parametrize("change, words", [
    (["--lag", "500"], "--lag=500 is invalid: fewer rows than the recording"),
    (["--lag", "soon"], "--lag='soon' is invalid"),
    (["--segments", "0.1,-2"], "--segments='0.1,-2' is invalid"),
    (["--families", "physics,oracle"], "--families='physics,oracle' is invalid"),
    (["--position-unit", "inch"], "invalid choice"),
    (["--length", "-1"], "--length=-1.0 is invalid"),
    (["--position-unit", "m"], "--length=0.08 is invalid: the robot's length in m: the tip moves up to"),  # mm as m
    (["--length", "80"], "--length=80.0 is invalid: the robot's length in m: the tip moves at most"),      # mm as m
    (["--routing-radius", "4.5"], "--routing-radius=4.5 is invalid: the tendons' distance from the backbone in m, "
                                  "below the robot's length (0.08 m), e.g. 0.0045 for 4.5 mm"),             # mm as m
    (["--routing-radius", "0"], "--routing-radius=0.0 is invalid: a positive finite number in m"),
    (["--workers", "0"], "--workers='0' is invalid: a whole number of worker processes >= 1"),
    (["--workers", "two"], "--workers='two' is invalid"),
])
def test_bad_options_one_line_exit_2_nothing_written(folder, tmp_path, capsys, change, words):
    out = tmp_path / "b.json"
    code, err = _bad(["lab", "benchmark", "--train", str(folder / "train.csv"), "--validate", str(folder / "val.csv"),
                      "--length", "0.08", "--families", "physics", "--json", str(out), "--quiet", *change], capsys)
    assert code == 2 and words in err and "\n" not in err and "Traceback" not in err
    assert list(tmp_path.iterdir()) == []


def test_calibrate_refuses_positions_in_another_unit(folder, tmp_path, capsys):
    """Positions in mm read as m move the tip farther than the robot reaches: refused in one line (the
    benchmark too, above), nothing written."""
    code, err = _bad(["lab", "calibrate", str(folder / "train.csv"), "--length", "0.08", "--position-unit", "m",
                      "-o", str(tmp_path / "robot.json"), "--quiet"], capsys)
    assert code == 2 and "--length=0.08 is invalid" in err and "drop --position-unit m" in err and "\n" not in err
    assert list(tmp_path.iterdir()) == []


def test_bad_recordings_one_line_exit_2_nothing_written(folder, tmp_path, capsys):
    lines = (folder / "train.csv").read_text().splitlines()
    lines[3], lines[4] = lines[4], lines[3]
    (tmp_path / "unsorted.csv").write_text("\n".join(lines) + "\n")
    tendon_recording(tmp_path / "other.csv", rows=30, header=["timestamp", "pattern_label", "servo_1_mm",
                                                             "servo_20_mm", "servo_99_mm", "tip_x", "tip_y", "tip_z"])
    out = tmp_path / "out" / "b.json"
    out.parent.mkdir()
    for train, words in [(tmp_path / "unsorted.csv", "sort the rows by time"),
                         (tmp_path / "other.csv", "every session of a robot needs the same input columns")]:
        code, err = _bad(["lab", "benchmark", "--train", str(train), "--validate", str(folder / "val.csv"),
                          "--length", "0.08", "--json", str(out), "--quiet"], capsys)
        assert code == 2 and words in err and "\n" not in err
        assert list(out.parent.iterdir()) == []


def test_synthetic_data_without_a_physics_one_line_exit_2(folder, tmp_path, capsys):
    header = ["timestamp", "pattern_label", "p_1_kpa", "p_2_kpa", "p_3_kpa", "tip_x", "tip_y", "tip_z"]
    tendon_recording(tmp_path / "kpa.csv", rows=40, header=header)
    tendon_recording(tmp_path / "kpa2.csv", rows=40, seed=1, header=header)
    out = tmp_path / "out" / "b.json"
    out.parent.mkdir()
    for synthetic, words in (("3", "--synthetic=3.0 is invalid: synthetic data need the calibrated tendon physics"),
                             ("-1", "--synthetic=-1.0 is invalid")):
        kpa, kpa2 = str(tmp_path / "kpa.csv"), str(tmp_path / "kpa2.csv")
        code, err = _bad(["lab", "benchmark", "--train", kpa, "--validate", kpa2,
                          "--length", "0.08", "--inputs", "p_*", "--families", "learned_map", "--synthetic", synthetic,
                          "--json", str(out), "--quiet"], capsys)
        assert code == 2 and words in err and "\n" not in err
        assert list(out.parent.iterdir()) == []


def _stat(pid) -> list:
    """The fields of /proc/PID/stat after the command's name (state, parent id...); [] if none."""
    try:
        return (Path("/proc") / str(pid) / "stat").read_text().rsplit(")", 1)[1].split()
    except OSError:
        return []


def _children(pid: int) -> set:
    """The ids of the processes whose parent is ``pid`` (Linux: /proc)."""
    return {int(d.name) for d in Path("/proc").iterdir() if d.name.isdigit() and _stat(d.name)[1:2] == [str(pid)]}


def _running(pids) -> set:
    """Those of ``pids`` still running (a zombie, ended but not yet reaped, is not)."""
    return {pid for pid in pids if _stat(pid)[:1] not in ([], ["Z"])}


@pytest.mark.skipif(not Path("/proc/self/stat").exists(), reason="reads the processes from /proc (Linux)")
def test_ctrl_c_stops_the_workers_with_one_line(folder, tmp_path):
    """Ctrl-C (SIGINT to the whole process group, as a terminal sends it) while the workers fit: one line,
    exit 130, nothing written, and no worker process left behind."""
    out = tmp_path / "b.json"
    script = Path(sys.executable).with_name("softrnn")
    command = [str(script)] if script.is_file() else [sys.executable, "-m", "softrnn.cli.main"]
    proc = subprocess.Popen(command + ["lab", "benchmark", "--train", str(folder / "train.csv"), "--validate",
                                       str(folder / "val.csv"), "--length", "0.08", "--families",
                                       "physics,learned_map", "--workers", "2", "--json", str(out), "--quiet"],
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, start_new_session=True)
    try:
        deadline, workers = time.monotonic() + 300, set()
        while len(workers) < 2:
            assert proc.poll() is None and time.monotonic() < deadline, "the workers did not start"
            workers = _children(proc.pid)
            time.sleep(0.05)
        time.sleep(2.0)                                     # into their first fits
        os.killpg(proc.pid, signal.SIGINT)
        _, err = proc.communicate(timeout=300)
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.wait()
    assert proc.returncode == 130, err
    lines = err.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("softrnn: interrupted;") and "Traceback" not in err, err
    assert not out.exists()
    deadline = time.monotonic() + 30
    while _running(workers) and time.monotonic() < deadline:
        time.sleep(0.1)
    assert not _running(workers)
