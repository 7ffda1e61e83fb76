"""Contact with rigid obstacles and Coulomb friction (docs/lgvi.md §2.11): no effect without
contact, a rod at rest on a plane, the friction onset on a tilted plane, the work balance of
friction, a falling rod stopped by a sphere and a cylinder, a rod pushed through a curved vessel,
and the one-line errors for nonsense input."""

import math
from dataclasses import replace

import numpy as np
import pytest

from softrnn.errors import SoftrnnInputError
from softrnn.rod import (
    Clamp,
    Constant,
    Contact,
    Cylinder,
    Damping,
    NodalLoad,
    Pin,
    Plane,
    RodSpec,
    RunConfig,
    Setup,
    Simulator,
    Sphere,
    Vessel,
    polyline,
    simulate_batch,
    straight,
)
from softrnn.rod.contact import closest_segments
from softrnn.rod.kernels import contact_wrench_into
from softrnn.rod.state import SAMPLE_FIELDS

G = 9.81
RADIUS = 0.005
LENGTH = 0.2
N = 21
MU = 0.4

PENETRATION_TOL = 0.01        # of the rod radius, at rest under the rod's own weight
REACTION_RTOL = 0.01          # total normal reaction against the weight
SLIDE_RTOL = 0.02             # sliding acceleration against g (sin - mu cos)
WORK_RTOL = 0.02              # energy lost against the contact work


def _rod(radius=RADIUS, n=N, length=LENGTH):
    return RodSpec(length=length, radius=radius, youngs_modulus=1e6, density=1000.0, n_nodes=n)


def _lying(theta=0.0, mu=MU, **contact):
    """A free, straight rod lying down the slope of a plane through the origin tilted by theta about
    y, at the default stiffness' rest penetration (0.5 % of r), gravity along -z; and the unit
    vector down the slope."""
    normal = np.array([-math.sin(theta), 0.0, math.cos(theta)])
    slope = np.array([math.cos(theta), 0.0, math.sin(theta)])
    shape = straight(N, LENGTH, origin=normal * RADIUS * (1 - 0.005), direction=slope, normal=normal)
    plane = Plane((0.0, 0.0, 0.0), tuple(normal))
    return Setup(rod=_rod(), reference=shape, gravity=(0.0, 0.0, -G),
                 contact=Contact(obstacles=(plane,), friction=mu, **contact)), -slope


def _centre_of_mass(sim, traj):
    m = sim.mass
    return np.einsum("a,sac->sc", m, traj.positions) / m.sum()


@pytest.mark.parametrize("integrator", ["explicit", "implicit"])
def test_an_obstacle_out_of_reach_changes_nothing(integrator):
    """A cantilever swinging in gravity, with obstacles of every kind that it never touches: the
    trajectory is byte-identical to the run without them."""
    shape = straight(N, LENGTH, direction=(1.0, 0.0, 0.0), normal=(0.0, 0.0, 1.0))
    base = Setup(rod=_rod(), reference=shape, boundary=(Clamp(0),), gravity=(0.0, 0.0, -G))
    tube = Vessel(np.array([[-1.0, 0.3, 0.0], [0.0, 0.35, 0.0], [1.0, 0.3, 0.0]]), 1.0)
    far = Contact(obstacles=(Plane((0, 0, -10.0), (0, 0, 1)), Sphere((5.0, 5, 5), 0.1),
                             Cylinder((0, 3.0, 0), (1, 0, 0), 0.1), tube), friction=0.5)
    config = RunConfig(dt=1e-3, n_samples=201, substeps=20, integrator=integrator)
    plain = Simulator(base).run(config)
    touched = Simulator(replace(base, contact=far)).run(config)
    assert np.ptp(plain.positions[:, -1, 2]) > 0.05  # it swings
    for name in SAMPLE_FIELDS:
        assert getattr(plain, name).tobytes() == getattr(touched, name).tobytes(), name
    assert plain.contact_forces is None
    assert touched.contact_forces.shape == plain.forces.shape and not np.any(touched.contact_forces)


