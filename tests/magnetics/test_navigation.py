"""The magnetic manipulator in a vessel (``ManipulatorSpec.contact``) and steered at a bifurcation
(``softrnn.magnetics.navigation``): a field across the trunk toward the left branch puts the tip in
the left branch, the mirrored field in the right one (mirror images of each other), and without a
field the tip stays on the symmetry plane at the junction; the rod never sinks 0.5 % of its radius
into a wall. A spec without contact runs exactly as before; ``softrnn magnetic navigate`` stores a
run as a dataset with its obstacles and currents; nonsense input is refused in one line."""

import math

import numpy as np
import pytest

from softrnn.errors import SoftrnnInputError
from softrnn.io import read_dataset
from softrnn.magnetics.manipulator import ManipulatorRun, ManipulatorSpec, currents_for_field, simulate_manipulator
from softrnn.magnetics.navigation import (
    DEMO_FIELD,
    demo_bifurcation,
    navigate,
    navigation_spec,
    steering_field,
    tip_branch,
)
from softrnn.magnetics.stepper import ManipulatorStepper
from softrnn.rod import Bifurcation, Contact, Vessel

from helpers import run_cli

RUN = dict(ramp=0.4, hold=0.3, dt=0.01, settle=0.2)   # 0.7 s: the tip settles in its branch in 0.6 s
PENETRATION_TOL = 0.005                              # of the rod radius


@pytest.fixture(scope="module")
def runs():
    spec = navigation_spec()
    return spec, {branch: navigate(branch, spec=spec, **RUN) for branch in ("left", "right", "none")}


def test_the_field_steers_the_tip_into_the_chosen_branch(runs):
    """15 mT across the trunk toward +y (left) or -y (right): the tip ends inside that branch's
    tube and outside the other's, 3 mm to that side, turned 10 degrees or more toward it, with
    the rod pressed on the trunk's wall; the two runs are mirror images (y -> -y) to 1e-9 m."""
    spec, traj = runs
    bif = spec.contact.obstacles[0]
    r = 0.5 * spec.diameter
    for branch, side in (("left", 1.0), ("right", -1.0)):
        tip = traj[branch].positions[-1, -1]
        assert tip_branch(bif, tip) == branch and tip_branch(bif, tip, r) == branch
        assert side * tip[1] > 0.0028
        d = traj[branch].positions[-1, -1] - traj[branch].positions[-1, -2]
        assert side * math.degrees(math.atan2(d[1], d[0])) > 10.0
        assert np.abs(traj[branch].rod.contact_forces[-1]).max() > 1e-3        # pressed on a wall
        assert np.allclose(traj[branch].fields[-1, :, 1], side * DEMO_FIELD, rtol=0.01)
    mirror = traj["right"].positions * np.array([1.0, -1.0, 1.0])
    assert np.abs(mirror - traj["left"].positions).max() < 1e-9


def test_without_a_field_the_tip_stays_at_the_junction_between_the_branches(runs):
    """The control: zero currents, the rod sags onto the trunk's floor and its tip, 5 mm past the
    junction, stays on the symmetry plane y = 0, inside both tubes (neither branch chosen)."""
    spec, traj = runs
    tip = traj["none"].positions[-1, -1]
    assert tip_branch(spec.contact.obstacles[0], tip) == "trunk"
    assert abs(tip[1]) < 1e-12 and tip[0] > 0.02
    assert np.all(traj["none"].currents == 0)


def test_the_rod_stays_inside_the_vessel(runs):
    spec, traj = runs
    bif = spec.contact.obstacles[0]
    radius = np.full(spec.n_nodes, 0.5 * spec.diameter)
    for t in traj.values():
        deepest = min(bif.gap(p, radius)[0].min() for p in t.positions)
        assert deepest > -PENETRATION_TOL * radius[0]


def test_the_frame_by_frame_stepper_carries_the_contact_too():
    """``ManipulatorStepper`` on the same spec: the currents for the left branch, ramped over 0.5 s
    of 30 Hz frames and held, put the tip in the left branch as ``navigate`` does (within 0.1 mm)."""
    spec = navigation_spec()
    currents = currents_for_field(spec.coils, (0.0, 0.0, 0.0), steering_field(spec.contact.obstacles[0], "left"))
    stepper = ManipulatorStepper(spec, 1 / 30, np.zeros(6), settle=0.2)
    for k in range(30):
        stepper.step(currents * min(1.0, k / 15))
    tip = stepper.positions[-1]
    assert tip_branch(spec.contact.obstacles[0], tip) == "left"
    assert tip == pytest.approx([0.02475, 0.00309, -0.00091], abs=1e-4)


def test_a_spec_without_contact_runs_as_before_and_far_obstacles_change_nothing():
    """The contact code is inert where nothing is touched: a vessel far wider than the rod's reach
    gives bit-identical positions to the run without contact."""
    spec = ManipulatorSpec()
    wide = ManipulatorSpec(contact=Contact(obstacles=Vessel([[-0.2, 0.0, 0.0], [0.2, 0.0, 0.0]], 0.1)))
    run = ManipulatorRun(dt=0.01, n_samples=11, substeps=4000)
    currents = np.tile([1.0, -1.0, 0.5, 0.0, 2.0, -2.0], (11, 1))
    a, b = simulate_manipulator(spec, currents, run), simulate_manipulator(wide, currents, run)
    assert np.array_equal(a.positions, b.positions) and a.rod.contact_forces is None
    assert np.array_equal(b.rod.contact_forces, np.zeros_like(b.rod.contact_forces))


def test_softrnn_magnetic_navigate_stores_the_run_with_its_obstacles_and_currents(tmp_path, capsys):
    path = tmp_path / "right.h5"
    assert run_cli(["magnetic", "navigate", "-o", str(path), "--branch", "right", "--duration", "0.6",
                    "--quiet"]) == 0
    assert "in the right branch (steered: right" in capsys.readouterr().out
    data = read_dataset(path)
    assert data.has_contact and data.contact["obstacles"][0]["kind"] == "bifurcation"
    assert data.actuation_units == {f"coil_{k}": "A" for k in range(6)}
    assert np.allclose(np.abs(data.actuation[-1]), [0, 5, 5, 0, 5, 5], atol=1e-5)
    assert data.attrs["tip_branch"] == "right" and data.attrs["branch"] == "right" and data.n_samples == 61
    assert run_cli(["magnetic", "navigate", "-o", str(path), "--duration", "0"]) == 2
    assert "--duration=0.0 is invalid" in capsys.readouterr().err


@pytest.mark.parametrize("build, words", [
    (lambda: ManipulatorSpec(contact="vessel"), "contact="),
    (lambda: navigate("up"), "branch="),
    (lambda: steering_field(demo_bifurcation(), "left", -0.01), "field="),
    (lambda: navigate("left", spec=ManipulatorSpec()), "spec.contact="),
    (lambda: navigation_spec(demo_bifurcation(radius=0.0012)), "contact.obstacles[0].radius"),
    (lambda: navigation_spec(Bifurcation([[-0.05, 0, 0], [0.0, 0, 0]], [[0.03, 0.01, 0]], [[0.03, -0.01, 0]],
                                         0.0035)), "inside obstacle 0"),
])
def test_nonsense_is_refused_in_one_line(build, words):
    with pytest.raises(SoftrnnInputError) as err:
        build()
    assert "\n" not in str(err.value) and words in str(err.value)
