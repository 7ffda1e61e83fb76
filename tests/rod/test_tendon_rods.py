"""Tendon-driven rods (Rucker & Webster 2011) in the dynamic simulator and the static solver: a
straight tendon bends a free rod to the constant curvature tau r / (E I); the damped dynamic rod
comes to rest on the static solution (a tendon with gravity, a helical tendon); a slack tendon
leaves the rod unloaded; the discrete tendon loads are the exact gradient of the discrete tendon
length; bad tendons are refused in one line; the tensions reach a dataset as actuation channels."""

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
    kernels,
    simulate,
    simulate_batch,
    straight,
)
from softrnn.rod.discrete import internal_loads, segment_strains, strain_energy
from softrnn.rod.lumped import frozen
from softrnn.rod.state import empty_samples
from softrnn.rod.tendons import (
    routing_arrays,
    tendon_actuation,
    tendon_energy,
    tendon_potential,
    tendon_resultants,
)
from softrnn.scenarios.scenario import parse_scenario
from softrnn.scenarios.summary import simulate_summary
from softrnn.statics import StaticLoads, StaticRod, solve

from helpers import fd_loads_of, random_deformed_rod, run_cli

L, RADIUS, E, RHO, NU = 0.2, 0.01, 1e7, 1000.0, 0.5
EI = E * np.pi * RADIUS**4 / 4
N_NODES = 21
OFFSET = 0.008                      # m, inside the 10 mm section
KAPPA = 5.0                         # 1/m: a tip angle of 1 rad
CURVATURE_RTOL = 1e-3               # against tau r / (E I)
AGREEMENT_TOL = 1e-3                # dynamic rest state vs static solution: max node distance / L
REST_TOL = 1e-6                     # settled: last two samples' largest move / L
GRADIENT_RTOL = 1e-6                # closed-form tendon loads vs finite differences (relative to max |load|)


def setup(tendons, gravity=(0.0, 0.0, 0.0), n=N_NODES):
    """A cantilever along +x (d1 = +z), heavily damped so it settles in 0.5 s."""
    rod = RodSpec(length=L, radius=RADIUS, youngs_modulus=E, density=RHO, n_nodes=n, poisson_ratio=NU)
    return Setup(rod=rod, reference=straight(n, L, direction=(1, 0, 0), normal=(0, 0, 1)), boundary=(Clamp(0),),
                 damping=Damping(translational=30.0, rotational=1e-3), gravity=gravity, tendons=tuple(tendons))


def settle(s, integrator="explicit"):
    traj = Simulator(s).run(RunConfig(dt=0.05, n_samples=11, integrator=integrator))
    assert np.abs(traj.positions[-1] - traj.positions[-2]).max() < REST_TOL * L  # at rest
    return traj


def static_rod(tendons, gravity=(0.0, 0.0, 0.0)):
    return StaticRod(length=L, radius=RADIUS, youngs_modulus=E, density=RHO, poisson_ratio=NU, gravity=gravity,
                     tendons=tuple(tendons))


def tip_angle(rotations):
    d3 = rotations[:, :, 2]
    return float(np.arccos(np.clip(d3[-1] @ d3[0], -1.0, 1.0)))


TAU = KAPPA * EI / OFFSET   # N


# --------------------------------------------------------------------------- constant curvature
@pytest.mark.parametrize("offset", [(OFFSET, 0.0), (0.0, -OFFSET)])
@pytest.mark.parametrize("integrator", ["explicit", "implicit"])
def test_a_straight_tendon_bends_a_free_rod_to_constant_curvature(offset, integrator):
    """No gravity: every segment's curvature is tau r / (E I) (the discrete strain K exactly, the
    tip angle / L within the discrete rod's O((l kappa)^2)), bending toward the tendon."""
    td = Tendon(name="t", offset=offset, tension=TAU)
    s = setup([td])
    sim = Simulator(s)
    traj = sim.run(RunConfig(dt=0.05, n_samples=11, integrator=integrator))
    assert np.abs(traj.positions[-1] - traj.positions[-2]).max() < REST_TOL * L
    kappa = TAU * OFFSET / EI
    K, _ = segment_strains(sim.state.rotations, sim.state.positions, s.rod.segment_length)
    np.testing.assert_allclose(np.linalg.norm(K, axis=1), kappa, rtol=CURVATURE_RTOL)
    assert tip_angle(traj.rotations()[-1]) / L == pytest.approx(kappa, rel=CURVATURE_RTOL)
    # bent toward the tendon's side: the tip moves along the offset's direction in the world
    side = offset[0] * np.array([0.0, 0.0, 1.0]) + offset[1] * np.array([0.0, -1.0, 0.0])  # d1 = z, d2 = -y
    assert traj.positions[-1, -1] @ side > 0.2 * L * OFFSET