@pytest.mark.parametrize("integrator", ["explicit", "implicit"])
def test_a_rod_at_rest_on_a_plane_carries_its_weight(integrator):
    """At rest on a horizontal plane: penetration below 1 % of r (the default stiffness puts it at
    0.5 %), the normal reaction equal to the weight within 1 %, no friction at rest."""
    setup, _ = _lying(mu=MU)
    sim = Simulator(setup)
    traj = sim.run(RunConfig(dt=1e-3, n_samples=301, integrator=integrator))
    radius = np.full(N, RADIUS)
    penetration = -setup.contact.gaps(traj.positions[-1], radius).min()
    assert 0 < penetration < PENETRATION_TOL * RADIUS
    assert penetration == pytest.approx(0.005 * RADIUS, rel=0.05)
    weight = sim.mass.sum() * G
    reaction = traj.contact_forces[-1].sum(axis=0)
    assert reaction[2] == pytest.approx(weight, rel=REACTION_RTOL)
    assert np.all(np.abs(reaction[:2]) < 1e-6 * weight)
    assert not np.any(traj.forces)  # the contact loads are not applied loads


def _slide(ratio, substeps=50, n_samples=501):
    """The rod on a plane tilted to tan theta = ratio mu: its centre of mass down the slope (S,) [m]."""
    setup, slope = _lying(theta=math.atan(ratio * MU))
    sim = Simulator(setup)
    traj = sim.run(RunConfig(dt=1e-3, n_samples=n_samples, substeps=substeps))
    return traj, (_centre_of_mass(sim, traj) - _centre_of_mass(sim, traj)[0]) @ slope


def test_friction_holds_the_rod_below_the_friction_angle():
    """tan theta = 0.9 mu: the rod stays. The regularised friction lets it creep at most at
    v_s' tan theta / mu with v_s' = max(v_s, h mu f_n / m_eff) and 1 / m_eff = 5 / m for a rod along
    the slope (rotation included): here 5 h g sin theta = 3.33e-4 m/s, and it creeps at that speed
    (measured 1.333e-4 m in 0.4 s against 1.329e-4 m predicted), 0.4 % of the slide at 1.1 mu."""
    traj, along = _slide(0.9)
    theta = math.atan(0.9 * MU)
    creep = max(1e-4 * 0.9, 5 * traj.step * G * math.sin(theta))
    assert abs(along[-1] - along[100]) < 1.2 * creep * (traj.time[-1] - traj.time[100])
    # against the 1.1 mu slide over the same time: 1/2 g (sin - mu cos) t^2 = 4.4 cm
    assert abs(along[-1]) < 0.01 * 0.5 * G * 0.04 * math.cos(theta) * traj.time[-1] ** 2


def test_the_rod_slides_above_the_friction_angle_with_the_coulomb_acceleration():
    """tan theta = 1.1 mu: the centre of mass accelerates at g (sin theta - mu cos theta) within 2 %
    (a quadratic fit over 0.1-0.5 s)."""
    traj, along = _slide(1.1)
    theta = math.atan(1.1 * MU)
    expected = G * (math.sin(theta) - MU * math.cos(theta))
    t = traj.time[100:]
    accel = 2 * np.polyfit(t, along[100:], 2)[0]
    assert accel == pytest.approx(expected, rel=SLIDE_RTOL)


def test_the_energy_lost_sliding_is_the_work_of_friction():
    """Sliding down a plane at tan theta = 1.5 mu, every step saved: the change of kinetic, elastic
    and gravitational energy equals the work of the contact loads within 2 %, that work is the
    friction's (the normal force does none at steady contact), and equals -mu m g cos theta times the
    distance slid."""
    theta = math.atan(1.5 * MU)
    setup, slope = _lying(theta=theta)
    sim = Simulator(setup)
    h = 5e-5
    traj = sim.run(RunConfig(dt=h, n_samples=6001, substeps=1))
    k0, k1 = 1000, 6000  # 50 ms to settle onto the plane, then 0.25 s of sliding
    energy = traj.energy.sum(axis=1)
    power = (np.einsum("sac,sac->s", traj.contact_forces, traj.velocities)
             + np.einsum("sac,sac->s", traj.contact_torques, traj.angular_velocities))
    work = h * power[k0:k1].sum()
    normal = np.array(setup.contact.obstacles[0].normal)
    normal_power = np.einsum("sac,c,sad,d->s", traj.contact_forces, normal, traj.velocities, normal)
    friction_work = work - h * normal_power[k0:k1].sum()
    com = _centre_of_mass(sim, traj) @ slope
    coulomb = -MU * sim.mass.sum() * G * math.cos(theta) * (com[k1] - com[k0])
    assert work < 0
    assert energy[k1] - energy[k0] == pytest.approx(work, rel=WORK_RTOL)
    assert friction_work == pytest.approx(work, rel=WORK_RTOL)
    assert friction_work == pytest.approx(coulomb, rel=WORK_RTOL)


