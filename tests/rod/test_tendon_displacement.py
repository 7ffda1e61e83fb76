"""Tendons driven by a displacement (a position-controlled servo through a series stiffness k) in
the dynamic simulator: the tension k max(0, q - (l_0 - l)) follows the rod's configuration.

Closed form: a straight tendon at the offset r on a straight, weightless, free rod, terminated at
the arc length L_e, bends every segment to the curvature kappa = tau r / (E I) and compresses it by
tau / (E A), so its discrete path shortens by exactly L_e (r kappa + tau / (E A)) and
tau = k q / (1 + k L_e (r^2 / (E I) + 1 / (E A))). The damped rod comes to rest there; a slack
(paid-out) tendon leaves the rod unloaded; a displacement chosen to give the tension tau rests where
the tension tau does; undamped, the rod's energy plus the spring's is conserved; a two-segment
robot rests on the static solution; the tension and the displacement reach a dataset."""

import dataclasses
import re

import h5py
import numpy as np
import pytest

from softrnn.errors import SoftrnnInputError
from softrnn.rod import (
    Clamp,
    Damping,
    RodSpec,
    RunConfig,
    Scalar,
    Setup,
    Simulator,
    Sinusoid,
    Tendon,
    simulate,
    simulate_batch,
    straight,
)
from softrnn.rod.discrete import segment_strains
from softrnn.rod.tendons import routing_arrays, tendon_actuation, tendon_energy, tendon_lengths, tension_matrix
from softrnn.scenarios.scenario import load_scenario, parse_scenario
from softrnn.scenarios.summary import simulate_summary
from softrnn.statics import StaticLoads, StaticRod, solve

L, RADIUS, E, RHO, NU = 0.2, 0.01, 1e7, 1000.0, 0.5
EI = E * np.pi * RADIUS**4 / 4
EA = E * np.pi * RADIUS**2
N_NODES = 11
OFFSET = 0.008                      # m
K_SPRING = 2000.0                   # N/m
Q = 0.002                           # m pulled in
REST_TOL = 1e-7                     # settled: last two samples' largest move / L
CLOSED_RTOL = 1e-5                  # rest state against the closed form
AGREEMENT_TOL = 1e-3                # dynamic rest state vs static solution: max node distance / L
ANGLES = np.radians([0.0, 120.0, 240.0])


def rod_spec(n=N_NODES):
    return RodSpec(length=L, radius=RADIUS, youngs_modulus=E, density=RHO, n_nodes=n, poisson_ratio=NU)


def setup(tendons, gravity=(0.0, 0.0, 0.0), damping=None, n=N_NODES):
    """A cantilever along +x (d1 = +z), heavily damped (default) so it settles in 0.5 s."""
    damping = Damping(translational=30.0, rotational=1e-3) if damping is None else damping
    return Setup(rod=rod_spec(n), reference=straight(n, L, direction=(1, 0, 0), normal=(0, 0, 1)),
                 boundary=(Clamp(0),), damping=damping, gravity=gravity, tendons=tuple(tendons))


def settle(s, seconds=0.6, integrator="explicit"):
    sim = Simulator(s)
    traj = sim.run(RunConfig(dt=0.05, n_samples=int(round(seconds / 0.05)) + 1, integrator=integrator))
    assert np.abs(traj.positions[-1] - traj.positions[-2]).max() < REST_TOL * L  # at rest
    return sim, traj


def closed_form_tension(k, q, r, length):
    return k * q / (1.0 + k * length * (r**2 / EI + 1.0 / EA))