def test_static_solver_gives_the_constant_curvature():
    sol = solve(static_rod([Tendon(name="t", offset=(OFFSET, 0.0), tension=TAU)]), tol=1e-12).raise_for_status()
    assert tip_angle(sol.rotations) / L == pytest.approx(TAU * OFFSET / EI, rel=CURVATURE_RTOL)
    # a circle through the base, tangent to +x, bending toward +z; the rod carries the compression
    # tau (strain tau / (E A)), so its radius is (1 - tau / (E A)) / kappa
    rho = (1 - TAU / (E * np.pi * RADIUS**2)) * EI / (TAU * OFFSET)
    centre = np.array([0.0, 0.0, rho])
    np.testing.assert_allclose(np.linalg.norm(sol.positions - centre, axis=1), rho, rtol=1e-6)


# --------------------------------------------------------------------------- dynamic = static
@pytest.mark.parametrize("tendon, gravity", [
    (Tendon(name="t", offset=(0.0, OFFSET), tension=TAU / 2), (0.0, 0.0, -9.81)),
    (Tendon(name="h", offset=(OFFSET, 0.0), tension=TAU / 3, routing="helical", pitch=0.4), (0.0, 0.0, -9.81)),
    (Tendon(name="s", offset=(0.0, -OFFSET), tension=TAU / 2, end_node=10), (0.0, 0.0, 0.0)),
])
@pytest.mark.parametrize("integrator", ["explicit", "implicit"])
def test_the_damped_dynamic_rod_rests_on_the_static_solution(tendon, gravity, integrator):
    """A tendon with gravity, a helical tendon with gravity, a tendon terminated mid-rod: every node
    within 0.1 % of L of the static solution (RK4 steps on the nodes)."""
    traj = settle(setup([tendon], gravity), integrator)
    static_tendon = tendon if tendon.end_node is None else dataclasses.replace(
        tendon, end_node=None, end_s=tendon.end_node * L / (N_NODES - 1))
    sol = solve(static_rod([static_tendon], gravity), n_steps=N_NODES - 1, tol=1e-12).raise_for_status()
    gap = np.linalg.norm(traj.positions[-1] - sol.positions, axis=1).max() / L
    assert gap < AGREEMENT_TOL, gap
    assert np.linalg.norm(sol.positions[-1, 1:]) > 0.05 * L  # the tip is deflected


# --------------------------------------------------------------------------- slack tendons
def test_zero_tension_gives_the_unloaded_rod():
    slack = [Tendon(name="a", offset=(OFFSET, 0.0), tension=0.0),
             Tendon(name="b", offset=(0.0, OFFSET),
                    tension=Scalar(Sinusoid((1.0, 0, 0), 2.0, offset=(-2.0, 0, 0))))]  # always < 0
    g = (0.0, 0.0, -9.81)
    cfg = RunConfig(dt=0.01, n_samples=6)
    with_slack, without = simulate(setup(slack, g), cfg), simulate(setup([], g), cfg)
    np.testing.assert_array_equal(with_slack.positions, without.positions)
    np.testing.assert_array_equal(with_slack.quaternions, without.quaternions)
    a = solve(static_rod(slack, g), tol=1e-12).raise_for_status()
    b = solve(static_rod([], g), tol=1e-12).raise_for_status()
    np.testing.assert_allclose(a.positions, b.positions, atol=1e-15)
    assert slack[1].tensions(np.linspace(0, 1, 11)).max() == 0.0  # a negative profile is clipped