@pytest.mark.parametrize("obstacle, y", [(Sphere((0.0, 0.0, 0.0), 0.05), 0.0),
                                         (Cylinder((0.0, 0.0, 0.0), (0.0, 1.0, 0.0), 0.05), 0.03)],
                         ids=["sphere", "cylinder"])
def test_a_falling_rod_is_stopped_by_a_sphere_and_a_cylinder(obstacle, y):
    """A horizontal rod of 20 nodes released just above a sphere (a cylinder across it, 3 cm along
    its axis from the origin): it falls, bends over the obstacle and comes to rest on its two
    middle nodes, which straddle the top, so the contact normals lean by 5 degrees. The stiffness
    is set for half the weight on one node (``reference_acceleration``). The surface is never
    penetrated by more than 1 % of r (measured: 0.65 % in the fall, 0.50 % at rest), every contact
    force points along the obstacle's normal at the node (frictionless), and at rest the reaction
    carries the weight."""
    n = 20
    top = 0.05 + RADIUS
    shape = straight(n, LENGTH, origin=(-LENGTH / 2, y, top + 0.1 * RADIUS), direction=(1.0, 0.0, 0.0),
                     normal=(0.0, 0.0, 1.0))
    contact = Contact(obstacles=(obstacle,), reference_acceleration=G * (n - 1) / 2)
    setup = Setup(rod=_rod(n=n), reference=shape, gravity=(0.0, 0.0, -G), contact=contact,
                  damping=Damping(translational=2.0))
    sim = Simulator(setup)
    traj = sim.run(RunConfig(dt=1e-3, n_samples=501))
    radius = np.full(n, RADIUS)
    gaps = np.array([contact.gaps(p, radius)[:, 0] for p in traj.positions])
    assert -gaps.min() < PENETRATION_TOL * RADIUS
    assert np.ptp(traj.positions[:, 0, 2]) > 0.5 * RADIUS  # the ends fell
    f = traj.contact_forces
    on = np.linalg.norm(f, axis=2) > 0
    assert on.sum() > 100 and set(np.flatnonzero(on[-1])) == {n // 2 - 1, n // 2}
    normals = np.array([obstacle.gap(p, radius)[1] for p in traj.positions])
    assert np.all(np.abs(normals[-1, n // 2, 0]) > 0.08)  # leaning
    cos = np.einsum("sac,sac->sa", f, normals)[on] / np.linalg.norm(f, axis=2)[on]
    assert np.all(cos > 1 - 1e-12)
    assert np.abs(traj.velocities[-1]).max() < 1e-3
    assert f[-1].sum(axis=0) == pytest.approx([0.0, 0.0, sim.mass.sum() * G], rel=REACTION_RTOL,
                                              abs=REACTION_RTOL * sim.mass.sum() * G)


def _tube_centreline():
    """A tube along x, a quarter bend of radius 0.1 m toward +y, then along y: points every 5 mm."""
    straight_in = np.stack([np.arange(-0.05, 0.25, 0.005), np.zeros(60), np.zeros(60)], axis=1)
    phi = np.linspace(0.0, math.pi / 2, 32)[:-1]
    bend = np.stack([0.25 + 0.1 * np.sin(phi), 0.1 - 0.1 * np.cos(phi), np.zeros(phi.size)], axis=1)
    straight_out = np.stack([np.full(40, 0.35), 0.1 + np.arange(40) * 0.005, np.zeros(40)], axis=1)
    return np.concatenate([straight_in, bend, straight_out])


class _Push:
    """Clamp motion: node 0 pushed along +x at speed V after a smooth start over T."""

    V, T = 0.25, 0.1

    def __init__(self, origin, rotation):
        self.origin, self.rotation = np.asarray(origin), np.asarray(rotation)

    def __call__(self, t):
        s = np.where(t < self.T, self.V * t**2 / (2 * self.T), self.V * (t - self.T / 2))
        return self.origin + s[:, None] * np.array([1.0, 0.0, 0.0]), np.broadcast_to(self.rotation, (t.size, 3, 3))


@pytest.mark.parametrize("a_ref, tol", [(None, 0.05), (10 * G, 0.01)], ids=["default", "stiff"])
def test_a_rod_pushed_through_a_curved_vessel_stays_inside(a_ref, tol):
    """A rod of radius 2 mm pushed at its base 0.14 m into a 90 degree bend of a 6 mm tube, in
    gravity, with friction: every node stays inside at every sample (distance to the centreline
    <= R - r + tol r), the tip turns into the bend, and the tracked segment of every node is the
    brute-force closest one. The bend presses the rod onto the outer wall with up to about 4 times
    the nodes' weights: at the default stiffness (0.5 % of r under the weight) the deepest node goes
    3.3 % of r into the wall, at ten times the reference acceleration 0.5 % (the initial rest)."""
    r = 0.002
    vessel = Vessel(_tube_centreline(), 0.006)
    # resting on the tube's floor at the stiffness' rest penetration
    rest = 0.005 * r * (1.0 if a_ref is None else G / a_ref)
    shape = straight(N, LENGTH, origin=(0.02, 0.0, -(0.006 - r) - rest), direction=(1.0, 0.0, 0.0),
                     normal=(0.0, 0.0, 1.0))
    setup = Setup(rod=_rod(radius=r), reference=shape, gravity=(0.0, 0.0, -G),
                  boundary=(Clamp(0, motion=_Push(shape.positions[0], shape.rotations[0])),),
                  contact=Contact(obstacles=vessel, friction=0.1, reference_acceleration=a_ref),
                  damping=Damping(translational=0.2))
    sim = Simulator(setup)
    radius = np.full(N, r)
    touched = 0.0
    for _ in range(6):
        traj = sim.run(RunConfig(dt=1e-3, n_samples=101))
        gaps = np.array([vessel.gap(p, radius)[0] for p in traj.positions])
        assert gaps.min() > -tol * r
        touched = max(touched, np.abs(traj.contact_forces).max())
        st = sim.state
        inputs = sim.inputs.with_contact(sim.inputs.at(np.array([st.time]), traj.step), st.contact_segment,
                                         np.zeros((0, 0, 6)))
        contact_wrench_into(traj.step, st.rotations, st.positions, st.velocities, st.angular_velocities, sim.rod,
                            inputs, np.zeros((N, 6)))
        assert np.array_equal(st.contact_segment[:, 0], closest_segments(vessel.points, st.positions)[0])
    assert touched > 0
    assert traj.positions[-1, -1, 1] > 0.03  # the tip went round the bend


class _Pull:
    """Pin path: the node pulled along -z at speed V after a smooth start over T."""

    V, T = 0.2, 0.05

    def __init__(self, origin):
        self.origin = np.asarray(origin)

    def __call__(self, t):
        s = np.where(t < self.T, self.V * t**2 / (2 * self.T), self.V * (t - self.T / 2))
        return self.origin - s[:, None] * np.array([0.0, 0.0, 1.0])


def _over_a_drum(drum, r, leg, n):
    """Nodes (n, 3) of a rope hanging over the top of a drum of radius ``drum`` (axis y): a vertical
    leg, the upper half circle of radius drum + r (less the rest penetration), a vertical leg,
    equally spaced in arc length; and its length [m]."""
    rho = drum + r * (1 - 0.005)
    length = 2 * leg + math.pi * rho
    s = np.linspace(0.0, length, n)
    phi = np.clip((s - leg) / rho, 0.0, math.pi)
    x = np.where(s < leg, -rho, np.where(s > leg + math.pi * rho, rho, -rho * np.cos(phi)))
    z = np.where(s < leg, s - leg, np.where(s > leg + math.pi * rho, leg + math.pi * rho - s, rho * np.sin(phi)))
    return np.stack([x, np.zeros(n), z], axis=1), length


@pytest.mark.parametrize("mu", [0.2, 0.4])
def test_a_rope_slipping_over_a_drum_obeys_the_capstan_equation(mu):
    """A thin, soft rope (r = 0.25 mm) over a fixed drum of radius 5 cm, wrapped by 180 degrees:
    one end loaded with T1, the other pulled down at 0.2 m/s, so that the rope slips over the drum.
    In steady slip the pull is T2 = T1 exp(mu pi) (Euler-Eytelwein; the belt-speed term lambda v^2
    taken off both) within 1 % (measured -0.24 % and -0.67 %: a rope of finite radius over a
    drum has an exponent lower by O(r / R), 0.5 % here). Implicit integrator (Kelvin-Voigt damping
    quiets the rope's axial waves); the stiffness is set for the pressure T2 / R."""
    drum, r, t1, n = 0.05, 0.00025, 0.01, 161
    points, length = _over_a_drum(drum, r, 0.08, n)
    rod = RodSpec(length=length, radius=r, youngs_modulus=1e7, density=1000.0, n_nodes=n)
    stiffness = t1 * math.exp(mu * math.pi) / drum / (0.005 * r)
    setup = Setup(rod=rod, reference=polyline(points, normal=(0.0, 1.0, 0.0)),
                  boundary=(Pin(n - 1, path=_Pull(points[-1])),), loads=(NodalLoad(0, force=Constant((0, 0, -t1))),),
                  contact=Contact(obstacles=Cylinder((0.0, 0.0, 0.0), (0.0, 1.0, 0.0), drum), friction=mu,
                                  stiffness=stiffness), damping=Damping(kelvin_voigt=0.003))
    traj = Simulator(setup).run(RunConfig(dt=1e-3, n_samples=251, save_nodes=(0, -1), integrator="implicit"))
    steady = traj.time >= 0.15
    assert np.all(np.diff(traj.positions[steady, 0, 2]) > 0)  # the loaded end rises: the rope slips
    t2 = -traj.reaction_forces[steady, 1, 2]
    belt = rod.density * math.pi * r**2 * _Pull.V**2
    assert np.ptp(t2) < 0.01 * t2.mean()
    assert (t2.mean() - belt) / (t1 - belt) == pytest.approx(math.exp(mu * math.pi), rel=0.01)


@pytest.mark.parametrize("build", [
    lambda: Plane((0, 0, 0), (0, 0, 0)),
    lambda: Plane((0, 0, math.nan), (0, 0, 1)),
    lambda: Sphere((0, 0, 0), -0.1),
    lambda: Cylinder((0, 0, 0), (1, 0, 0), 0.0),
    lambda: Cylinder((0, 0, 0), (0, 0, 0), 0.1),
    lambda: Vessel(np.zeros((1, 3)), 0.01),
    lambda: Vessel(np.array([[0, 0, 0], [0, 0, 0], [1, 0, 0.0]]), 0.01),
    lambda: Vessel(np.array([[0, 0, 0], [1, 0, 0.0]]), -0.01),
    lambda: Vessel(np.array([[0, 0, 0], [1, 0, 0.0]]), [0.01, 0.01, 0.01]),
    lambda: Contact(obstacles=(Plane((0, 0, 0), (0, 0, 1)),), friction=-0.1),
    lambda: Contact(obstacles=()),
    lambda: Contact(obstacles=("floor",)),
    lambda: Contact(obstacles=Plane((0, 0, 0), (0, 0, 1)), slip_velocity=0.0),
    lambda: Contact(obstacles=Plane((0, 0, 0), (0, 0, 1)), penetration=1.5),
    lambda: Contact(obstacles=Plane((0, 0, 0), (0, 0, 1)), stiffness=-1.0),
    lambda: Plane((0, 0, 0), (0, 0, 1), friction=-1),
], ids=["zero-normal", "nan-point", "negative-radius", "zero-radius", "zero-axis", "one-point", "repeated-point",
        "negative-vessel-radius", "radii-count", "negative-friction", "no-obstacle", "not-an-obstacle", "zero-slip",
        "penetration", "negative-stiffness", "negative-own-friction"])
def test_nonsense_geometry_is_refused_in_one_line(build):
    with pytest.raises(SoftrnnInputError) as err:
        build()
    assert "\n" not in str(err.value) and "is invalid" in str(err.value)


def test_setups_with_impossible_contact_are_refused_in_one_line():
    """A rod starting inside a sphere, a vessel narrower than the rod, a contact that is not a
    Contact, and a batch with contact in one setup only."""
    shape = straight(N, LENGTH, direction=(1.0, 0.0, 0.0), normal=(0.0, 0.0, 1.0))
    cases = [dict(contact=Contact(obstacles=Sphere((0.1, 0.0, 0.0), 0.05))),
             dict(contact=Contact(obstacles=Vessel(np.array([[-1, 0, 0], [1, 0, 0.0]]), 0.004))),
             dict(contact="floor")]
    for kw in cases:
        with pytest.raises(SoftrnnInputError) as err:
            Setup(rod=_rod(), reference=shape, **kw)
        assert "\n" not in str(err.value)
    setup = Setup(rod=_rod(), reference=shape, contact=Contact(obstacles=Plane((0, 0, -1.0), (0, 0, 1))))
    with pytest.raises(SoftrnnInputError, match="contact"):
        simulate_batch([setup, replace(setup, contact=None)], RunConfig(dt=1e-3, n_samples=2))

