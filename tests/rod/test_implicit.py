"""The stiff-stable (implicit) integrator: stiff wires at large steps, order of convergence in time,
energy behaviour undamped, the Kelvin-Voigt modal decay rate, a release from a static solution
against a converged reference, and its parity with the explicit integrator on soft rods."""

from dataclasses import replace

import numpy as np
import pytest

from softrnn.errors import SoftrnnInputError
from softrnn.rod import Clamp, Constant, Damping, NodalLoad, RodSpec, RunConfig, Setup, Simulator, straight
from softrnn.rod.discrete import segment_strains
from softrnn.rod.implicit import IMPLICIT_BETA, IMPLICIT_THETA, accuracy_step, bending_frequency
from softrnn.rod.integrators import Explicit, Implicit
from softrnn.rod.loads import Scheduled
from softrnn.rod.shapes import RodShape
from softrnn.scenarios import load_scenario
from softrnn.statics import static_start

from helpers import (
    ORDER_RANGE,
    convergence_order,
    energy_error,
    gravity_release,
    planar_bent_shape,
    smooth_ramp,
    zero_crossing_period,
)

RELEASE_TOL = 0.005        # tip error / L against a converged reference (the goal for stiff wires)
KV_DECAY_RTOL = 0.03       # measured first-mode decay rate vs tau omega_1^2 / 2
ENERGY_BOUND = 1e-4        # max |E - E0| / energy exchanged, undamped whip at the automatic step


def _tip_error(setup, config, refine=8):
    """Max Euclidean tip distance / L between a run and the same run with ``refine`` x more substeps."""
    sim = Simulator(setup)
    run = sim.run(replace(config, save_nodes=(-1,)))
    ref = Simulator(setup).run(replace(config, save_nodes=(-1,), substeps=run.substeps * refine))
    return np.linalg.norm(run.positions - ref.positions, axis=-1).max() / setup.rod.length, run, ref


@pytest.mark.parametrize("name", ["steel-wire", "nitinol-guidewire"])
def test_stiff_wires_released_for_two_seconds_match_a_converged_reference(name):
    """The shipped wires (material damping), released from a bent shape: steps 1e4-1e8 x the
    explicit limit, the tip within 0.5 % of L of an 8x finer run over the whole 2 s (measured:
    0.006 % and 0.003 %)."""
    sc = load_scenario(name)
    explicit_limit = Simulator(sc.setup).stable_step()
    assert explicit_limit < 1e-9  # shear and Kelvin-Voigt: the explicit solver is out of reach
    assert sc.config.dt * (sc.config.n_samples - 1) == pytest.approx(2.0)
    err, run, ref = _tip_error(sc.setup, sc.config)
    assert run.step > 1e4 * explicit_limit
    assert run.step == pytest.approx(min(sc.config.dt, accuracy_step(Simulator(sc.setup).rod)), rel=0.15)
    assert err < RELEASE_TOL
    assert np.linalg.norm(np.ptp(ref.positions[:, 0], axis=0)) > 0.03 * sc.setup.rod.length  # it did swing


def test_release_from_a_static_solution_matches_a_converged_reference():
    """A steel wire bent to equilibrium by a tip force (statics, frames included), the force
    released at t = 0: free vibration with material damping, 1 s, against an 8x finer run."""
    sc = load_scenario("steel-wire")
    setup = sc.setup
    # the force acts at the static start (t = 0) and is released right after it
    pull = NodalLoad(-1, force=Scheduled(Constant((0.0, 0.3, -0.5)), release=1e-9))
    loaded = Setup(rod=setup.rod, reference=setup.reference, boundary=setup.boundary, loads=(pull,),
                   damping=setup.damping, gravity=setup.gravity)
    start = static_start(loaded)
    released = Setup(rod=setup.rod, reference=setup.reference, initial=start, boundary=setup.boundary,
                     loads=(pull,), damping=setup.damping, gravity=setup.gravity)
    err, run, ref = _tip_error(released, replace(sc.config, n_samples=1001))
    assert err < RELEASE_TOL
    swing = np.linalg.norm(ref.positions[:, 0] - ref.positions[0, 0], axis=-1).max()
    assert swing > 0.05 * setup.rod.length


