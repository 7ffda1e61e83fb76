"""Insertion and rotation at the hub (``softrnn.rod.hub``): a prescribed hub moves its node exactly
along the axis and turns its frame exactly about it; a straight rod's tip twists with a slowly
turned hub; a hub pushed by a force accelerates a free rod as F / (m_rod + m_hub) and one twisted by
a torque spins it as T / J_total; commanded inputs keep the motion continuous and equal the same
table run; nonsense is refused in one line."""

import math

import numpy as np
import pytest

from softrnn.errors import SoftrnnInputError
from softrnn.rod import Damping, RodSpec, RunConfig, Setup, Simulator, simulate_batch, straight
from softrnn.rod.hub import Commanded, Hub, HubTable, axis_rotation

N = 11
LENGTH = 0.2
ROD = RodSpec(length=LENGTH, radius=0.001, youngs_modulus=1e7, density=1000.0, n_nodes=N, poisson_ratio=0.3)
AXIS = np.array([1.0, 0.0, 0.0])
REF = straight(N, LENGTH, origin=(0.0, 0.0, 0.0), direction=tuple(AXIS), normal=(0.0, 0.0, 1.0))


def _hub(**inputs) -> Hub:
    return Hub(entry=(0.0, 0.0, 0.0), axis=tuple(AXIS), rotation0=REF.rotations[0], **inputs)


def _setup(hub: Hub, **kw) -> Setup:
    return Setup(rod=ROD, reference=REF, boundary=(hub.clamp(0),), **kw)


def test_a_prescribed_hub_moves_its_node_exactly_along_the_axis_and_turns_its_frame_about_it():
    insertion = ([0.0, 0.05, 0.1], [0.0, 0.004, 0.01])
    rotation = ([0.0, 0.1], [0.0, 1.2])
    hub = _hub(insertion=insertion, rotation=rotation)
    traj = Simulator(_setup(hub, damping=Damping(translational=0.05))).run(RunConfig(dt=0.01, n_samples=13))
    d = np.interp(traj.time, *insertion)
    np.testing.assert_allclose(traj.positions[:, 0], d[:, None] * AXIS, rtol=0, atol=1e-15)
    assert traj.positions[-1, 0, 0] == pytest.approx(0.01, abs=1e-15)        # held after the table
    expected = axis_rotation(AXIS, np.interp(traj.time, *rotation)) @ REF.rotations[0]
    np.testing.assert_allclose(traj.rotations()[:, 0], expected, rtol=0, atol=1e-12)
    np.testing.assert_allclose(hub.twist_angle(traj.rotations()[:, 0]), np.interp(traj.time, *rotation), atol=1e-12)


def test_a_straight_rods_tip_twists_with_a_slowly_turned_hub():
    """Turned a quarter turn over 0.4 s (its first torsional mode is near 80 Hz): the tip follows."""
    from softrnn.rod.loads import Constant, Scheduled
    from softrnn.rod.tendons import Scalar

    turn = Scalar(Scheduled(Constant((0.5 * math.pi, 0.0, 0.0)), ramp=0.4))
    hub = _hub(rotation=turn)
    setup = _setup(hub, damping=Damping(translational=0.01, rotational=1e-9))
    traj = Simulator(setup).run(RunConfig(dt=0.02, n_samples=31, save_nodes=(0, N - 1)))
    tip = hub.twist_angle(traj.rotations()[:, 1])
    base = hub.twist_angle(traj.rotations()[:, 0])
    np.testing.assert_allclose(base, turn(traj.time), atol=1e-12)
    assert np.abs(tip - base).max() < 0.01 * 0.5 * math.pi and tip[-1] == pytest.approx(0.5 * math.pi, abs=1e-3)
    np.testing.assert_allclose(traj.positions[:, 1], np.broadcast_to(REF.positions[-1], (31, 3)), atol=1e-9)