# --------------------------------------------------------------------------- closed form
@pytest.mark.parametrize("k, end_node", [(K_SPRING, None), (2e5, None), (K_SPRING, 6)])
@pytest.mark.parametrize("integrator", ["explicit", "implicit"])
def test_a_displaced_tendon_rests_at_the_closed_form(k, end_node, integrator):
    """Every routed segment's curvature is tau r / (E I) with tau = k q / (1 + k L_e (r^2/(EI) +
    1/(EA))), the segments beyond the termination stay straight, and the recorded tension is tau."""
    s = setup([Tendon(name="t", offset=(OFFSET, 0.0), displacement=Q, stiffness=k, end_node=end_node)])
    sim, traj = settle(s, integrator=integrator)
    e = N_NODES - 1 if end_node is None else end_node
    tau = closed_form_tension(k, Q, OFFSET, e * s.rod.segment_length)
    K, G = segment_strains(sim.state.rotations, sim.state.positions, s.rod.segment_length)
    np.testing.assert_allclose(K[:e, 1], tau * OFFSET / EI, rtol=CLOSED_RTOL)   # about d2: toward +d1
    np.testing.assert_allclose(np.linalg.norm(K[:, [0, 2]], axis=1), 0.0, atol=1e-9)
    np.testing.assert_allclose(K[e:], 0.0, atol=1e-9 * tau * OFFSET / EI)
    np.testing.assert_allclose(G[:e, 2], 1.0 - tau / EA, rtol=1e-9)
    np.testing.assert_allclose(traj.tendon_tensions[-1], [tau], rtol=CLOSED_RTOL)
    # the path shortening is L_e (r kappa + tau / (E A)): the rest of the pull-in stretches the spring
    route, ends = routing_arrays(s.tendons, N_NODES, s.rod.segment_length)
    length = tendon_lengths(sim.state.rotations, sim.state.positions, s.rod.segment_length, route, ends)[0]
    shortening = e * s.rod.segment_length - length
    np.testing.assert_allclose(shortening, Q - tau / k, rtol=1e-9)


def test_a_stiffer_spring_approaches_the_kinematic_pull():
    """The stiffer the spring, the closer r kappa L + tau L / (E A) comes to the pull-in q."""
    gaps = []
    for k in (1e3, 1e4, 1e5):
        sim, traj = settle(setup([Tendon(name="t", offset=(OFFSET, 0.0), displacement=Q, stiffness=k)]))
        tau = traj.tendon_tensions[-1, 0]
        K, _ = segment_strains(sim.state.rotations, sim.state.positions, sim.seg_length)
        kappa = np.linalg.norm(K, axis=1).mean()
        gaps.append((Q - L * (OFFSET * kappa + tau / EA)) / Q)
        np.testing.assert_allclose(gaps[-1], tau / k / Q, rtol=1e-5)      # the spring's stretch
    assert gaps[0] > gaps[1] > gaps[2] > 0 and gaps[2] < 0.05


# --------------------------------------------------------------------------- slack
def test_a_paid_out_tendon_leaves_the_rod_unloaded():
    """A negative displacement (and one that turns negative) leaves the tendon slack: zero tension,
    the same trajectory as without tendons, bit for bit."""
    slack = [Tendon(name="a", offset=(OFFSET, 0.0), displacement=-0.001, stiffness=K_SPRING),
             Tendon(name="b", offset=(0.0, OFFSET), stiffness=K_SPRING,
                    displacement=Scalar(Sinusoid((0.001, 0, 0), 2.0, offset=(-0.002, 0, 0))))]
    g = (0.0, 0.0, -9.81)
    cfg = RunConfig(dt=0.01, n_samples=6)
    with_slack, without = simulate(setup(slack, g), cfg), simulate(setup([], g), cfg)
    np.testing.assert_array_equal(with_slack.positions, without.positions)
    np.testing.assert_array_equal(with_slack.quaternions, without.quaternions)
    assert with_slack.tendon_tensions.shape == (6, 2) and np.all(with_slack.tendon_tensions == 0.0)
    assert without.tendon_tensions is None


# --------------------------------------------------------------------------- = a tension tendon
def test_the_displacement_for_a_tension_rests_where_the_tension_does():
    """With gravity: pull a tendon with the tension tau, read its path shortening at rest, drive it
    instead by q = tau / k + shortening: it rests at the same shape with the tension tau."""
    tau = 1.5
    tension = Tendon(name="t", offset=(0.0, OFFSET), tension=tau)
    g = (0.0, 0.0, -9.81)
    sim, traj = settle(setup([tension], g))
    route, ends = routing_arrays((tension,), N_NODES, sim.seg_length)
    shortening = L - tendon_lengths(sim.state.rotations, sim.state.positions, sim.seg_length, route, ends)[0]
    moved = Tendon(name="t", offset=(0.0, OFFSET), displacement=tau / K_SPRING + shortening, stiffness=K_SPRING)
    _, traj2 = settle(setup([moved], g))
    np.testing.assert_allclose(traj2.positions[-1], traj.positions[-1], atol=1e-7 * L)
    np.testing.assert_allclose(traj2.tendon_tensions[-1], [tau], rtol=1e-6)
    assert np.linalg.norm(traj.positions[-1, -1, 1:]) > 0.03 * L   # deflected