def test_second_order_convergence_in_time():
    """The large-deflection 3-D cantilever of the explicit test, at steps 3-24x the explicit limit."""
    n, L = 10, 0.2
    rod = RodSpec(length=L, radius=0.01, youngs_modulus=1e6, density=1000, n_nodes=n)
    setup = Setup(rod=rod, reference=straight(n, L, direction=(1, 0, 0), normal=(0, 0, 1)), boundary=(Clamp(0),),
                  loads=(NodalLoad(-1, force=smooth_ramp((0.05, 0.1, -0.3), 2.0)),
                         NodalLoad(-1, torque=smooth_ramp((0.0, 0.0, 0.01), 2.0), frame="body")))
    base = max(1, int(np.ceil(0.025 / (24 * Simulator(setup).stable_step()))))
    order, err = convergence_order(setup, integrator="implicit", base=base)
    assert err[0] > 1e-7 * L
    assert ORDER_RANGE[0] < order < ORDER_RANGE[1], (order, err)


def test_undamped_energy_is_bounded_at_the_automatic_step():
    """The horizontal cantilever whipping down in gravity (large motion) at the automatic step
    (3.3x the explicit one here): the total energy oscillates within a bound and does not drift."""
    sim = Simulator(gravity_release())
    h = accuracy_step(sim.rod)
    assert h > 3 * sim.stable_step()
    err, traj = energy_error(sim, 20_000, h, integrator="implicit")
    assert traj.positions[:, -1, 2].min() < -0.5 * 0.2
    assert np.abs(err).max() < ENERGY_BOUND
    tenth = err.size // 10
    assert abs(err[-tenth:].mean() - err[:tenth].mean()) < ENERGY_BOUND / 2


def test_kelvin_voigt_decay_rate_matches_the_modal_formula():
    """Kelvin-Voigt damping D = tau C damps mode k at the rate tau omega_k^2 / 2: a slender
    cantilever released from its first-mode-like static shape decays at tau omega_1^2 / 2. (The
    explicit integrator needs 6e-7 s steps for this rod and damping: 30 s of test.)"""
    n, L, r, E, rho, tau = 20, 0.2, 0.002, 1e7, 1000.0, 1e-3
    rod = RodSpec(length=L, radius=r, youngs_modulus=E, density=rho, n_nodes=n)
    s = np.linspace(0, L, n)
    tip = 1e-3 * L
    angles = 3 * tip / L**3 * (L * s - s**2 / 2)
    setup = Setup(rod=rod, reference=straight(n, L, direction=(1, 0, 0), normal=(0, 0, 1)),
                  initial=planar_bent_shape(angles, L / (n - 1)), boundary=(Clamp(0),),
                  damping=Damping(kelvin_voigt=tau))
    omega1 = 1.8751**2 * np.sqrt(E * np.pi * r**4 / 4 / (rho * np.pi * r**2 * L**4))
    T1 = 2 * np.pi / omega1
    traj = Simulator(setup).run(RunConfig(dt=T1 / 100, n_samples=10 * 100 + 1, save_nodes=(-1,),
                                          integrator="implicit"))
    z = traj.positions[:, 0, 2]
    # from the fourth period on: the second mode (39x faster decay) is gone
    peaks = [np.abs(z[i * 100:(i + 1) * 100]).max() for i in range(4, 10)]
    rate = -np.polyfit(np.arange(4, 10) * T1, np.log(peaks), 1)[0]
    omega_measured = 2 * np.pi / zero_crossing_period(traj.time, z)[0]
    assert rate == pytest.approx(tau * omega_measured**2 / 2, rel=KV_DECAY_RTOL)
    assert rate > 0.1 / (10 * T1)  # a clearly damped signal


