"""Scheduled loads and a time-varying gravity: the schedule factor (start, ramp, release, shape) on
vector and scalar profiles; gravity given as a time function goes through the nodal loads and
equals the constant-gravity path to round-off; a cantilever under slowly ramped gravity comes to
the same rest state as under constant gravity (and to Euler-Bernoulli); a tip force released at
t_r leaves the rod oscillating freely at its first bending frequency with constant energy."""

import numpy as np
import pytest

from softrnn.errors import SoftrnnInputError
from softrnn.rod import Clamp, Damping, NodalLoad, RodSpec, RunConfig, Setup, Simulator, simulate, simulate_batch
from softrnn.rod.loads import Constant, Scheduled, Sinusoid, gravity_at, smoothstep
from softrnn.rod.lumped import constant_gravity, lumped_rod
from softrnn.rod.shapes import straight
from softrnn.rod.tendons import Scalar, Tendon

G = (0.0, 0.0, -9.81)
# a cantilever along +x: L = 0.5 m, r = 1 cm, E = 100 MPa, rho = 1000 kg/m^3, 21 nodes
L, R, E, RHO, N = 0.5, 0.01, 1e8, 1000.0, 21
AREA, INERTIA = np.pi * R**2, np.pi * R**4 / 4
OMEGA1 = 1.8751**2 * np.sqrt(E * INERTIA / (RHO * AREA * L**4))  # first bending mode [rad/s]


def _cantilever(**kw) -> Setup:
    rod = RodSpec(length=L, radius=R, youngs_modulus=E, density=RHO, n_nodes=N)
    return Setup(rod=rod, reference=straight(N, L, direction=(1, 0, 0), normal=(0, 0, 1)), boundary=(Clamp(0),),
                 **kw)


# --------------------------------------------------------------------------- the schedule
def test_schedule_factor_is_zero_before_start_ramps_and_drops_at_release():
    t = np.array([-1.0, 0.5, 1.0, 1.25, 1.5, 2.0, 2.9, 3.0, 4.0])
    smooth = Scheduled(Constant((1.0, 2.0, 3.0)), start=1.0, ramp=0.5, release=3.0)
    w = smooth.factor(t)
    np.testing.assert_allclose(w, [0, 0, 0, smoothstep(np.array(0.5)), 1, 1, 1, 0, 0])
    assert w[3] == pytest.approx(0.5)
    np.testing.assert_allclose(smooth(t), w[:, None] * [1.0, 2.0, 3.0])
    linear = Scheduled(Constant((1.0, 0.0, 0.0)), start=1.0, ramp=0.5, shape="linear")
    np.testing.assert_allclose(linear.factor(np.array([1.0, 1.125, 1.25, 1.5, 100.0])), [0, 0.25, 0.5, 1, 1])
    step = Scheduled(Constant((1.0, 0.0, 0.0)), start=0.2)
    np.testing.assert_array_equal(step.factor(np.array([0.0, 0.1999, 0.2, 5.0])), [0, 0, 1, 1])
    # the smooth ramp starts and ends with zero slope; the linear one does not
    eps = 1e-6
    assert smooth.factor(np.array([1.0 + eps]))[0] < 1e-12
    assert linear.factor(np.array([1.0 + eps]))[0] == pytest.approx(eps / 0.5)


def test_one_schedule_serves_vector_and_scalar_profiles():
    t = np.linspace(0.0, 2.0, 9)
    vec = Scheduled(Sinusoid((0.0, 1.0, 0.0), frequency=1.0), ramp=1.0, release=1.5)
    assert vec(t).shape == (9, 3)
    np.testing.assert_allclose(vec(t), Sinusoid((0.0, 1.0, 0.0), frequency=1.0)(t) * vec.factor(t)[:, None])
    tension = Scheduled(Scalar(Constant((2.0, 0.0, 0.0))), start=0.5, ramp=0.5, release=1.5)
    assert tension(t).shape == (9,)
    np.testing.assert_allclose(tension(t), 2.0 * tension.factor(t))
    td = Tendon(name="left", offset=(0.005, 0.0), tension=tension)
    np.testing.assert_allclose(td.tensions(t), [0, 0, 0, 1.0, 2, 2, 0, 0, 0])  # removed at t = 1.5
    servo = Tendon(name="servo", offset=(0.005, 0.0), stiffness=100.0,
                   displacement=Scheduled(Scalar(Constant((0.003, 0.0, 0.0))), ramp=1.0, shape="linear"))
    np.testing.assert_allclose(servo.displacements(np.array([0.0, 0.5, 2.0])), [0.0, 0.0015, 0.003])


@pytest.mark.parametrize("kwargs, words", [
    (dict(ramp=-1.0), "Scheduled.ramp=-1.0"),
    (dict(start=1.0, release=0.5), "Scheduled.release=0.5"),
    (dict(start=1.0, release=1.0), "a time after start = 1 s"),
    (dict(shape="cubic"), "Scheduled.shape='cubic'"),
    (dict(start=float("nan")), "Scheduled.start=nan"),
])
def test_bad_schedules_give_one_line_errors(kwargs, words):
    with pytest.raises(SoftrnnInputError, match=words.replace(".", r"\.")) as info:
        Scheduled(Constant((1.0, 0.0, 0.0)), **kwargs)
    assert len(str(info.value).splitlines()) == 1
    with pytest.raises(SoftrnnInputError, match="Scheduled.function"):
        Scheduled((1.0, 0.0, 0.0))