# --------------------------------------------------------------------------- energy
def _undamped(displacement):
    return setup([Tendon(name="t", offset=(OFFSET, 0.0), displacement=displacement, stiffness=K_SPRING)],
                 damping=Damping(), n=21)


def test_a_constant_displacement_conserves_the_energy_with_the_spring():
    """No damping, no gravity, the servo steps to q on the straight rod: the rod swings about its
    bent rest shape. Kinetic + elastic + the spring's tau^2 / (2 k) stays constant to the
    integrator's second order, while kinetic + elastic alone swings by all of the energy converted;
    the tension swings about its rest value."""
    s = _undamped(0.004)
    spread = []
    for substeps in (40, 80):
        traj = simulate(s, RunConfig(dt=0.002, n_samples=151, substeps=substeps))
        potential, work = tendon_energy(s, traj)
        rod_energy = traj.energy.sum(axis=1)
        converted = np.ptp(rod_energy)
        assert rod_energy.max() > 10 * abs(rod_energy[0])
        np.testing.assert_allclose(potential[0], 0.5 * K_SPRING * 0.004**2, rtol=1e-9)   # straight: l = l_0
        spread.append(np.ptp(rod_energy + potential) / converted)
        tau = traj.tendon_tensions[:, 0]
        np.testing.assert_allclose(potential, 0.5 * tau**2 / K_SPRING, rtol=1e-6)
        np.testing.assert_allclose(work, potential[0] - potential, atol=2e-3 * converted)
        rest = closed_form_tension(K_SPRING, 0.004, OFFSET, L)
        assert tau.min() < rest < tau.max()
    assert spread[0] < 5e-3, spread
    assert spread[0] / spread[1] > 3.0, spread      # second order


def test_a_varying_displacement_balances_the_tendons_work():
    s = _undamped(Scalar(Sinusoid((0.002, 0, 0), 3.0, offset=(0.002, 0, 0))))
    traj = simulate(s, RunConfig(dt=0.001, n_samples=301))
    _, work = tendon_energy(s, traj)
    balance = traj.energy.sum(axis=1) - work
    assert np.ptp(work) > 0.0
    assert np.ptp(balance) < 1e-2 * np.ptp(work), np.ptp(balance) / np.ptp(work)


