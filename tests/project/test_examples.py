"""The examples run: each is run as a user runs it, on a small synthetic stand-in of its input."""

import importlib.util
import json
import subprocess
import sys
from pathlib import Path

from softrnn.lab.benchmark import BenchmarkOptions, prepare
from softrnn.lab.nets import NetOptions
from softrnn.lab.recording import read_recording
from softrnn.lab.uncertainty import pattern_folds

from helpers import tendon_recording

ROOT = Path(__file__).resolve().parents[2]


def _example(name: str, *args, cwd) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, str(ROOT / "examples" / name), *map(str, args)], cwd=cwd,
                          capture_output=True, text=True, timeout=600)


def test_interval_quarters_checks_the_learned_map_s_three_scales(tmp_path):
    """``--learned-map``: one quarter's coverage of the learned map with its scale with and without its
    distance from the physics, and with none (small networks, through the example's ``quarter``)."""
    spec = importlib.util.spec_from_file_location("interval_quarters", ROOT / "examples" / "interval_quarters.py")
    example = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(example)
    tendon_recording(tmp_path / "rec.csv", rows=160, seed=1)
    options = BenchmarkOptions(length=0.08, segments=(0.08,), nets=NetOptions(members=2, steps=100, hidden=8))
    prepared = prepare([read_recording(tmp_path / "rec.csv")], None, options)
    train, block = pattern_folds(list(prepared.train), 4)[0]
    out = example.quarter(prepared.robot, options, train, block, False, with_map=True)
    assert set(out["learned_map"]) == {"physics", "no physics", "none"}
    assert all(0.0 <= share <= 1.0 for share in out["learned_map"].values())


def test_interval_quarters_checks_the_intervals_on_a_training_session_alone(tmp_path):
    """Each quarter of the session's patterns is a validation session in turn: every model's coverage is a
    share of rows, and the JSON has the four quarters; a session without pattern labels is refused in one
    line, exit 2, nothing written."""
    tendon_recording(tmp_path / "rec.csv", rows=160, seed=0)
    done = _example("interval_quarters.py", "rec.csv", "--length", 0.08, "--segments", 0.08, "--json", "out.json",
                    cwd=tmp_path)
    assert done.returncode == 0, done.stderr
    out = json.loads((tmp_path / "out.json").read_text())
    assert sorted(out) == [f"quarter {j}" for j in range(4)]
    for quarter in out.values():
        assert {"physics", "persistence", "constant_velocity", "linear_arx", "static_map"} <= set(quarter)
        assert all(0.0 <= share <= 1.0 for shares in quarter.values() for share in shares.values())
    text = (tmp_path / "rec.csv").read_text().splitlines()
    rows = [line.split(",") for line in text]
    (tmp_path / "plain.csv").write_text("\n".join(",".join(r[:1] + r[2:]) for r in rows) + "\n")
    refused = _example("interval_quarters.py", "plain.csv", "--length", 0.08, "--segments", 0.08, "--json",
                       "plain.json", cwd=tmp_path)
    assert refused.returncode == 2 and "no pattern labels" in refused.stderr
    assert len(refused.stderr.strip().splitlines()) == 1 and not (tmp_path / "plain.json").exists()