def test_soft_rod_agrees_with_the_explicit_integrator():
    """A soft paper-like rod under a ramped tip load: both integrators at their automatic steps give
    the same motion to a small fraction of the deflection."""
    n, L = 21, 0.5
    rod = RodSpec(length=L, radius=0.01, youngs_modulus=2.5e6, density=1000, n_nodes=n)
    setup = Setup(rod=rod, reference=straight(n, L, direction=(1, 0, 0), normal=(0, 0, 1)), boundary=(Clamp(0),),
                  gravity=(0, 0, -9.81), damping=Damping(translational=0.01, rotational=1e-6),
                  loads=(NodalLoad(-1, force=smooth_ramp((0.0, 0.05, 0.0), 1.0)),))
    config = RunConfig(dt=0.01, n_samples=101, save_nodes=(-1,))
    explicit = Simulator(setup).run(config)
    implicit = Simulator(setup).run(replace(config, integrator="implicit"))
    assert implicit.step > 3 * explicit.step
    deflection = np.abs(explicit.positions[:, 0] - explicit.positions[0, 0]).max()
    assert np.abs(implicit.positions - explicit.positions).max() < 0.01 * deflection


def test_bending_frequency_estimate_and_unknown_integrator():
    sc = load_scenario("steel-wire")
    rod = Simulator(sc.setup).rod
    L, r, E, rho = 0.6, 0.0008, 200e9, 7850.0
    omega1 = 1.8751**2 * np.sqrt(E * r**2 / 4 / (rho * L**4))
    assert bending_frequency(rod, 1) == pytest.approx(omega1 * (0.5 * np.pi) ** 2 / 1.8751**2, rel=0.01)
    with pytest.raises(ValueError, match="integrator"):
        RunConfig(dt=0.01, n_samples=2, integrator="rk4")
    assert isinstance(sc.setup.initial, RodShape)


def _moving_clamp(t):
    """The base slides along y and turns about z: smooth, from rest."""
    s = 0.5 * (1 - np.cos(2 * np.pi * t))
    pos = np.zeros((t.size, 3))
    pos[:, 1] = 0.05 * s
    angle = 0.3 * s
    c, si = np.cos(angle), np.sin(angle)
    R = np.zeros((t.size, 3, 3))
    # the straight reference frame (d1 = z, d3 = x) turned about z
    R[:, 0, 2], R[:, 1, 2] = c, si
    R[:, 0, 1], R[:, 1, 1] = si, -c
    R[:, 2, 0] = 1.0
    return pos, R


def test_a_moving_clamp_drives_the_rod_like_the_explicit_integrator():
    """A clamp with a prescribed sliding and turning motion: the implicit run follows the explicit
    one, the clamp node follows its motion exactly and the mean reactions agree."""
    n, L = 21, 0.4
    rod = RodSpec(length=L, radius=0.005, youngs_modulus=5e6, density=1000, n_nodes=n)
    ref = straight(n, L, direction=(1, 0, 0), normal=(0, 0, 1))
    assert np.allclose(_moving_clamp(np.zeros(1))[1][0], ref.rotations[0])
    setup = Setup(rod=rod, reference=ref, boundary=(Clamp(0, motion=_moving_clamp),), gravity=(0, 0, -9.81),
                  damping=Damping(translational=0.05))
    config = RunConfig(dt=0.005, n_samples=201)
    explicit = Simulator(setup).run(config)
    implicit = Simulator(setup).run(replace(config, integrator="implicit"))
    motion = np.abs(explicit.positions[:, -1] - explicit.positions[0, -1]).max()
    assert motion > 0.05
    assert np.abs(implicit.positions - explicit.positions).max() < 0.01 * motion
    np.testing.assert_allclose(implicit.positions[:, 0], _moving_clamp(implicit.time)[0], atol=1e-12)
    # the clamp's reaction carries the rod along: on average, its weight and its momentum change
    np.testing.assert_allclose(implicit.reaction_forces[:, 0].mean(0), explicit.reaction_forces[:, 0].mean(0),
                               atol=0.02 * np.abs(explicit.reaction_forces[:, 0]).max())


