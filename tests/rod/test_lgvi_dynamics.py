"""Dynamics of the LGVI: bending frequency, energy behaviour, discrete Noether momenta,
convergence order in time, the stability limit and its guard, input validation and mirror
symmetry (lgvi.md §2.3-2.8, §2.10, §3)."""

import re

import numpy as np
import pytest
import scipy.linalg

from softrnn.errors import SimulationError, SoftrnnInputError
from softrnn.rod import (
    Clamp,
    Constant,
    Damping,
    NodalLoad,
    RodSpec,
    RunConfig,
    Setup,
    Simulator,
    Window,
    arc,
    kernels,
    polyline,
    straight,
)
from softrnn.rod.discrete import internal_loads
from softrnn.rod.shapes import RodShape
from softrnn.rod.so3 import cay

from helpers import (
    ORDER_RANGE,
    convergence_order,
    energy_error,
    gravity_release,
    kernel_step,
    planar_bent_shape,
    smooth_ramp,
    zero_crossing_period,
)

FREQUENCY_RTOL = 0.02            # first bending frequency vs Euler-Bernoulli
ENERGY_BOUND = 1e-5              # max |E - E0| / energy exchanged, undamped, 1e5 steps
ENERGY_DRIFT = 1e-6              # |mean error of last tenth - first tenth| / energy exchanged
MOMENTUM_RTOL = 1e-12            # discrete Noether momenta, relative to their natural scale
SYMMETRY_TOL = 1e-10             # mirror asymmetry / displacement
LIMIT_RTOL = 1e-9                # stable_step(safety=1) <= 2/omega_max(exact) within round-off


# --------------------------------------------------------------------------- frequency
@pytest.mark.parametrize("integrator", ["explicit", "implicit"])
def test_cantilever_first_bending_frequency(integrator):
    """Slender (L/r = 50) undamped cantilever released from its small static tip-load shape; the
    tip oscillates at omega_1 = 1.8751^2 sqrt(EI/(rho A L^4)) (rotary inertia and shear lower it by
    ~0.1 % at this slenderness)."""
    n, L, r, E, rho = 50, 0.2, 0.004, 1e7, 1000.0
    A, I = np.pi * r**2, np.pi * r**4 / 4
    omega1 = 1.8751**2 * np.sqrt(E * I / (rho * A * L**4))
    T1 = 2 * np.pi / omega1
    s = np.linspace(0, L, n)
    tip = 1e-3 * L
    angles = 3 * tip / L**3 * (L * s - s**2 / 2)  # slope of the static tip-load deflection
    rod = RodSpec(length=L, radius=r, youngs_modulus=E, density=rho, n_nodes=n)
    setup = Setup(rod=rod, reference=straight(n, L, direction=(1, 0, 0), normal=(0, 0, 1)),
                  initial=planar_bent_shape(angles, L / (n - 1)), boundary=(Clamp(0),))
    traj = Simulator(setup).run(RunConfig(dt=T1 / 200, n_samples=8 * 200 + 1, save_nodes=(-1,),
                                          integrator=integrator))
    z = traj.positions[:, 0, 2]
    assert np.abs(z).max() == pytest.approx(tip, rel=0.05)  # small amplitude, no damping
    period, crossings = zero_crossing_period(traj.time, z)
    assert crossings >= 15
    omega = 2 * np.pi / period
    assert omega == pytest.approx(omega1, rel=FREQUENCY_RTOL)  # measured: 0.12 % low


