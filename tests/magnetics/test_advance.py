"""Insertion of the magnetic manipulator (``ManipulatorSpec.advance``, a ``BaseAdvance``): the base
follows its smoothstep profile along +x exactly, as ``softrnn.rod.Simulator`` moves a clamp with a
motion; an advance that has not begun changes nothing, bit for bit; the frame-by-frame stepper
carries it; steered by the field and advanced 12 mm, the rod goes into the chosen branch, 17 mm
along it (a fixed base leaves the tip at the mouth); nonsense is refused in one line."""

import numpy as np
import pytest

from softrnn.errors import SoftrnnInputError
from softrnn.magnetics import BaseAdvance
from softrnn.magnetics.manipulator import ManipulatorRun, ManipulatorSpec, simulate_manipulator
from softrnn.magnetics.navigation import DEMO_ADVANCE, navigate, navigation_spec, tip_branch
from softrnn.magnetics.stepper import ManipulatorStepper
from softrnn.rod import RunConfig, Simulator
from softrnn.rod.boundary import Clamp
from softrnn.rod.loads import smoothstep

CURRENTS = np.array([1.0, -1.0, 0.5, 0.0, 2.0, -2.0])
RUN = dict(ramp=0.5, hold=0.7, dt=0.01, settle=0.3)      # the shipped scenario's timing: 1.2 s


def test_the_base_follows_its_profile_exactly():
    """Node 0 at every saved sample, settling included (t < start): base + distance s((t - start)
    / ramp) along +x to 1e-12 m, its rotation held; at zero current the run is the plain rod
    simulation of ``spec.setup()`` (a ``Clamp`` with the same motion)."""
    advance = BaseAdvance(distance=0.004, start=0.02, ramp=0.05)
    spec = ManipulatorSpec(advance=advance)
    run = ManipulatorRun(dt=0.005, n_samples=21, settle=0.01)
    traj = simulate_manipulator(spec, np.tile(CURRENTS, (21, 1)), run)
    expected = np.array(spec.base) + 0.004 * smoothstep((traj.time - 0.02) / 0.05)[:, None] * np.array([1, 0, 0])
    assert np.abs(traj.positions[:, 0] - expected).max() < 1e-12
    assert traj.positions[-1, 0, 0] - spec.base[0] == pytest.approx(0.004, abs=1e-15)
    assert np.array_equal(traj.quaternions[:, 0], np.broadcast_to(traj.quaternions[0, 0], (21, 4)))
    assert traj.rod.velocities[10, 0, 0] > 0.05                                    # moving mid-ramp
    assert spec.base_motion().advance is advance and spec.setup().boundary[0].motion is not None

    plain = simulate_manipulator(spec, np.zeros((21, 6)), ManipulatorRun(dt=0.005, n_samples=21))
    ref = Simulator(spec.setup()).run(RunConfig(dt=0.005, n_samples=21, substeps=plain.substeps))
    np.testing.assert_allclose(plain.positions, ref.positions, rtol=0, atol=1e-15)
    np.testing.assert_allclose(plain.quaternions, ref.quaternions, rtol=0, atol=1e-13)   # the base: t + h rounded


def test_an_advance_that_has_not_begun_changes_nothing_bit_for_bit():
    """A fixed base is a clamp without motion (no prescribed node); an advance that starts after the
    run moves the base by exactly 0, and every result equals the fixed base's bit for bit."""
    fixed = ManipulatorSpec()
    assert fixed.advance is None and fixed.base_motion() is None
    assert fixed.setup().boundary == (Clamp(0),)
    late = ManipulatorSpec(advance=BaseAdvance(distance=0.01, start=1.0, ramp=0.5))
    run = ManipulatorRun(dt=0.01, n_samples=6, settle=0.02)
    a = simulate_manipulator(fixed, np.tile(CURRENTS, (6, 1)), run)
    b = simulate_manipulator(late, np.tile(CURRENTS, (6, 1)), run)
    for name in ("positions", "quaternions", "velocities", "angular_velocities", "reaction_forces",
                 "reaction_torques", "energy"):
        assert np.array_equal(getattr(a.rod, name), getattr(b.rod, name)), name
    assert np.array_equal(a.wrenches, b.wrenches)