# --------------------------------------------------------------------------- robots of segments
def _robot(qs, n=21):
    """Two segments, three tendons 120 deg apart each: segment 1's end at node n // 2 (0.1 m),
    segment 2's (turned by 60 deg) at the tip."""
    tendons = []
    for seg, (end, turn) in enumerate(((n // 2, 0.0), (n - 1, np.pi / 3))):
        for i, a in enumerate(ANGLES + turn):
            tendons.append(Tendon(name=f"s{seg + 1}{'abc'[i]}", offset=(OFFSET * np.cos(a), OFFSET * np.sin(a)),
                                  displacement=qs[3 * seg + i], stiffness=K_SPRING, end_node=end))
    return tendons


def test_a_segment_tendon_bends_only_its_segment():
    """Segment 1's tendon pulled in, every other tendon paid out (slack): segment 1 bends to the
    closed form over L_e = L/2, segment 2 stays straight."""
    n = 21
    sim, traj = settle(setup(_robot([Q, -0.003, -0.003, -0.003, -0.003, -0.003], n), n=n))
    tau = closed_form_tension(K_SPRING, Q, OFFSET, L / 2)
    K, _ = segment_strains(sim.state.rotations, sim.state.positions, sim.seg_length)
    np.testing.assert_allclose(np.linalg.norm(K[:10], axis=1), tau * OFFSET / EI, rtol=CLOSED_RTOL)
    np.testing.assert_allclose(K[10:], 0.0, atol=1e-8)
    np.testing.assert_allclose(traj.tendon_tensions[-1], [tau, 0, 0, 0, 0, 0], rtol=CLOSED_RTOL, atol=1e-12)


@pytest.mark.parametrize("integrator", ["explicit", "implicit"])
def test_a_two_segment_robot_rests_on_the_static_solution(integrator):
    """Six tendons with gravity, all pulled in by different amounts: every node within 0.1 % of L
    of the static solution and the tensions within 1 %."""
    n = 21
    qs = [0.003, 0.0, 0.001, 0.0015, 0.0005, 0.0]
    g = (0.0, 0.0, -9.81)
    sim, traj = settle(setup(_robot(qs, n), g, n=n), seconds=1.0, integrator=integrator)
    static = [dataclasses.replace(td, end_node=None, end_s=td.end_node * L / (n - 1)) for td in _robot(qs, n)]
    sol = solve(StaticRod(length=L, radius=RADIUS, youngs_modulus=E, density=RHO, poisson_ratio=NU, gravity=g,
                          tendons=tuple(static)), n_steps=n - 1, tol=1e-10).raise_for_status()
    gap = np.linalg.norm(traj.positions[-1] - sol.positions, axis=1).max() / L
    assert gap < AGREEMENT_TOL, gap
    np.testing.assert_allclose(traj.tendon_tensions[-1], sol.tendon_tensions, rtol=1e-2, atol=1e-3)
    assert np.count_nonzero(sol.tendon_tensions > 0.1) >= 3


# --------------------------------------------------------------------------- batch, dataset
def test_a_batch_gives_each_rod_its_own_tensions():
    cfg = RunConfig(dt=0.01, n_samples=6)
    setups = [setup([Tendon(name="t", offset=(OFFSET, 0.0), displacement=q, stiffness=K_SPRING)]) for q in (Q, 2 * Q)]
    batch = simulate_batch(setups, cfg)
    for s, traj in zip(setups, batch):
        one = simulate(s, cfg)
        np.testing.assert_allclose(traj.positions, one.positions, rtol=0, atol=1e-12)
        np.testing.assert_allclose(traj.tendon_tensions, one.tendon_tensions, rtol=1e-12)
    assert batch[1].tendon_tensions[-1, 0] > 1.5 * batch[0].tendon_tensions[-1, 0] > 0
    with pytest.raises(SoftrnnInputError, match="driven as in setups"):
        simulate_batch([setups[0], setup([Tendon(name="t", offset=(OFFSET, 0.0), tension=1.0)])], cfg)


SCENARIO = """
format = 1
name = "servo-test"
[rod]
length = 0.2
radius = 0.01
youngs_modulus = 1e7
density = 1000.0
n_nodes = 11
[reference]
kind = "straight"
[[boundary]]
kind = "clamp"
node = 0
[[tendons]]
name = "top"
offset = [0.008, 0.0]
displacement = { kind = "sinusoid", offset = 0.002, amplitude = 0.001, frequency = 2.0, ramp = 0.02 }
stiffness = 2000.0
[[tendons]]
name = "side"
offset = [0.0, 0.005]
tension = { kind = "constant", value = 0.5 }
[run]
dt = 0.002
n_samples = 26
nodes_of_interest = [-1]
"""


def test_a_scenario_writes_the_tension_and_the_displacement_as_actuation(tmp_path):
    sc = parse_scenario(SCENARIO)
    top, side = sc.setup.tendons
    assert top.stiffness == 2000.0 and top.tension is None and side.displacement is None
    path = tmp_path / "run.h5"
    simulate_summary(name=sc.name, title=sc.title, setup=sc.setup, config=sc.config, node=-1, out_path=path)
    traj = simulate(sc.setup, sc.config)
    with h5py.File(path) as f:
        act, time = f["actuation"][()], f["time"][()]
        names, units = f["actuation"].attrs["names"], f["actuation"].attrs["units"]
    assert names == '["tendon_top", "tendon_side", "tendon_top_displacement"]' and units == '["N", "N", "m"]'
    values, channels = tendon_actuation(sc.setup.tendons, time, traj.tendon_tensions)
    assert list(channels) == ["tendon_top", "tendon_side", "tendon_top_displacement"]
    np.testing.assert_allclose(act, values, rtol=1e-6, atol=1e-9)  # float32 in the file
    np.testing.assert_allclose(act[:, 2], top.displacements(time), rtol=1e-6, atol=1e-9)
    np.testing.assert_allclose(act[:, 1], 0.5)
    assert act[0, 0] == 0.0 and act[-1, 0] > 1.0     # the tension follows the pull-in
    with pytest.raises(SoftrnnInputError, match="driven by a displacement.*Trajectory.tendon_tensions"):
        tension_matrix(sc.setup.tendons, time)


def test_the_shipped_servo_arm_runs():
    sc = load_scenario("tendon-displacement")
    assert all(td.displacement_controlled and td.stiffness == 2000.0 for td in sc.setup.tendons)
    traj = simulate(sc.setup, RunConfig(dt=sc.config.dt, n_samples=301, save_nodes=sc.nodes_of_interest))
    assert traj.tendon_tensions.shape == (301, 3) and traj.tendon_tensions.max() > 0.1
    assert np.all(traj.tendon_tensions >= 0)
    assert np.linalg.norm(traj.positions[-1, 0, :2]) > 1e-3      # the tip moves sideways


# --------------------------------------------------------------------------- bad inputs
@pytest.mark.parametrize("kwargs, match", [
    (dict(tension=1.0, displacement=0.001, stiffness=1e3), r"tension=1.0 is invalid: .*not both"),
    (dict(displacement=0.001), r"stiffness=None is invalid: a finite series stiffness > 0 in N/m"),
    (dict(displacement=0.001, stiffness=0.0), r"stiffness=0.0 is invalid"),
    (dict(displacement=0.001, stiffness=-5.0), r"stiffness=-5.0 is invalid"),
    (dict(displacement=0.001, stiffness=float("inf")), r"stiffness=inf is invalid"),
    (dict(displacement=float("nan"), stiffness=1e3), r"displacement=nan is invalid: a finite length"),
    (dict(displacement="1 mm", stiffness=1e3), r"displacement='1 mm' is invalid"),
    (dict(tension=1.0, stiffness=1e3), r"stiffness=1000.0 is invalid: no stiffness for a tendon pulled"),
])
def test_bad_displacement_tendons_are_refused_in_one_line(kwargs, match):
    with pytest.raises(SoftrnnInputError, match=match) as err:
        Tendon(name="t", offset=(0.0, 0.0), **kwargs)
    assert "\n" not in str(err.value)


def test_a_displacement_profile_of_the_wrong_shape_is_refused():
    td = Tendon(name="t", offset=(0.0, 0.0), displacement=lambda t: np.zeros((len(t), 3)), stiffness=1e3)
    with pytest.raises(SoftrnnInputError, match="displacement.*profile t \\(K,\\) -> \\(K,\\) in m"):
        td.displacements(np.zeros(4))
    with pytest.raises(SoftrnnInputError, match="driven by a displacement"):
        td.tensions(np.zeros(4))
    clash = [Tendon(name="a", offset=(0.0, 0.0), displacement=0.001, stiffness=1e3),
             Tendon(name="a_displacement", offset=(0.0, 0.0), tension=1.0)]
    with pytest.raises(SoftrnnInputError, match="actuation channel 'tendon_a_displacement'"):
        setup(clash)
    with pytest.raises(SoftrnnInputError, match="tendon_displacements"):
        StaticLoads(tendon_displacements=(float("nan"),))


@pytest.mark.parametrize("old, new, key", [
    ('stiffness = 2000.0\n', '', "missing key 'tendons.0.stiffness'"),
    ('stiffness = 2000.0', 'stiffness = -5.0',
     "tendons.0.stiffness = -5.0 is invalid: expected a positive number in N/m"),
    ('stiffness = 2000.0', 'stiffness = 2000.0\ntension = { kind = "constant", value = 1.0 }',
     "tendons.0: give tension or displacement, not both"),
    ('value = 0.5 }', 'value = 0.5 }\nstiffness = 100.0',
     "tendons.1.stiffness: only a tendon driven by a displacement"),
    ('displacement = { kind = "sinusoid", offset = 0.002, amplitude = 0.001, frequency = 2.0, ramp = 0.02 }',
     'displacement = "2 mm"', "tendons.0.displacement = '2 mm' is invalid"),
    ('kind = "sinusoid", offset = 0.002', 'kind = "ramp", offset = 0.002', "tendons.0.displacement.kind"),
    ('amplitude = 0.001, frequency', 'amplitud = 0.001, frequency', "unknown key 'tendons.0.displacement.amplitud'"),
])
def test_bad_displacement_entries_in_a_scenario_name_the_key(old, new, key):
    text = SCENARIO.replace(old, new, 1)
    assert text != SCENARIO
    with pytest.raises(SoftrnnInputError, match=re.escape(key)) as err:
        parse_scenario(text)
    assert "\n" not in str(err.value)


def test_a_constant_displacement_in_a_scenario():
    text = SCENARIO.replace('{ kind = "sinusoid", offset = 0.002, amplitude = 0.001, frequency = 2.0, ramp = 0.02 }',
                            "-0.001")
    top = parse_scenario(text).setup.tendons[0]
    assert top.displacement == -0.001 and top.displacements(np.zeros(2)).tolist() == [-0.001, -0.001]
