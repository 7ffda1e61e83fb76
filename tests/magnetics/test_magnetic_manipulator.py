"""The magnetic manipulator in the dynamic simulator: zero-current motion, gravity sag, torque balance in
a near-uniform field, wrenches recomputed from the pose, determinism, current inputs, bad input."""

import math

import numpy as np
import pytest

from softrnn.errors import SoftrnnInputError
from softrnn.magnetics import (
    CurrentSchedule,
    Magnet,
    ManipulatorRun,
    ManipulatorSpec,
    bigmag_like,
    currents_for_field,
    field,
    gradient,
    random_currents,
    simulate_manipulator,
    wrench,
)
from softrnn.rod import Damping, RunConfig, Simulator

L = 0.05


def _tangent_angles(traj):
    """Angle [rad] of every node's tangent d3 in the xz-plane, positive toward +z: (S, n)."""
    d3 = traj.rod.rotations()[..., 2]
    return np.arctan2(d3[..., 2], d3[..., 0])


def _linear_tip_sag(spec, g):
    """Tip deflection [m] of the lumped rod by linear beam theory: node weights m_a g, piecewise EI."""
    lump = spec.rod_spec().lumped()
    l = spec.segment_length
    s_nodes = l * np.arange(spec.n_nodes)
    EI = lump["C2"][:, 0]
    weights = lump["mass"] * g
    delta = 0.0
    for a in range(spec.n_nodes - 1):
        s = s_nodes[a] + l * (np.arange(200) + 0.5) / 200          # midpoint rule inside segment a
        M = np.sum(weights[None, :] * np.clip(s_nodes[None, :] - s[:, None], 0.0, None), axis=1)
        delta += np.sum(M * (L - s)) * (l / 200) / EI[a]
    return delta


# --------------------------------------------------------------------------- the model
def test_magnet_segments_conserve_mass_and_are_stiff():
    spec = ManipulatorSpec()
    lump = spec.rod_spec().lumped()
    area = math.pi * (0.5 * spec.diameter) ** 2
    extra = sum((m.density - spec.density) * m.volume for m in spec.magnets)
    assert np.sum(lump["mass"]) == pytest.approx(spec.density * area * L + extra, rel=1e-12)
    assert [spec.magnet_node_range(j) for j in range(2)] == [(12, 13), (24, 25)]
    EI = lump["C2"][:, 0]
    EI_rod = spec.youngs_modulus * math.pi * (0.5 * spec.diameter) ** 4 / 4
    np.testing.assert_allclose(EI[[12, 24]], 100 * EI_rod, rtol=1e-12)
    np.testing.assert_allclose(np.delete(EI, [12, 24]), EI_rod, rtol=1e-12)
    # the true 41.4 GPa magnets: ~13x smaller stable step (sqrt of the stiffness ratio over the mass ratio)
    true = ManipulatorSpec(magnet_stiffness_factor=None)
    assert true.rod_spec().lumped()["C2"][12, 0] == pytest.approx(41.4e9 * EI_rod / spec.youngs_modulus)
    assert 8 < spec.stable_step() / true.stable_step() < 20


def test_scaled_spec_perturbs_stiffness_remanence_and_damping():
    spec = ManipulatorSpec()
    real = spec.scaled(stiffness=1.05, remanence=0.97, damping=1.2)
    assert real.youngs_modulus == pytest.approx(1.05 * spec.youngs_modulus)
    assert [m.br for m in real.magnets] == pytest.approx([0.97 * 1.30, 0.97 * 1.35])
    assert real.damping.translational == pytest.approx(1.2 * spec.damping.translational)
    assert spec.magnets[0].br == 1.30                                   # the nominal spec is unchanged
    with pytest.raises(SoftrnnInputError, match="stiffness=-1.0 is invalid"):
        spec.scaled(stiffness=-1.0)