# --------------------------------------------------------------------------- energy
def test_undamped_energy_is_bounded_without_drift():
    sim = Simulator(gravity_release())
    h = sim.stable_step()
    err, traj = energy_error(sim, 100_000, h)
    assert traj.positions[:, -1, 2].min() < -0.5 * 0.2  # a large motion, many swings
    assert np.abs(err).max() < ENERGY_BOUND
    tenth = err.size // 10
    assert abs(err[-tenth:].mean() - err[:tenth].mean()) < ENERGY_DRIFT
    # the error is the O(h^2) energy oscillation of a symplectic scheme: halving h quarters it
    sim2 = Simulator(gravity_release())
    err2, _ = energy_error(sim2, 40_000, h / 2)
    ratio = np.abs(err[: err.size * 2 // 10]).max() / np.abs(err2).max()
    assert 3.0 < ratio < 5.5, ratio


@pytest.mark.parametrize("integrator", ["explicit", "implicit"])
def test_damping_dissipates_energy(integrator):
    setup = gravity_release()
    setup = Setup(rod=setup.rod, reference=setup.reference, boundary=setup.boundary, gravity=setup.gravity,
                  damping=Damping(translational=0.5, rotational=1e-5))
    traj = Simulator(setup).run(RunConfig(dt=0.01, n_samples=301, integrator=integrator))
    total = traj.energy.sum(axis=1)
    exchanged = np.ptp(traj.energy[:, 2])
    # non-increasing up to the O(h^2) energy oscillation of the undamped scheme
    assert np.diff(total).max() < ENERGY_BOUND * exchanged
    assert total[-1] < total[0] - 0.5 * exchanged


# --------------------------------------------------------------------------- momenta
def _momenta(sim, h):
    """P = sum m v^k and L = sum r^k x m v^k + Lambda^k pi(omega^k) (lgvi.md §2.10 item 5).

    After a run the state holds r^{k+1}, Lambda^{k+1} and the staggered v^k, omega^k of the step
    just taken, so r^k = r^{k+1} - h v^k and Lambda^k = Lambda^{k+1} cay(h omega^k)^T. Also returns
    the natural scales of P and L and, as a control, Lambda^{k+1} pi(omega^k) (wrong time index)."""
    st = sim.state
    m, J = sim.mass[:, None], sim.inertia
    v, w = st.velocities, st.angular_velocities
    r0 = st.positions - h * v
    R0 = st.rotations @ np.swapaxes(cay(h * w), 1, 2)
    Jw = J * w
    pi = Jw + 0.5 * h * np.cross(w, Jw) + 0.25 * h * h * np.sum(w * Jw, 1, keepdims=True) * w
    P = np.sum(m * v, 0)
    lin = np.cross(r0, m * v)
    Lm = lin.sum(0) + np.einsum("aij,aj->i", R0, pi)
    wrong = lin.sum(0) + np.einsum("aij,aj->i", st.rotations, pi)
    scale_P = np.sum(m * np.abs(v))
    scale_L = np.sum(np.abs(lin)) + np.sum(np.abs(pi))
    return P, Lm, scale_P, scale_L, wrong


@pytest.mark.parametrize("integrator", ["explicit", "implicit"])
def test_free_rod_conserves_linear_and_angular_momentum(integrator):
    n, L = 10, 0.2
    rod = RodSpec(length=L, radius=0.01, youngs_modulus=1e6, density=1000, n_nodes=n)
    s = np.linspace(0, 1, n)
    initial = planar_bent_shape(0.8 * np.sin(2.5 * s), L / (n - 1))  # released from a bent shape
    kick = 0.005  # s: a push and a body torque, then no loads at all
    setup = Setup(rod=rod, reference=straight(n, L, direction=(1, 0, 0), normal=(0, 0, 1)), initial=initial,
                  loads=(NodalLoad(2, force=Window(Constant((0.0, 1.0, 0.3)), 0.0, kick)),
                         NodalLoad(7, torque=Window(Constant((1e-2, 2e-2, -1e-2)), 0.0, kick), frame="body")))
    sim = Simulator(setup)
    chunk = 300
    traj = sim.run(RunConfig(dt=chunk * sim.stable_step(), n_samples=2, substeps=chunk, integrator=integrator))
    h = traj.step
    assert chunk * h > 2 * kick
    P0, L0, sP, sL, wrong0 = _momenta(sim, h)
    # the kick's impulse: the force acts at t_k = k h < kick, h F per step, less the half step
    # that the rest start (half-kick, v^-1 = -(h/2) f/m) assigns to before t0
    kicked_steps = int(np.count_nonzero(np.arange(chunk) * h < kick))
    np.testing.assert_allclose(P0, (kicked_steps - 0.5) * h * np.array([0.0, 1.0, 0.3]), atol=MOMENTUM_RTOL * sP)
    assert np.linalg.norm(P0) > 0.02 * sP and np.linalg.norm(L0) > 0.02 * sL  # both clearly nonzero
    wrong_drift = 0.0
    for _ in range(10):
        sim.run(RunConfig(dt=chunk * h, n_samples=2, substeps=chunk, integrator=integrator))
        P, Lm, sP, sL, wrong = _momenta(sim, h)
        assert np.abs(P - P0).max() < MOMENTUM_RTOL * sP
        assert np.abs(Lm - L0).max() < MOMENTUM_RTOL * sL
        wrong_drift = max(wrong_drift, np.abs(wrong - wrong0).max())
    # control: pairing omega^k with Lambda^{k+1} is not conserved, so the check above is sharp
    assert wrong_drift > 1e3 * MOMENTUM_RTOL * sL
    # and the rod did move and deform a lot
    assert np.abs(sim.state.angular_velocities).max() > 10.0


# --------------------------------------------------------------------------- convergence in h
def test_second_order_convergence_in_time():
    """3-D large-deflection cantilever under a smoothly ramped tip force and body torque, starting
    at rest in equilibrium; positions at the same saved times vs a 64x finer reference."""
    n, L = 10, 0.2
    rod = RodSpec(length=L, radius=0.01, youngs_modulus=1e6, density=1000, n_nodes=n)
    setup = Setup(rod=rod, reference=straight(n, L, direction=(1, 0, 0), normal=(0, 0, 1)), boundary=(Clamp(0),),
                  loads=(NodalLoad(-1, force=smooth_ramp((0.05, 0.1, -0.3), 2.0)),
                         NodalLoad(-1, torque=smooth_ramp((0.0, 0.0, 0.01), 2.0), frame="body")))
    order, err = convergence_order(setup)
    assert err[0] > 100 * np.finfo(float).eps * L  # far above round-off
    assert ORDER_RANGE[0] < order < ORDER_RANGE[1], (order, err)


def test_second_order_convergence_when_released_from_a_static_shape():
    """The cantilever is bent to rest by a tip force and couple (with damping), then released: no
    loads, no damping, starting at rest out of equilibrium. Steps well below the stability limit so
    the few high modes excited by the point loads are resolved."""
    n, L = 10, 0.2
    rod = RodSpec(length=L, radius=0.01, youngs_modulus=1e6, density=1000, n_nodes=n)
    ref = straight(n, L, direction=(1, 0, 0), normal=(0, 0, 1))
    pre = Simulator(Setup(rod=rod, reference=ref, boundary=(Clamp(0),),
                          damping=Damping(translational=8.0, rotational=1e-3),
                          loads=(NodalLoad(-1, force=Constant((0.0, 0.1, -0.3))),
                                 NodalLoad(-1, torque=Constant((0.0, 0.0, 0.01)), frame="body"))))
    pre.run(RunConfig(dt=0.1, n_samples=31))
    assert np.abs(pre.state.velocities).max() < 1e-9 and np.abs(pre.state.angular_velocities).max() < 1e-9
    setup = Setup(rod=rod, reference=ref, initial=RodShape(pre.state.positions, pre.state.rotations),
                  boundary=(Clamp(0),))
    order, err = convergence_order(setup, dt=0.0125, levels=(4, 8, 16, 32), ref=256)
    assert ORDER_RANGE[0] < order < ORDER_RANGE[1], (order, err)


# --------------------------------------------------------------------------- stability limit
def _rod_sim(n=12, L=0.2, r=0.01, E=1e7, nu=0.3, boundary=(), initial_noise=0.0):
    rod = RodSpec(length=L, radius=r, youngs_modulus=E, density=1000, n_nodes=n, poisson_ratio=nu)
    ref = straight(n, L, direction=(1, 0, 0), normal=(0, 0, 1))
    initial = None
    if initial_noise:
        rng = np.random.default_rng(5)
        initial = polyline(ref.positions + initial_noise * L / (n - 1) * rng.normal(size=(n, 3)), ref.rotations)
    return Simulator(Setup(rod=rod, reference=ref, initial=initial, boundary=boundary))


def exact_omega_max(sim, eps=1e-7):
    """Highest angular frequency of the free rod linearised about its straight reference: generalised
    eigenvalues of the finite-difference stiffness (of discrete.internal_loads) and the lumped masses."""
    R0, r0 = sim.setup.reference.rotations, sim.setup.reference.positions
    n = r0.shape[0]
    K = np.zeros((6 * n, 6 * n))
    for a in range(n):
        for i in range(6):
            cols = []
            for sgn in (1, -1):
                R, r = R0.copy(), r0.copy()
                e = np.zeros(3)
                e[i % 3] = sgn * eps
                if i < 3:
                    r[a] += e
                else:
                    R[a] = R[a] @ cay(e)
                f, t = internal_loads(R, r, sim.seg_length, sim.C1, sim.C2, sim.K0, sim.G0)
                cols.append(np.concatenate([f, t], 1).reshape(-1))
            K[:, 6 * a + i] = -(cols[0] - cols[1]) / (2 * eps)
    M = np.concatenate([np.repeat(sim.mass[:, None], 3, 1), sim.inertia], 1).reshape(-1)
    w2 = scipy.linalg.eigh(0.5 * (K + K.T), np.diag(M), eigvals_only=True)
    return float(np.sqrt(w2.max()))


@pytest.mark.parametrize("params", [
    dict(n=12, L=0.2, r=0.01, E=1e7, nu=0.3),    # shear-rotary limited
    dict(n=30, L=1.0, r=0.002, E=1e6, nu=0.5),   # thin: shear-rotary cut-off
    dict(n=21, L=1.0, r=0.01, E=1e5, nu=0.45),   # axial limited (lgvi.md §3 table row 3 scaled)
])
def test_stable_step_respects_exact_linear_limit(params):
    sim = _rod_sim(**params)
    h_exact = 2.0 / exact_omega_max(sim)
    h_est = sim.stable_step(safety=1.0)
    assert h_est <= h_exact * (1 + LIMIT_RTOL)
    assert h_est > 0.85 * h_exact  # and not needlessly small (lgvi.md §3: estimate within ~10 %)


def _kernel_run(sim, h, n_steps):
    st = sim.state.copy()
    code, step, out = kernel_step(st.rotations, st.positions, st.velocities, st.angular_velocities,
                                  l=sim.seg_length, C1=sim.C1, C2=sim.C2, K0=sim.K0, G0=sim.G0, mass=sim.mass,
                                  inertia=sim.inertia, h=h, n_steps=n_steps, kind=sim.kind)
    return code, step, st, out


def test_kernel_is_stable_below_and_diverges_above_the_limit_without_nans():
    sim = _rod_sim(initial_noise=1e-7)
    h_exact = 2.0 / exact_omega_max(sim)
    code, _, st, _ = _kernel_run(sim, 0.95 * h_exact, 4000)
    assert code == kernels.OK
    assert np.abs(st.positions - sim.state.positions).max() < 1e-5 * sim.seg_length
    for factor in (1.3, 10.0, 1e4):
        code, step, st, out = _kernel_run(sim, factor * h_exact, 4000)
        assert code in (kernels.DIVERGED, kernels.NEWTON_FAILED), factor
        assert step < 4000
        for arr in (st.positions, st.rotations, st.velocities, st.angular_velocities):
            assert np.all(np.isfinite(arr)), factor
        assert np.all(np.isfinite(out["r"][:step])) and np.all(np.isfinite(out["e"][:step]))


def test_simulator_raises_simulation_error_when_unstable(monkeypatch):
    sim = _rod_sim(boundary=(Clamp(0),), initial_noise=1e-7)
    h_limit = sim.stable_step(safety=1.0)
    monkeypatch.setattr(sim, "stable_step", lambda safety=0.6: 1.0)  # defeat the guard
    with pytest.raises(SimulationError, match="substeps"):
        sim.run(RunConfig(dt=100 * 1.5 * h_limit, n_samples=11, substeps=100))
    for arr in (sim.state.positions, sim.state.rotations, sim.state.velocities, sim.state.angular_velocities):
        assert np.all(np.isfinite(arr))


@pytest.mark.parametrize("factor", [1.0001, 2.0, 50.0])
def test_explicit_substeps_beyond_the_limit_are_refused(factor):
    sim = _rod_sim(boundary=(Clamp(0),))
    limit = sim.stable_step()
    substeps = 4
    config = RunConfig(dt=factor * limit * substeps, n_samples=3, substeps=substeps)
    with pytest.raises(SoftrnnInputError, match="substeps") as info:
        sim.run(config)
    assert f"{limit:.3g}" in str(info.value)
    assert re.search(r"substeps >= \d+", str(info.value))
    need = int(re.search(r"substeps >= (\d+)", str(info.value)).group(1))
    assert config.dt / need <= limit  # the advice is right
    # the same interval with automatic substeps runs, at a step within the limit
    traj = sim.run(RunConfig(dt=config.dt, n_samples=3))
    assert traj.step <= limit and traj.substeps == need


def test_automatic_substeps_are_the_fewest_stable():
    sim = _rod_sim()
    limit = sim.stable_step()
    for dt in (0.5 * limit, limit, 3.7 * limit, 25 * limit):
        traj = sim.run(RunConfig(dt=dt, n_samples=2))
        assert traj.step <= limit * (1 + 1e-12)
        assert traj.substeps == 1 or dt / (traj.substeps - 1) > limit


# --------------------------------------------------------------------------- input validation
GOOD = dict(length=0.2, radius=0.01, youngs_modulus=1e7, density=1000.0, n_nodes=11)


@pytest.mark.parametrize("name,value", [
    ("length", 0.0), ("length", -0.2), ("radius", 0.0), ("radius", -0.01), ("youngs_modulus", 0.0),
    ("youngs_modulus", -1e7), ("density", 0.0), ("density", -1000.0), ("n_nodes", 1), ("n_nodes", 0),
    ("n_nodes", -5), ("length", float("nan")), ("radius", float("inf")), ("n_nodes", 10.0),
])
def test_bad_rod_spec_names_argument_and_value(name, value):
    with pytest.raises(SoftrnnInputError, match=re.escape(f"{name}={value!r}")):
        RodSpec(**{**GOOD, name: value})


def test_bad_run_config_and_setup():
    with pytest.raises(SoftrnnInputError, match=r"dt=0\.0"):
        RunConfig(dt=0.0, n_samples=10)
    with pytest.raises(SoftrnnInputError, match="n_samples=0"):
        RunConfig(dt=1e-3, n_samples=0)
    with pytest.raises(SoftrnnInputError, match="substeps=0"):
        RunConfig(dt=1e-3, n_samples=10, substeps=0)
    with pytest.raises(SoftrnnInputError, match=r"safety=1\.5"):
        RunConfig(dt=1e-3, n_samples=10, safety=1.5)
    rod = RodSpec(**GOOD)
    with pytest.raises(SoftrnnInputError, match="reference.n_nodes=12"):
        Setup(rod=rod, reference=straight(12, 0.2))
    with pytest.raises(SoftrnnInputError, match="gravity"):
        Setup(rod=rod, reference=straight(11, 0.2), gravity=(0, 0, float("nan")))


# --------------------------------------------------------------------------- symmetry
@pytest.mark.parametrize("push", [(0.0, -0.5, 0.0), (0.0, 0.0, 0.3), (0.0, -0.4, 0.3)])
@pytest.mark.parametrize("integrator", ["explicit", "implicit"])
def test_semicircle_clamped_at_both_ends_responds_symmetrically(push, integrator):
    """Semicircle from the origin along +y bending toward +x, ends clamped at (0,0,0) and (2 rho,0,0),
    pushed at its middle node: the motion is mirror symmetric about the plane x = rho (node a <->
    node n-1-a, x -> 2 rho - x), including out-of-plane pushes that bend and twist it."""
    n, L = 21, 0.5
    rho = L / np.pi
    rod = RodSpec(length=L, radius=0.01, youngs_modulus=1e6, density=1000, n_nodes=n)
    shape = arc(n, L, rho, tangent=(0, 1, 0), inward=(1, 0, 0))
    mid = (n - 1) // 2
    setup = Setup(rod=rod, reference=shape, boundary=(Clamp(0), Clamp(-1)), damping=Damping(translational=0.5),
                  gravity=(0, 0, -9.81), loads=(NodalLoad(mid, force=Window(Constant(push), 0.0, 0.1)),))
    traj = Simulator(setup).run(RunConfig(dt=1e-3, n_samples=301, integrator=integrator))
    p, v, rf = traj.positions, traj.velocities, traj.reaction_forces
    disp = np.abs(p - shape.positions).max()
    assert disp > 0.1 * rho
    mirror = lambda x, flip: x[:, ::-1] * flip  # noqa: E731
    p_m = mirror(p, [-1, 1, 1])
    p_m[..., 0] += 2 * rho
    assert np.abs(p - p_m).max() < SYMMETRY_TOL * disp
    assert np.abs(v - mirror(v, [-1, 1, 1])).max() < SYMMETRY_TOL * np.abs(v).max()
    assert np.abs(rf - mirror(rf, [-1, 1, 1])).max() < 1e-8 * np.abs(rf).max()
    # the middle node stays on the mirror plane
    assert np.abs(p[:, mid, 0] - rho).max() < SYMMETRY_TOL * disp
