"""examples/pneumatic_arm.py, the simulated pneumatic-like arm of the real-robot guide: its pose is a
constant-curvature arc (analytic checks), a pressure held long enough bends the tip to that pose
toward its chamber, the play holds the tip where the pressure came from, the sessions are
deterministic, and the lab reads what it writes."""

import runpy
import sys
from pathlib import Path

import numpy as np
import pytest

from softrnn.lab.recording import read_recording

PATH = Path(__file__).resolve().parents[2] / "examples" / "pneumatic_arm.py"
EXAMPLE = runpy.run_path(str(PATH))
ARM = EXAMPLE["PneumaticArm"]()


def test_pose_is_a_constant_curvature_arc():
    assert ARM.pose(np.zeros(3)) == pytest.approx([0.0, 0.0, -ARM.length], abs=1e-9)
    r = np.array([0.5, 0.0, 0.0])                  # chamber a alone: bends toward +x in the x-z plane
    kappa, s = ARM.curvature * 0.5, ARM.length + ARM.stretch * 0.5
    expected = [(1.0 - np.cos(kappa * s)) / kappa, 0.0, -np.sin(kappa * s) / kappa]
    assert ARM.pose(r) == pytest.approx(expected, abs=1e-9)
    # equal pressures cancel the bend and lengthen the arm
    assert ARM.pose(np.full(3, 0.4)) == pytest.approx([0.0, 0.0, -(ARM.length + 3 * 0.4 * ARM.stretch)], abs=1e-9)
    # chamber b bends toward 120 degrees
    x, y, _ = ARM.pose(np.array([0.0, 0.5, 0.0]))
    assert np.degrees(np.arctan2(y, x)) == pytest.approx(120.0)


def test_sessions_are_deterministic_lab_recordings(tmp_path):
    session, csv_text = EXAMPLE["session"], EXAMPLE["csv_text"]
    a, b = session(ARM, 7, duration=6.0), session(ARM, 7, duration=6.0)
    assert all(np.array_equal(x, y) for x, y in zip(a, b))
    other = session(ARM, 8, duration=6.0)
    assert not np.array_equal(a[2], other[2])
    time, tip, p = a
    assert time.shape == (120,) and np.allclose(np.diff(time), 0.05)
    assert tip.shape == (120, 3) and p.shape == (120, 3) and p.min() >= 0.0 and p.max() <= 1.0
    assert tip[0] == pytest.approx([0.0, 0.0, -ARM.length], abs=5 * ARM.noise)    # starts at rest
    path = tmp_path / "s.csv"
    path.write_text(csv_text(*a))
    rec = read_recording(path)
    assert rec.names == ("p_a", "p_b", "p_c") and rec.units == ("bar", "bar", "bar")
    assert np.allclose(rec.tip, tip, atol=1e-7) and np.allclose(rec.inputs, p, atol=1e-4)


def test_a_held_pressure_settles_on_its_pose_and_the_play_holds_it():
    """Chamber a driven to 0.5 bar from below and from above, each then held for 16 s (the swing decays
    as exp(-zeta omega t), to 2e-4 of its start): the tip settles on the pose of 0.5 bar less or more
    half the play, as the play operator leaves the effective pressure at the edge it was dragged by."""
    run, dt = EXAMPLE["run"], 1e-3
    hold = int(16.0 / dt)
    up = np.zeros((2 * hold, 3))
    up[:hold, 0] = 0.0
    up[hold:, 0] = 0.5
    down = up.copy()
    down[:hold, 0] = 1.0
    w = ARM.play / 2.0
    from_below, from_above = run(ARM, up, dt)[-1], run(ARM, down, dt)[-1]
    assert from_below == pytest.approx(ARM.pose(np.array([0.5 - w, 0.0, 0.0])), abs=5e-5)
    assert from_above == pytest.approx(ARM.pose(np.array([0.5 + w, 0.0, 0.0])), abs=5e-5)
    assert np.linalg.norm(from_above - from_below) > 2e-3          # the play's width shows at the tip


@pytest.mark.parametrize("args, words", [
    (["--duration", "0"], "--duration=0 is invalid: a positive length in s"),
    (["--rate", "5000"], "--rate=5000 is invalid: rows per second in (0, 1000] Hz"),
    (["--seeds", "1", "-2"], "--seeds=-2 is invalid: seeds >= 0"),
])
def test_bad_options_are_one_line_exit_2_nothing_written(tmp_path, monkeypatch, capsys, args, words):
    monkeypatch.setattr(sys, "argv", [str(PATH), str(tmp_path / "out"), *args])
    with pytest.raises(SystemExit) as stop:
        runpy.run_path(str(PATH), run_name="__main__")
    err = capsys.readouterr().err.strip()
    assert stop.value.code == 2 and words in err and "\n" not in err and not (tmp_path / "out").exists()
