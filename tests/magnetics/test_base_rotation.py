"""Rotation of the magnetic manipulator's base, its hub (``BaseAdvance.rotation``): the base turns
about its axis by the advance's smoothstep while it advances, exactly; without a rotation the
motion is the held frame bit for bit; ``softrnn magnetic navigate --rotate DEG`` turns it and
records the turn; nonsense is refused in one line."""

import math

import numpy as np
import pytest

from softrnn.errors import SoftrnnInputError
from softrnn.magnetics import BaseAdvance
from softrnn.magnetics.manipulator import ManipulatorRun, ManipulatorSpec, simulate_manipulator
from softrnn.rod.hub import axis_rotation
from softrnn.rod.loads import smoothstep
from softrnn.rod.so3 import quaternion_to_matrix

from helpers import run_cli

CURRENTS = np.array([1.0, -1.0, 0.5, 0.0, 2.0, -2.0])


def test_the_base_turns_about_its_axis_while_it_advances():
    advance = BaseAdvance(distance=0.003, start=0.01, ramp=0.04, rotation=0.5 * math.pi)
    spec = ManipulatorSpec(advance=advance)
    traj = simulate_manipulator(spec, np.tile(CURRENTS, (11, 1)), ManipulatorRun(dt=0.005, n_samples=11, settle=0.01))
    s = smoothstep((traj.time - 0.01) / 0.04)
    R0 = spec.reference_shape().rotations[0]
    expected = axis_rotation(np.array([1.0, 0.0, 0.0]), 0.5 * math.pi * s) @ R0
    np.testing.assert_allclose(quaternion_to_matrix(traj.quaternions[:, 0]), expected, atol=1e-12)
    np.testing.assert_allclose(traj.positions[:, 0, 0] - spec.base[0], 0.003 * s, atol=1e-12)


def test_an_advance_without_rotation_holds_the_frame_bit_for_bit():
    spec = ManipulatorSpec(advance=BaseAdvance(distance=0.003, start=0.01, ramp=0.04))
    t = np.linspace(0.0, 0.1, 7)
    pos, rot = spec.base_motion()(t)
    assert np.array_equal(rot, np.broadcast_to(spec.reference_shape().rotations[0], (7, 3, 3)))
    turned = ManipulatorSpec(advance=BaseAdvance(distance=0.003, start=0.01, ramp=0.04, rotation=1.0))
    assert np.array_equal(turned.base_motion()(t)[0], pos)


def test_softrnn_magnetic_navigate_rotates_the_base(tmp_path, capsys):
    from softrnn.io import read_dataset

    path = tmp_path / "turned.h5"
    argv = ["magnetic", "navigate", "-o", str(path), "--rotate", "90", "--advance", "5", "--duration", "0.4",
            "--quiet"]
    assert run_cli(argv) == 0
    assert "base advanced 5 mm, base turned 90 deg" in capsys.readouterr().out
    data = read_dataset(path)
    assert data.attrs["rotate_rad"] == pytest.approx(0.5 * math.pi) and data.attrs["advance_m"] == 0.005
    R = quaternion_to_matrix(data.quaternions[-1, 0].astype(float))
    assert R[:, 2] == pytest.approx([1.0, 0.0, 0.0], abs=1e-6)                 # the axis held
    R0 = ManipulatorSpec().reference_shape().rotations[0]
    assert R[:, 0] == pytest.approx(axis_rotation(np.array([1.0, 0, 0]), np.array([0.5 * math.pi]))[0] @ R0[:, 0],
                                    abs=1e-6)


@pytest.mark.parametrize("build, words", [
    (lambda: BaseAdvance(distance=0.0), "advance.distance=0.0 is invalid"),
    (lambda: BaseAdvance(distance=0.01, rotation=float("inf")), "advance.rotation=inf is invalid"),
])
def test_bad_rotations_are_refused_in_one_line(build, words):
    with pytest.raises(SoftrnnInputError) as err:
        build()
    assert "\n" not in str(err.value) and words in str(err.value), str(err.value)


def test_a_bad_rotate_flag_is_refused_in_one_line(tmp_path, capsys):
    assert run_cli(["magnetic", "navigate", "-o", str(tmp_path / "x.h5"), "--rotate", "0"]) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and "--rotate=0.0 is invalid" in err
    assert not (tmp_path / "x.h5").exists()