def test_a_pushed_hub_accelerates_a_free_rod_as_force_over_total_mass():
    """An axial force F on a hub of mass M holding node 0 of a free rod: the centre of mass of rod
    and hub moves F t^2 / (2 (m_rod + M)) along the axis, exactly (the explicit step conserves
    momentum and starts with the half kick); the reaction across the axis is 0 on a straight rod."""
    F, M = 0.01, 0.002
    hub = _hub(force=F, mass=M)
    sim = Simulator(_setup(hub))
    m_rod = ROD.density * math.pi * ROD.radius ** 2 * LENGTH
    assert sim.mass.sum() == pytest.approx(m_rod + M, rel=1e-12) and sim.kind[0] == 3
    traj = sim.run(RunConfig(dt=0.004, n_samples=26))
    com = (traj.positions[..., 0] * sim.mass).sum(axis=1) / sim.mass.sum()
    expected = F * traj.time ** 2 / (2 * (m_rod + M))
    np.testing.assert_allclose(com - com[0], expected, rtol=1e-9, atol=1e-15)
    assert expected[-1] > 0.05 * LENGTH                                      # it really moved
    np.testing.assert_allclose(traj.positions[:, 0, 1:], 0.0, atol=1e-15)   # held across the axis
    np.testing.assert_allclose(traj.forces[:, 0], np.broadcast_to(F * AXIS, (26, 3)), atol=1e-15)
    assert np.abs(traj.reaction_forces[:, 0]).max() < 1e-9 * F


def test_a_twisted_hub_spins_a_straight_rod_as_torque_over_total_inertia():
    """A torque T on a hub of axial inertia J_hub: the rod and hub turn about the axis with
    sum(J_a theta_a) = T t^2 / 2 (J_a the nodes' polar inertias, the hub's added to node 0), to the
    Cayley map's O((h omega)^2); position held."""
    T, J_hub = 5e-7, 1e-9
    hub = _hub(torque=T, inertia=J_hub)
    sim = Simulator(_setup(hub))
    J = sim.inertia[:, 2]
    J_rod = ROD.density * 0.5 * math.pi * ROD.radius ** 4 * LENGTH
    assert J.sum() == pytest.approx(J_rod + J_hub, rel=1e-9) and sim.kind[0] == 4
    traj = sim.run(RunConfig(dt=0.002, n_samples=21))
    theta = np.stack([hub.twist_angle(traj.rotations()[:, a]) for a in range(N)], axis=1)
    expected = T * traj.time ** 2 / 2 / J.sum()
    np.testing.assert_allclose((theta * J).sum(axis=1) / J.sum(), expected, rtol=1e-5, atol=1e-12)
    assert expected[-1] > 0.1                                                 # a tenth of a radian at least
    np.testing.assert_allclose(traj.positions[:, 0], 0.0, atol=1e-15)


def test_a_driven_hub_runs_in_a_batch_as_alone():
    hub = _hub(force=0.01, mass=0.002, torque=1e-7)
    config = RunConfig(dt=0.002, n_samples=6)
    alone = Simulator(_setup(hub)).run(config)
    batch = simulate_batch([_setup(hub), _setup(hub)], config)
    np.testing.assert_allclose(batch[1].positions, alone.positions, rtol=0, atol=1e-15)
    assert Simulator(_setup(hub)).kind[0] == 5


def test_commanded_rates_keep_the_motion_continuous_and_equal_a_table():
    hub = Hub.commanded((0.0, 0.0, 0.0), tuple(AXIS), REF.rotations[0])
    sim = Simulator(_setup(hub))
    h = 5e-5
    for k, (rate, spin) in enumerate([(0.05, 1.0), (0.0, -2.0), (0.1, 0.0)]):
        hub.command(sim.state.time, insertion_rate=rate, rotation_rate=spin)
        sim.advance(400, h)
        assert sim.state.time == pytest.approx(0.02 * (k + 1), abs=1e-15)
    times = [0.0, 0.02, 0.04, 0.06]
    d, theta = [0.0, 0.001, 0.001, 0.003], [0.0, 0.02, -0.02, -0.02]
    np.testing.assert_allclose(hub.insertion(np.array(times)), d, atol=1e-15)
    np.testing.assert_allclose(hub.rotation(np.array(times)), theta, atol=1e-15)
    np.testing.assert_allclose(sim.state.positions[0], 0.003 * AXIS, atol=1e-15)
    table = Simulator(_setup(_hub(insertion=(times, d), rotation=(times, theta))))
    table.advance(1200, h)
    np.testing.assert_allclose(table.state.positions, sim.state.positions, rtol=0, atol=1e-12)