# --------------------------------------------------------------------------- zero current: pure gravity
def test_zero_current_is_the_plain_rod_simulation():
    spec = ManipulatorSpec()
    run = ManipulatorRun(dt=0.005, n_samples=5)
    traj = simulate_manipulator(spec, np.zeros((run.n_samples, 6)), run)
    ref = Simulator(spec.setup()).run(RunConfig(dt=run.dt, n_samples=run.n_samples, substeps=traj.substeps))
    np.testing.assert_allclose(traj.positions, ref.positions, rtol=0, atol=1e-15)
    np.testing.assert_allclose(traj.quaternions, ref.quaternions, rtol=0, atol=1e-14)
    np.testing.assert_allclose(traj.rod.energy, ref.energy, rtol=1e-12, atol=1e-18)
    assert np.all(traj.wrenches == 0) and np.all(traj.fields == 0)
    assert traj.positions[-1, -1, 2] < -1e-3                          # it is falling


def test_settled_gravity_sag_matches_linear_beam_theory():
    run = ManipulatorRun(dt=0.01, n_samples=2, settle=0.6)
    # small deflection (g / 10): the lumped rod against linear theory with the same node weights
    spec = ManipulatorSpec(gravity=(0.0, 0.0, -0.981))
    traj = simulate_manipulator(spec, np.zeros((2, 6)), run)
    sag = -traj.positions[-1, -1, 2]
    assert sag == pytest.approx(_linear_tip_sag(spec, 0.981), rel=5e-3)
    assert np.max(np.abs(traj.rod.velocities[-1])) < 1e-4
    # full gravity: ~8 mm by linear theory (magnetic.md §1.3); the large deflection sags a little less
    spec = ManipulatorSpec()
    traj = simulate_manipulator(spec, np.zeros((2, 6)), run)
    sag, linear = -traj.positions[-1, -1, 2], _linear_tip_sag(spec, 9.81)
    assert linear == pytest.approx(8.0e-3, rel=0.04)
    assert 0.9 * linear < sag < linear


# --------------------------------------------------------------------------- a near-uniform field
@pytest.fixture(scope="module")
def step_responses():
    """Zero gravity, one N45 magnet at the tip (axial along +d3 or -d3), currents that give B = 12 mT
    along +z at the tip, heavy damping: the rod turns toward B (or away) and settles."""
    out = {}
    for sign in (1.0, -1.0):
        spec = ManipulatorSpec(magnets=(Magnet(arc_length=L - 1e-3, grade="N45", direction=(0, 0, sign)),),
                               gravity=(0.0, 0.0, 0.0), damping=Damping(translational=1.0))
        I = currents_for_field(spec.coils, (0.024, 0.0, 0.0), (0.0, 0.0, 0.012))
        run = ManipulatorRun(dt=0.02, n_samples=21)
        out[sign] = spec, simulate_manipulator(spec, np.tile(I, (run.n_samples, 1)), run)
    return out


def test_a_field_across_the_rod_turns_the_tip_toward_it(step_responses):
    _, traj = step_responses[1.0]
    theta = _tangent_angles(traj)[:, -1]
    assert abs(theta[0]) < 1e-12 and math.radians(15) < theta[-1] < math.radians(35)
    assert traj.positions[-1, -1, 2] > 5e-3 and np.all(np.abs(traj.positions[..., 1]) < 1e-12)
    # antiparallel magnetisation: mu x B reverses and the tip turns down by about as much
    _, flipped = step_responses[-1.0]
    theta_f = _tangent_angles(flipped)[:, -1]
    assert theta_f[-1] < -math.radians(15)