def test_the_stepper_advances_the_base_as_the_batch_run_does():
    spec = ManipulatorSpec(advance=BaseAdvance(distance=0.003, start=0.01, ramp=0.06))
    dt = 1 / 30
    batch = simulate_manipulator(spec, np.tile(CURRENTS, (4, 1)), ManipulatorRun(dt=dt, n_samples=4, settle=0.05))
    stepper = ManipulatorStepper(spec, dt, CURRENTS, settle=0.05)
    got = [stepper.positions]
    for _ in range(3):
        stepper.step(CURRENTS)
        got.append(stepper.positions)
    np.testing.assert_allclose(np.array(got), batch.positions, rtol=0, atol=1e-13)
    assert got[-1][0, 0] - spec.base[0] == pytest.approx(0.003, abs=1e-12)


def _along(bif, tip, side):
    """How far [m] the tip lies along the axis of branch ``side`` from the junction."""
    J = bif.trunk[-1]
    first = getattr(bif, side)[0]
    return float((tip - J) @ (first - J) / np.linalg.norm(first - J))


@pytest.fixture(scope="module")
def inserted():
    spec = navigation_spec(advance=DEMO_ADVANCE)
    return spec, {branch: navigate(branch, spec=spec, **RUN) for branch in ("left", "right")}


def test_steered_and_advanced_the_rod_goes_into_the_chosen_branch(inserted):
    """15 mT toward a branch, the base advanced 12 mm from 0.3 s over 0.7 s: the tip ends inside that
    branch's tube only, 17 mm along it (a fixed base: 5 mm, at the mouth), and the rod never sinks
    0.5 % of its radius into a wall; the two runs are mirror images."""
    spec, traj = inserted
    bif = spec.contact.obstacles[0]
    fixed = navigate("left", spec=navigation_spec(), **RUN).positions[-1, -1]
    assert tip_branch(bif, fixed) == "left" and _along(bif, fixed, "left") < 0.006
    radius = np.full(spec.n_nodes, 0.5 * spec.diameter)
    for branch in ("left", "right"):
        tip = traj[branch].positions[-1, -1]
        assert tip_branch(bif, tip) == branch
        assert _along(bif, tip, branch) > 0.016 > 0.01 + _along(bif, fixed, "left")
        assert traj[branch].positions[-1, 0, 0] == pytest.approx(-0.013, abs=1e-12)
        deepest = min(bif.gap(p, radius)[0].min() for p in traj[branch].positions)
        assert deepest > -0.005 * radius[0]
    mirror = traj["right"].positions * np.array([1.0, -1.0, 1.0])
    assert np.abs(mirror - traj["left"].positions).max() < 1e-9


@pytest.mark.parametrize("build, words", [
    (lambda: BaseAdvance(distance=-0.01), "advance.distance=-0.01 is invalid"),
    (lambda: BaseAdvance(distance=0.01, start=-1.0), "advance.start=-1.0 is invalid"),
    (lambda: BaseAdvance(distance=0.01, ramp=0.0), "advance.ramp=0.0 is invalid"),
    (lambda: BaseAdvance(distance=float("nan")), "advance.distance=nan is invalid"),
    (lambda: BaseAdvance(distance=True), "advance.distance=True is invalid"),
    (lambda: ManipulatorSpec(advance=0.01), "advance=0.01 is invalid: a softrnn.magnetics.BaseAdvance"),
    (lambda: ManipulatorSpec(advance=BaseAdvance(distance=0.2)), "when fully advanced"),
])
def test_bad_advances_are_refused_in_one_line(build, words):
    with pytest.raises(SoftrnnInputError) as err:
        build()
    assert "\n" not in str(err.value) and words in str(err.value), str(err.value)


def test_softrnn_magnetic_navigate_advances_the_base(tmp_path, capsys):
    """``--advance MM``: the base advances MM mm from a quarter of the run over half of it."""
    from softrnn.io import read_dataset

    from helpers import run_cli

    path = tmp_path / "left.h5"
    assert run_cli(["magnetic", "navigate", "-o", str(path), "--advance", "12", "--duration", "1.2", "--quiet"]) == 0
    assert "in the left branch (steered: left, base advanced 12 mm" in capsys.readouterr().out
    data = read_dataset(path)
    assert data.attrs["tip_branch"] == "left" and data.attrs["advance_m"] == 0.012
    assert data.positions[-1, 0, 0] == pytest.approx(-0.013, abs=1e-7)          # stored as float32
    assert run_cli(["magnetic", "navigate", "-o", str(path), "--advance", "30", "--overwrite"]) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and "--advance=30.0 is invalid" in err