# --------------------------------------------------------------------------- exact discrete loads
def _potential(R, r, l, C1, C2, K0, G0, route, end, tau):
    return strain_energy(R, r, l, C1, C2, K0, G0) + tendon_potential(R, r, l, route, end, tau)


def test_tendon_loads_are_the_gradient_of_the_discrete_tendon_length():
    """NumPy reference: f = -dV/dr, t = -dV/dLambda (left-trivialised) for V the strain energy plus
    tau times the tendon lengths (a straight and a helical tendon on a random deformed rod); and
    the kernel applies the same loads."""
    rng = np.random.default_rng(3)
    n, l = 8, 0.05
    R, r, K0, G0, C1, C2 = random_deformed_rod(rng, n, l)
    tendons = (Tendon(name="a", offset=(0.004, 0.002), tension=2.0, end_node=5),
               Tendon(name="b", offset=(-0.003, 0.0), tension=1.5, routing="helical", pitch=0.11))
    route, end = routing_arrays(tendons, n, l)
    tau = np.array([2.0, 1.5])
    terms = lambda K, G: tendon_resultants(K, G, route, end, tau)  # noqa: E731
    f, t = internal_loads(R, r, l, C1, C2, K0, G0, terms)
    f_fd, t_fd = fd_loads_of(lambda RR, rr: _potential(RR, rr, l, C1, C2, K0, G0, route, end, tau), R, r, 1e-6)
    scale = max(np.abs(f).max(), np.abs(t).max())
    assert np.abs(f - f_fd).max() < GRADIENT_RTOL * scale
    assert np.abs(t - t_fd).max() < GRADIENT_RTOL * scale
    fk, tk = _kernel_loads(R, r, l, C1, C2, K0, G0, route, end, tau)
    np.testing.assert_allclose(fk, f, atol=1e-9 * scale)
    np.testing.assert_allclose(tk, t, atol=1e-9 * scale)


def _kernel_loads(R, r, l, C1, C2, K0, G0, route, end, tau, h=1e-4):
    """The loads the kernel applies: one step from rest of free unit-mass, unit-inertia nodes."""
    n = r.shape[0]
    zeros = np.zeros((n - 1, 3))
    rod = frozen(length=l, weight=np.ones(n), mass=np.ones(n), inertia=np.ones((n, 3)), C1=C1, C2=C2, D1=zeros,
                 D2=zeros, K0=K0, G0=G0, ct=np.zeros(n), cr=np.zeros(n), gravity=np.zeros(3), kind=np.zeros(n),
                 kv_on=False)
    v, w = np.zeros((n, 3)), np.zeros((n, 3))
    state = kernels.StateArrays(R.copy(), r.copy(), v, w, np.zeros((n - 1, 3)), np.zeros((n - 1, 3)))
    none = np.zeros(0, np.int64)
    inputs = kernels.StepInputs(none, np.zeros((1, 0, 12)), none, np.zeros((1, 0, 3)), np.zeros((0, 2)), none,
                                np.zeros((2, 0, 3)), np.zeros((2, 0, 3, 3)), route, end, tau[None, :].copy())
    code, _ = kernels.advance(rod, state, inputs, empty_samples(np.arange(n, dtype=np.int64), 1, n), h, 0, 1, 1, 0)
    assert code == kernels.OK
    y = h * w
    t = (y + 0.5 * np.cross(y, y) + 0.25 * np.sum(y * y, 1, keepdims=True) * y) / h**2
    return v / h, t


# --------------------------------------------------------------------------- batches
def test_a_batch_with_tendons_matches_single_runs():
    cfg = RunConfig(dt=0.01, n_samples=5)
    setups = [setup([Tendon(name="t", offset=(OFFSET, 0.0), tension=tau)], (0.0, 0.0, -9.81), n=11)
              for tau in (1.0, 4.0)]
    for b, traj in zip(setups, simulate_batch(setups, cfg)):
        np.testing.assert_allclose(traj.positions, simulate(b, cfg).positions, rtol=0, atol=1e-14)