def test_torque_is_recomputed_from_the_pose_and_decreases_as_the_magnet_aligns(step_responses):
    spec, traj = step_responses[1.0]
    mu, B, W = traj.magnet_moments[:, 0], traj.fields[:, 0], traj.wrenches[:, 0]
    tau = np.linalg.norm(W[:, 3:], axis=1)
    assert tau[-1] < 0.85 * tau[0]
    angle = np.arccos(np.sum(mu * B, 1) / (np.linalg.norm(mu, axis=1) * np.linalg.norm(B, axis=1)))
    np.testing.assert_allclose(tau, np.linalg.norm(mu, axis=1) * np.linalg.norm(B, axis=1) * np.sin(angle),
                               rtol=1e-9)
    # every recorded quantity follows from the recorded pose and currents
    p = traj.magnet_positions[:, 0]
    np.testing.assert_allclose(mu, spec.magnets[0].moment * traj.magnet_rotations[:, 0, :, 2], rtol=1e-12)
    for k in (0, 7, 20):
        np.testing.assert_allclose(B[k], field(spec.coils, p[k], traj.currents[k]), rtol=1e-12, atol=1e-15)
        G = gradient(spec.coils, p[k], traj.currents[k])
        np.testing.assert_allclose(traj.gradients[k, 0], G, rtol=1e-10, atol=1e-14)
        np.testing.assert_allclose(W[k], wrench(mu[k], B[k], G), rtol=1e-10, atol=1e-16)
    # the magnet centre sits halfway between the last two nodes, and the nodes carry the wrench
    np.testing.assert_allclose(p, 0.5 * (traj.positions[:, -2] + traj.positions[:, -1]), atol=1e-15)
    np.testing.assert_allclose(traj.rod.forces[:, -2:].sum(1), W[:, :3], rtol=1e-12, atol=1e-18)


def test_settled_shape_satisfies_the_torque_balance(step_responses):
    """At rest, segment a bends by 2 atan(M_a l / 2 EI_a) with M_a = tau + (p - r_mid) x f, the
    moment of the magnet's wrench about the segment's middle (the discrete elastica, no gravity)."""
    for sign in (1.0, -1.0):
        spec, traj = step_responses[sign]
        r, p, W = traj.positions[-1], traj.magnet_positions[-1, 0], traj.wrenches[-1, 0]
        M = W[3:] + np.cross(p - 0.5 * (r[1:] + r[:-1]), W[:3])
        l, EI = spec.segment_length, spec.rod_spec().lumped()["C2"][:, 0]
        predicted = np.concatenate([[0.0], np.cumsum(2 * np.arctan(-M[:, 1] * l / (2 * EI)))])
        theta = _tangent_angles(traj)[-1]
        assert np.max(np.abs(theta - predicted)) < 1e-3 * abs(theta[-1])
        # the gradient force matters: without it the prediction is off by 3.4%, 30 times the tolerance
        no_force = np.sum(2 * np.arctan(-W[4] * l / (2 * EI)))
        assert abs(no_force - theta[-1]) > 0.03 * abs(theta[-1])


# --------------------------------------------------------------------------- current inputs
def test_random_currents_are_smooth_bounded_and_reproducible():
    layout = bigmag_like()
    a = random_currents(layout, 20.0, seed=7)
    b = random_currents(layout, 20.0, seed=7)
    c = random_currents(layout, 20.0, seed=8)
    np.testing.assert_array_equal(a.values, b.values)
    assert not np.allclose(a.values, c.values)
    np.testing.assert_allclose(np.max(np.abs(a.values), axis=0), 0.9 * 8.0, rtol=1e-12)
    assert np.all(a.values[0] == 0.0)
    t = np.linspace(0, 20, 7777)
    assert np.max(np.abs(a(t))) <= 0.9 * 8.0
    # band-limited (0.1-2 Hz): with a Hann window against leakage, nearly no power above 3 Hz
    window = np.hanning(a.times.size)[:, None]
    spectrum = np.abs(np.fft.rfft(a.values * window, axis=0)) ** 2
    freq = np.fft.rfftfreq(a.times.size, d=a.times[1] - a.times[0])
    assert spectrum[freq > 3.0].sum() < 1e-6 * spectrum.sum()
    assert spectrum[freq < 2.0].sum() > 0.999 * spectrum.sum()