def test_an_explicit_stiff_wire_run_is_refused_with_the_implicit_integrator_as_the_fix():
    sc = load_scenario("steel-wire")
    with pytest.raises(SoftrnnInputError, match=r"solver steps .* the implicit integrator"):
        Simulator(sc.setup).run(replace(sc.config, integrator="explicit"))


def test_a_simulator_switches_between_the_integrators():
    """Runs of one simulator may alternate integrators (a control loop choosing per phase): after an
    implicit run the explicit step's Kelvin-Voigt memory holds the current strains, and the explicit
    run that follows tracks an all-explicit one."""
    n, L = 11, 0.2
    rod = RodSpec(length=L, radius=0.004, youngs_modulus=1e6, density=1000, n_nodes=n)
    setup = Setup(rod=rod, reference=straight(n, L, direction=(1, 0, 0), normal=(0, 0, 1)), boundary=(Clamp(0),),
                  gravity=(0, 0, -9.81), damping=Damping(kelvin_voigt=1e-4))
    config = RunConfig(dt=0.002, n_samples=11)
    both = Simulator(setup)
    both.run(replace(config, integrator="implicit", substeps=40))
    K, G = segment_strains(both.state.rotations, both.state.positions, both.seg_length)
    np.testing.assert_array_equal(both.state.prev_curvature, K)
    np.testing.assert_array_equal(both.state.prev_shear, G)
    assert np.abs(K).max() > 0.1  # the rod has bent since the start
    mixed = both.run(config)
    explicit = Simulator(setup)
    explicit.run(config)
    ref = explicit.run(config)
    sag = np.abs(ref.positions[:, -1, 2]).max()
    assert np.abs(mixed.positions[:, -1] - ref.positions[:, -1]).max() < 0.02 * sag


def test_integrators_are_typed_values_and_their_names_still_work():
    """``RunConfig.integrator`` holds an ``Explicit``/``Implicit`` value (the names are converted);
    ``Implicit`` carries its options, checked; a run with the default options is the named run's."""
    assert RunConfig(dt=0.01, n_samples=2).integrator == Explicit()
    assert RunConfig(dt=0.01, n_samples=2, integrator="implicit").integrator == Implicit()
    assert (Implicit().beta, Implicit().theta) == (IMPLICIT_BETA, IMPLICIT_THETA)
    assert str(Implicit(beta=1.0)) == "implicit" and Explicit().name == "explicit"
    for bad_options in ({"beta": 0.1}, {"theta": 1.5}, {"beta": float("nan")}):
        with pytest.raises(ValueError, match="integrator"):
            Implicit(**bad_options)
    sc = load_scenario("steel-wire")
    config = replace(sc.config, n_samples=6, save_nodes=(-1,), substeps=40)
    named = Simulator(sc.setup).run(replace(config, integrator="implicit"))
    typed = Simulator(sc.setup).run(replace(config, integrator=Implicit(beta=IMPLICIT_BETA, theta=IMPLICIT_THETA)))
    assert np.array_equal(named.positions, typed.positions)
    other = Simulator(sc.setup).run(replace(config, integrator=Implicit(beta=1.0)))
    assert not np.array_equal(named.positions, other.positions)


def test_the_kernel_stamp_covers_every_kernel_module():
    """The cached kernels are rebuilt when any module whose helpers they inline changes: every
    ``*kernel*.py`` of ``softrnn.rod`` is in ``KERNEL_FILES``, and the stamp hashes them."""
    from pathlib import Path

    from softrnn.rod import kernel_records

    folder = Path(kernel_records.__file__).parent
    assert set(kernel_records.KERNEL_FILES) == {p.name for p in folder.glob("*kernel*.py")}
    stamp = kernel_records.kernel_stamp()
    assert 0 <= stamp < 16**15 and stamp == kernel_records.kernel_stamp()