# --------------------------------------------------------------------------- gravity as a profile
def test_a_gravity_profile_gives_the_lumped_rod_no_constant_gravity():
    ramped = _cantilever(gravity=Scheduled(Constant(G), ramp=0.5))
    assert constant_gravity(ramped) == (0.0, 0.0, 0.0) and np.all(lumped_rod(ramped).gravity == 0.0)
    assert constant_gravity(_cantilever(gravity=G)) == G
    assert gravity_at(ramped.gravity, 0.25) == pytest.approx((0.0, 0.0, -9.81 * 0.5))
    assert gravity_at(G, 3.0) == G
    with pytest.raises(SoftrnnInputError, match="gravity=") as info:
        _cantilever(gravity=lambda t: np.zeros((np.size(t), 2)))
    assert "(K, 3)" in str(info.value) and len(str(info.value).splitlines()) == 1


def test_a_constant_gravity_profile_equals_the_constant_gravity_path():
    """An undamped cantilever whipping down under gravity: the constant vector (lumped rod) and the
    same gravity as a time function (nodal loads) agree to round-off; the recorded forces of the
    profile run hold the weights m_a g."""
    config = RunConfig(dt=2e-3, n_samples=151)
    a = simulate(_cantilever(gravity=G), config)
    b = simulate(_cantilever(gravity=Constant(G)), config)
    assert a.substeps == b.substeps and np.abs(a.positions[-1, -1, 2]) > 0.0
    # the loads add up in another order: round-off in the configuration (measured 1e-14 of its
    # size after 12,000 undamped steps), which the stiff axial forces amplify in the velocities and
    # support reactions (measured 1e-10 and 1.4e-9 of their sizes)
    for name, tol in (("positions", 1e-12), ("quaternions", 1e-12), ("velocities", 1e-8),
                      ("angular_velocities", 1e-8), ("reaction_forces", 1e-8), ("reaction_torques", 1e-8)):
        x, y = getattr(a, name), getattr(b, name)
        np.testing.assert_allclose(y, x, rtol=0, atol=tol * np.abs(x).max(), err_msg=name)
    np.testing.assert_allclose(b.energy[:, :2], a.energy[:, :2], rtol=0, atol=1e-8 * a.energy[:, :2].max())
    assert np.all(b.energy[:, 2] == 0.0)  # counts a constant gravity only
    mass = Simulator(_cantilever(gravity=G)).mass
    np.testing.assert_allclose(b.forces - a.forces, np.broadcast_to(mass[:, None] * G, a.forces.shape), atol=1e-15)


def test_slowly_ramped_gravity_comes_to_rest_where_constant_gravity_does():
    """Gravity ramped in over 1 s (about 3.5 periods) with drag: at 3 s the rod rests where the
    same rod under constant gravity rests, at the Euler-Bernoulli tip deflection q L^4 / (8 E I)."""
    drag = Damping(translational=RHO * AREA * OMEGA1)  # first mode damped at zeta = 0.5
    config = RunConfig(dt=5e-3, n_samples=601)
    const = simulate(_cantilever(gravity=G, damping=drag), config)
    ramped = simulate(_cantilever(gravity=Scheduled(Constant(G), ramp=1.0), damping=drag), config)
    assert np.abs(ramped.velocities[-1]).max() < 1e-9
    np.testing.assert_allclose(ramped.positions[-1], const.positions[-1], rtol=0, atol=1e-9)
    euler_bernoulli = RHO * AREA * 9.81 * L**4 / (8 * E * INERTIA)  # 30.7 mm
    assert -ramped.positions[-1, -1, 2] == pytest.approx(euler_bernoulli, rel=5e-3)


def test_gravity_profiles_in_a_batch_equal_single_runs():
    config = RunConfig(dt=2e-3, n_samples=26)
    setups = [_cantilever(gravity=Scheduled(Constant(G), ramp=ramp)) for ramp in (0.02, 0.04)]
    batch = simulate_batch(setups, config)
    for b, setup in enumerate(setups):
        np.testing.assert_allclose(batch[b].positions, simulate(setup, config).positions, rtol=0, atol=1e-13)
    with pytest.raises(SoftrnnInputError, match=r"setups\[1\]\.gravity"):
        simulate_batch([setups[0], _cantilever(gravity=G)], config)


# --------------------------------------------------------------------------- release
def test_a_released_tip_force_leaves_a_free_oscillation_at_the_first_bending_frequency():
    """A tip force ramped in over 2 s (quasi-static: the tip sits at F L^3 / (3 E I)) and removed
    at t_r = 2.5 s, no damping: afterwards kinetic + elastic energy stays constant and the tip
    swings about the straight shape at the first bending frequency."""
    force, t_release = 0.3, 2.5
    load = NodalLoad(-1, force=Scheduled(Constant((0.0, 0.0, force)), ramp=2.0, release=t_release))
    s = simulate(_cantilever(loads=(load,)), RunConfig(dt=1e-3, n_samples=4001))
    static = force * L**3 / (3 * E * INERTIA)
    held = np.searchsorted(s.time, t_release) - 1
    assert s.positions[held, -1, 2] == pytest.approx(static, rel=2e-3)
    after = s.time > t_release + 1e-3
    assert np.all(s.forces[after] == 0.0)
    energy = s.energy[after, 0] + s.energy[after, 1]
    assert np.ptp(energy) < 1e-5 * energy.mean()
    assert energy.mean() == pytest.approx(0.5 * force * static, rel=1e-2)  # the strain energy at release
    t, z = s.time[after], s.positions[after, -1, 2]
    i = np.flatnonzero((z[:-1] < 0) & (z[1:] >= 0))
    upward = t[i] - z[i] * (t[i + 1] - t[i]) / (z[i + 1] - z[i])
    assert upward.size >= 4
    assert 1.0 / np.diff(upward).mean() == pytest.approx(OMEGA1 / (2 * np.pi), rel=5e-3)
    assert abs(z.max() + z.min()) < 0.05 * static  # about the straight shape