def test_a_ramp_command_reaches_its_target_and_a_later_command_replaces_its_plan():
    c = Commanded(0.5)
    c.ramp_to(1.0, 1.5, 2.0)
    np.testing.assert_allclose(c(np.array([0.0, 1.0, 2.0, 3.0, 9.0])), [0.5, 0.5, 1.0, 1.5, 1.5])
    c.rate(2.0, -1.0)                          # before the ramp ended: the hold is dropped
    assert c.at(2.5) == pytest.approx(0.5) and c.at(2.0) == pytest.approx(1.0)
    c.set(3.0, 7.0)
    assert c.at(2.9) == pytest.approx(0.1) and c.at(3.0) == 7.0


@pytest.mark.parametrize("build, words", [
    (lambda: _hub(insertion=([0.0, 1.0, 1.0], [0.0, 0.1, 0.2])), "Hub.insertion"),
    (lambda: _hub(rotation=([0.0, 1.0], [0.0, float("nan")])), "Hub.rotation"),
    (lambda: _hub(insertion=([0.0, float("inf")], [0.0, 0.1])), "strictly increasing"),
    (lambda: HubTable([0.0, -1.0], [0.0, 0.1]), "strictly increasing"),
    (lambda: HubTable([0.0, 1.0], [[0.0, 0.1]]), "HubTable.values"),
    (lambda: Hub(entry=(0.0, 0.0, 0.0), axis=(0.0, 0.0, 0.0)), "Hub.axis"),
    (lambda: _hub(insertion=0.1, force=1.0), "give insertion or force, not both"),
    (lambda: _hub(insertion=0.1, mass=1.0), "Hub.mass"),
    (lambda: Hub(entry=(0, 0, 0), axis=(0, 1, 0), rotation0=REF.rotations[0], torque=1e-6), "Hub.rotation0"),
    (lambda: _hub(rotation=lambda t: np.zeros((len(t), 3))), "Hub.rotation"),
    (lambda: _hub(insertion=0.1).command(0.0, insertion_rate=1.0), "insertion_rate=1.0 is invalid"),
    (lambda: Commanded().rate(float("nan"), 1.0), "t_now=nan"),
    (lambda: Simulator(_setup(_hub(force=1.0))).run(RunConfig(dt=0.01, n_samples=2, integrator="implicit")),
     "integrator='implicit' is invalid"),
    (lambda: Setup(rod=ROD, reference=REF, boundary=(_hub().clamp(0), _hub().clamp(-1))), "at most one hub"),
])
def test_bad_hubs_are_refused_in_one_line(build, words):
    with pytest.raises(SoftrnnInputError) as err:
        build()
    assert "\n" not in str(err.value) and words in str(err.value), str(err.value)


def test_commands_come_in_time_order():
    c = Commanded()
    c.rate(1.0, 0.1)
    with pytest.raises(SoftrnnInputError, match="t_now=0.5 is invalid"):
        c.rate(0.5, 0.2)