# --------------------------------------------------------------------------- bad inputs
@pytest.mark.parametrize("kwargs, match", [
    (dict(offset=(0.011, 0.0)), "offset.*at most the section radius 0.01 m"),
    (dict(offset=(0.0, 0.0), end_node=21), "end_node=21 is invalid"),
    (dict(offset=(0.0, 0.0), end_node=0), "termination beyond the base node"),
    (dict(offset=(0.0, 0.0), end_s=0.3), "end_s=0.3 is invalid"),
])
def test_bad_tendons_are_refused_by_the_setup(kwargs, match):
    with pytest.raises(SoftrnnInputError, match=match) as err:
        setup([Tendon(name="t", tension=1.0, **kwargs)])
    assert "\n" not in str(err.value)


def test_bad_tendon_values_are_refused_in_one_line():
    for kwargs, match in ((dict(tension=-1.0), "tension=-1.0 is invalid: a tension >= 0"),
                          (dict(routing="spiral"), "routing"), (dict(routing="helical"), "pitch"),
                          (dict(pitch=0.1), "no pitch for straight routing"), (dict(name="Left"), "name")):
        with pytest.raises(SoftrnnInputError, match=match) as err:
            Tendon(**{"name": "t", "offset": (0.0, 0.0), **kwargs})
        assert "\n" not in str(err.value)
    with pytest.raises(SoftrnnInputError, match="tendon_tensions"):
        StaticLoads(tendon_tensions=(-1.0,))
    with pytest.raises(SoftrnnInputError, match="offset"):
        static_rod([Tendon(name="t", offset=(0.0, 0.012))])


SCENARIO = """
format = 1
name = "tendon-test"
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
tension = { kind = "sinusoid", offset = 2.0, amplitude = 1.5, frequency = 2.0, ramp = 0.02 }
[[tendons]]
name = "side"
offset = [0.0, 0.005]
routing = "helical"
turns = 1.5
end_node = 6
tension = { kind = "random_smooth", mean = 1.0, amplitude = 0.5, cutoff = 5.0, seed = 4 }
[run]
dt = 0.002
n_samples = 26
nodes_of_interest = [-1]
"""


@pytest.mark.parametrize("old, new, key", [
    ('offset = [0.008, 0.0]', 'offset = [0.008, 0.009]', "tendons.0.offset = [0.008, 0.009] is invalid"),
    ('end_node = 6', 'end_node = 11', "tendons.1.end_node = 11 is invalid"),
    ('offset = 2.0, amplitude = 1.5', 'offset = 1.0, amplitude = 1.5', "tendons.0.tension.offset = 1.0 is invalid"),
    ('mean = 1.0', 'mean = 0.4', "tendons.1.tension.mean = 0.4 is invalid"),
    ('turns = 1.5', 'pitch = 0.1\nturns = 1.5', "exactly one of pitch"),
    ('routing = "helical"\n', '', "only a helical tendon has a turns"),
])
def test_bad_tendon_entries_in_a_scenario_name_the_key(tmp_path, old, new, key):
    text = SCENARIO.replace(old, new)
    assert text != SCENARIO
    with pytest.raises(SoftrnnInputError, match=re.escape(key)) as err:
        parse_scenario(text)
    assert "\n" not in str(err.value)
    path = tmp_path / "bad.toml"
    path.write_text(text)
    assert run_cli(["simulate", str(path), "--quiet"]) == 2


def test_negative_constant_tension_in_a_scenario():
    text = SCENARIO.replace('{ kind = "sinusoid", offset = 2.0, amplitude = 1.5, frequency = 2.0, ramp = 0.02 }',
                            '{ kind = "constant", value = -0.5 }')
    with pytest.raises(SoftrnnInputError, match=r"tendons.0.tension.value = -0.5 is invalid: expected a number >= 0"):
        parse_scenario(text)