def test_runs_are_deterministic_and_record_the_applied_currents():
    spec = ManipulatorSpec()
    run = ManipulatorRun(dt=0.02, n_samples=6)
    schedule = random_currents(spec.coils, run.duration, seed=3, ramp=0.0)
    one = simulate_manipulator(spec, schedule, run)
    two = simulate_manipulator(spec, random_currents(spec.coils, run.duration, seed=3, ramp=0.0), run)
    for name in ("currents", "magnet_positions", "fields", "wrenches"):
        np.testing.assert_array_equal(getattr(one, name), getattr(two, name))
    np.testing.assert_array_equal(one.positions, two.positions)
    np.testing.assert_allclose(one.currents, schedule(one.time), rtol=1e-12, atol=1e-12)
    assert np.max(np.abs(one.currents)) <= 8.0 and np.any(one.wrenches != 0)
    # the same currents given as samples (n_samples, 6) at the save times
    sampled = simulate_manipulator(spec, one.currents, run)
    np.testing.assert_allclose(sampled.currents, one.currents, rtol=1e-14, atol=1e-14)
    assert one.currents.flags.writeable                                # the input was not frozen or changed


# --------------------------------------------------------------------------- bad input: one-line messages
@pytest.mark.parametrize("make, match", [
    (lambda: ManipulatorSpec(magnets=(Magnet(arc_length=L - 0.5e-3),)),
     r"magnets\[0\]\.arc_length=0.0495 is invalid: a centre in \[0.001, 0.049\] m"),
    (lambda: ManipulatorSpec(magnets=(Magnet(arc_length=-0.01),)), "lies inside the 0.05 m rod"),
    (lambda: ManipulatorSpec(magnets=(Magnet(arc_length=0.02, size=(3e-3, 3e-3, 2e-3)),)),
     "its diagonal 4.24 mm exceeds the diameter 3 mm"),
    (lambda: ManipulatorSpec(magnets=(Magnet(arc_length=0.02), Magnet(arc_length=0.021))), "do not share rod nodes"),
    (lambda: ManipulatorSpec(base=(0.01, 0.0, 0.0)), "a rod inside the coils' workspace"),
    (lambda: ManipulatorSpec(coils=bigmag_like(radius=0.065)), "a coil outside the workspace"),
    (lambda: ManipulatorSpec(base="origin"), "base='origin' is invalid: a finite 3-vector"),
    (lambda: ManipulatorSpec(gravity=(0.0, -9.81)), r"gravity=\(0.0, -9.81\) is invalid"),
    (lambda: ManipulatorSpec(magnets=Magnet(arc_length=0.02)), "a tuple of Magnet entries"),
    (lambda: ManipulatorSpec(magnet_stiffness_factor=0.5), "magnet_stiffness_factor=0.5"),
    (lambda: simulate_manipulator(ManipulatorSpec(), np.full((3, 6), 8.5), ManipulatorRun(dt=0.01, n_samples=3)),
     r"max \|currents\|=8.5 is invalid: currents within the coil limit \+/-8 A"),
    (lambda: simulate_manipulator(ManipulatorSpec(), np.zeros((3, 5)), ManipulatorRun(dt=0.01, n_samples=3)),
     r"currents.shape=\(3, 5\) is invalid: \(T, 6\)"),
    (lambda: simulate_manipulator(ManipulatorSpec(), np.zeros((4, 6)), ManipulatorRun(dt=0.01, n_samples=3)),
     r"currents.shape=\(4, 6\) is invalid"),
    (lambda: simulate_manipulator(ManipulatorSpec(), CurrentSchedule([0.0, 0.01], np.zeros((2, 6))),
                                  ManipulatorRun(dt=0.01, n_samples=3)), "covers the run to t = 0.02 s"),
    (lambda: simulate_manipulator(ManipulatorSpec(), np.zeros((2, 6)), ManipulatorRun(dt=0.01, n_samples=2,
                                                                                      substeps=10)),
     "substeps=10 is invalid: at least"),
    (lambda: CurrentSchedule([0.0, 0.0], np.zeros((2, 6))), "strictly increasing"),
    (lambda: random_currents(bigmag_like(), 1.0, seed=1, band=(0.1, 600.0)), "band"),
    (lambda: currents_for_field(bigmag_like(), np.zeros(3), (0, 0, 0.05)), "within the coil limit"),
    (lambda: ManipulatorRun(dt=0.01, n_samples=3, settle=-1.0), "settle=-1.0"),
])
def test_bad_input_gives_a_one_line_message(make, match):
    with pytest.raises(SoftrnnInputError, match=match) as err:
        make()
    assert "\n" not in str(err.value)