def test_a_hub_tells_its_inputs_and_measures_its_node():
    hub = Hub.commanded((0.0, 0.0, 0.0), tuple(AXIS), REF.rotations[0])
    hub.command(0.0, insertion_rate=0.1, rotation_rate=2.0)
    assert hub.at(0.5) == pytest.approx((0.05, 1.0), abs=1e-15)
    pos, rot = hub(np.array([0.5]))
    assert hub.measure(pos[0], rot[0]) == pytest.approx((0.05, 1.0), abs=1e-12)
    driven = _hub(force=1.0, rotation=0.3)
    assert math.isnan(driven.at(1.0)[0]) and driven.at(1.0)[1] == pytest.approx(0.3)
    assert driven.channels == {"hub_insertion": "m", "hub_rotation": "rad", "hub_force": "N"}


def test_a_commanded_driven_hub_takes_force_and_torque_commands():
    hub = Hub.commanded((0.0, 0.0, 0.0), tuple(AXIS), REF.rotations[0], pushed=True, twisted=True, mass=0.002,
                        inertia=1e-9)
    sim = Simulator(_setup(hub))
    sim.advance(100, 5e-5)
    np.testing.assert_allclose(sim.state.positions, REF.positions, atol=1e-15)     # no force yet: at rest
    hub.command(sim.state.time, force=0.01, torque=1e-7)
    sim.advance(400, 5e-5)
    d, theta = hub.measure(sim.state.positions[0], sim.state.rotations[0])
    assert d > 0 and theta > 0 and math.isnan(hub.at(sim.state.time)[0])
    with pytest.raises(SoftrnnInputError, match="insertion_rate=0.1 is invalid"):
        hub.command(sim.state.time, insertion_rate=0.1)


def test_a_commanded_insertion_stops_at_the_ends_of_its_travel_and_goes_on_from_there():
    hub = Hub.commanded((0.0, 0.0, 0.0), tuple(AXIS), REF.rotations[0], travel=0.01)
    assert hub.insertion.bounds == (0.0, 0.01) and hub.rotation.bounds is None
    hub.command(0.0, insertion_rate=0.02, rotation_rate=1.0)
    t = np.array([0.0, 0.25, 0.5, 1.0])
    np.testing.assert_array_equal(hub.insertion(t), np.clip(0.02 * t, 0.0, 0.01))   # stops at its end
    np.testing.assert_array_equal(hub.rotation(t), t)                                # the angle is free
    hub.command(1.0, insertion_rate=-0.01, rotation_rate=0.0)                        # from where it stopped
    np.testing.assert_array_equal(hub.insertion(np.array([1.0, 1.5, 9.0])), [0.01, 0.01 - 0.01 * 0.5, 0.0])
    pos, _ = hub(np.array([0.5, 9.0]))
    np.testing.assert_array_equal(pos, [[0.01, 0.0, 0.0], [0.0, 0.0, 0.0]])
    hub.reset_commands()                                                             # a new episode
    assert hub.at(5.0) == (0.0, 0.0)
    hub.command(0.0, insertion_rate=0.001, rotation_rate=0.0)
    assert hub.at(2.0) == pytest.approx((0.002, 0.0), abs=1e-18)


def test_a_bounded_command_refuses_targets_outside_its_bounds():
    c = Commanded(0.5, bounds=(0.0, 1.0))
    c.ramp_to(0.0, 1.0, 1.0)
    assert c.at(2.0) == 1.0
    for call, words in ((lambda: c.set(3.0, 1.5), "value=1.5 is invalid"),
                        (lambda: c.ramp_to(3.0, -0.1, 1.0), "target=-0.1 is invalid"),
                        (lambda: Commanded(2.0, bounds=(0.0, 1.0)), "Commanded.bounds"),
                        (lambda: Commanded(bounds=(0.0,)), "Commanded.bounds"),
                        (lambda: Hub.commanded((0.0, 0.0, 0.0), tuple(AXIS), travel=-0.1), "travel=-0.1 is invalid"),
                        (lambda: Hub.commanded((0.0, 0.0, 0.0), tuple(AXIS), pushed=True, travel=0.1), "travel")):
        with pytest.raises(SoftrnnInputError) as err:
            call()
        assert "\n" not in str(err.value) and words in str(err.value), str(err.value)