# --------------------------------------------------------------------------- dataset
def test_a_scenario_with_tendons_writes_the_tensions_as_actuation(tmp_path):
    sc = parse_scenario(SCENARIO)
    top, side = sc.setup.tendons
    assert side.end_node == 6 and side.pitch == pytest.approx(6 * 0.02 / 1.5) and side.routing == "helical"
    path = tmp_path / "run.h5"
    simulate_summary(name=sc.name, title=sc.title, setup=sc.setup, config=sc.config, node=-1, out_path=path)
    with h5py.File(path) as f:
        act, time = f["actuation"][()], f["time"][()]
        names, units = f["actuation"].attrs["names"], f["actuation"].attrs["units"]
    values, channels = tendon_actuation(sc.setup.tendons, time)
    assert channels == {"tendon_top": "N", "tendon_side": "N"}
    assert names == '["tendon_top", "tendon_side"]' and units == '["N", "N"]'
    assert act.shape == (26, 2) and values.shape == (26, 2)
    np.testing.assert_allclose(act, values, rtol=1e-6, atol=1e-6)  # float32 in the file
    t = np.array([0.0, 0.01, 0.03])
    np.testing.assert_allclose(values[[0, 5, 15], 0], top.tensions(t))
    assert values[0, 0] == 0.0 and values[-1, 0] == pytest.approx(2.0 + 1.5 * np.sin(2 * np.pi * 2.0 * 0.05))
    assert np.all(values[:, 1] >= 0.5 - 1e-12) and np.all(values[:, 1] <= 1.5 + 1e-12)


# --------------------------------------------------------------------------- energy balance
def _undamped(tension):
    rod = RodSpec(length=L, radius=RADIUS, youngs_modulus=E, density=RHO, n_nodes=N_NODES, poisson_ratio=NU)
    return Setup(rod=rod, reference=straight(N_NODES, L, direction=(1, 0, 0), normal=(0, 0, 1)),
                 boundary=(Clamp(0),), damping=Damping(translational=0.0, rotational=0.0),
                 tendons=(Tendon(name="t", offset=(OFFSET, 0.0), tension=tension),))


def test_a_constant_tension_conserves_energy_with_the_tendon_potential():
    """No damping, no gravity, a constant tension released on the straight rod: the rod swings
    about its bent rest shape. Kinetic + elastic + tau l stays constant to the integrator's
    second order: within 0.5 % of the energy the tendon converts at the chosen step, 3.4x closer at
    half the step (0.23 % and 0.066 % measured), while kinetic + elastic alone
    (``Trajectory.energy``) swings by all of it."""
    s = _undamped(TAU)
    spread = []
    for substeps in (40, 80):               # 40: the automatic (stable) choice
        traj = simulate(s, RunConfig(dt=0.002, n_samples=151, substeps=substeps))
        potential, work = tendon_energy(s, traj)
        rod_energy = traj.energy.sum(axis=1)
        converted = np.ptp(rod_energy)
        assert rod_energy.max() > 10 * abs(rod_energy[0])   # the rod moves
        spread.append(np.ptp(rod_energy + potential) / converted)
        np.testing.assert_allclose(potential[0], TAU * L, rtol=1e-12)       # straight: l = L
        # the work the tendon did is the potential it gave up (constant tension)
        np.testing.assert_allclose(work, potential[0] - potential, atol=1e-12 * TAU * L)
    assert spread[0] < 5e-3, spread
    assert spread[0] / spread[1] > 3.0, spread      # second order: 4 in the limit


def test_a_varying_tension_balances_the_tendons_work():
    """A sinusoidal tension on the undamped rod: kinetic + elastic - the tendon's work (trapezoidal
    over samples 1 ms apart) is constant within 1 % of the work done."""
    s = _undamped(Scalar(Sinusoid((TAU / 2, 0, 0), 3.0, offset=(TAU / 2, 0, 0))))
    traj = simulate(s, RunConfig(dt=0.001, n_samples=301))
    _, work = tendon_energy(s, traj)
    balance = traj.energy.sum(axis=1) - work
    assert np.ptp(work) > 0.0
    assert np.ptp(balance) < 1e-2 * np.ptp(work), np.ptp(balance) / np.ptp(work)


def test_tendon_energy_needs_every_node():
    s = _undamped(TAU)
    traj = simulate(s, RunConfig(dt=0.01, n_samples=3, save_nodes=(0, N_NODES - 1)))
    with pytest.raises(SoftrnnInputError, match="trajectory.*saves all 21 nodes"):
        tendon_energy(s, traj)
