"""Predictive contact of the implicit integrator (``Contact(implicit=True)``): a node that reaches a
wall within a step is stopped there by a spring on its end-of-step gap, so the penetration no longer
grows with the step (a drop, a fast approach that would pass through a thin obstacle), and no energy
is gained (a bouncing rod), while explicit contact stays as it was."""

import math
from dataclasses import replace

import numpy as np
import pytest

from softrnn.rod import Contact, Cylinder, Plane, RodSpec, RunConfig, Setup, Simulator, guidewire, straight
from softrnn.rod.contact import step_limit
from softrnn.scenarios import load_scenario

G = 9.81
RADIUS = 0.005
LENGTH = 0.2
N = 21
DROP = 0.005              # drop height [m]
FACTOR = 20               # the large step, a multiple of the explicit contact limit
APEX_GAIN = 1e-3          # an apex may exceed the one before by this fraction of the drop height


def _drop(height, implicit, **contact):
    """A free, straight, horizontal rod whose surface is ``height`` [m] above the plane z = 0."""
    rod = RodSpec(length=LENGTH, radius=RADIUS, youngs_modulus=1e6, density=1000.0, n_nodes=N)
    shape = straight(N, LENGTH, origin=(0.0, 0.0, RADIUS + height), direction=(1.0, 0.0, 0.0),
                     normal=(0.0, 0.0, 1.0))
    return Setup(rod=rod, reference=shape, gravity=(0.0, 0.0, -G),
                 contact=Contact(obstacles=(Plane((0.0, 0.0, 0.0), (0.0, 0.0, 1.0)),), implicit=implicit,
                                 **contact))


def _depth(positions):
    """Deepest penetration [m] into the plane z = 0 over samples (S, n, 3)."""
    return float(max(0.0, RADIUS - positions[:, :, 2].min()))


def _limit(setup):
    sim = Simulator(setup)
    return step_limit(sim.inputs.contact["contact_node"], sim.rod.mass)


def test_a_drop_at_a_large_step_stays_within_the_explicit_penetration():
    """Dropped 5 mm onto a stiff plane: implicit contact at 20x the explicit contact limit penetrates no
    deeper than explicit contact at half that limit (every step saved), and under 5 % of one step's
    travel at the impact speed (what a spring taken only once the node is in the wall allows)."""
    setup = _drop(DROP, True, penetration=1e-4)
    limit = _limit(setup)
    run = Simulator(setup).run(RunConfig(dt=FACTOR * limit, n_samples=int(math.ceil(0.3 / (FACTOR * limit))),
                                         integrator="implicit", substeps=1))
    explicit = Simulator(_drop(DROP, False, penetration=1e-4)).run(
        RunConfig(dt=limit / 2, n_samples=int(math.ceil(0.3 / (limit / 2))), integrator="implicit", substeps=1))
    assert run.positions[:, :, 2].min() < RADIUS            # it touched
    travel = run.step * math.sqrt(2 * G * DROP)
    assert _depth(run.positions) <= _depth(explicit.positions)
    assert _depth(run.positions) < 0.05 * travel


def test_a_fast_approach_at_a_large_step_does_not_pass_through_a_thin_obstacle():
    """A rod falls at 250 m/s^2 onto a thin cylinder (radius 0.5 mm) under its middle node; over the
    step where that node would reach the cylinder it travels 2.4 mm, more than the cylinder and the
    rod are thick together (1.5 mm), to beyond it: it is stopped on top instead, its middle node (which
    then carries the whole rod's weight) never deeper than half the rod radius."""
    r, rho, accel, h = 0.00025, 0.0005, 250.0, 1e-3
    n, length = 11, 0.2
    # free fall from rest: z_k = z0 - a (k h)^2 / 2; at k = 9 the node is 0.3 mm above the surface,
    # at k = 10 it would be past the cylinder
    z0 = rho + r + 0.0003 + 0.5 * accel * (9 * h) ** 2
    assert z0 - 0.5 * accel * (10 * h) ** 2 < -(rho + r)
    rod = RodSpec(length=length, radius=r, youngs_modulus=1e9, density=1000.0, n_nodes=n)
    shape = straight(n, length, origin=(-length / 2, 0.0, z0), direction=(1.0, 0.0, 0.0), normal=(0.0, 0.0, 1.0))
    cylinder = Cylinder((0.0, 0.0, 0.0), (0.0, 1.0, 0.0), rho)
    setup = Setup(rod=rod, reference=shape, gravity=(0.0, 0.0, -accel),
                  contact=Contact(obstacles=(cylinder,), implicit=True, penetration=0.01))
    run = Simulator(setup).run(RunConfig(dt=h, n_samples=15, integrator="implicit", substeps=1))
    middle = run.positions[:, n // 2]
    assert np.all(np.isfinite(run.positions))
    assert middle[9, 2] > rho + r                          # outside at the start of that step
    assert middle[:, 2].min() > rho + r - 0.5 * r


@pytest.mark.parametrize("factor", [2, FACTOR])
def test_a_bouncing_rod_gains_no_energy(factor):
    """Dropped onto an undamped stiff plane at 2x and 20x the explicit contact limit: each apex after
    an impact (where the energy is all gravitational) is no higher than the one before it (to 0.1 %
    of the drop) nor than the drop."""
    setup = _drop(DROP, True, damping=0.0, penetration=1e-4)
    dt = factor * _limit(setup)
    run = Simulator(setup).run(RunConfig(dt=dt, n_samples=int(math.ceil(0.4 / dt)), integrator="implicit",
                                         substeps=1))
    z = run.positions[:, :, 2].mean(axis=1)
    assert np.all(np.isfinite(z)) and z.min() < RADIUS       # it touched
    apex = [z[i] for i in range(1, len(z) - 1) if z[i] >= z[i - 1] and z[i] > z[i + 1] and z[i] > RADIUS]
    assert all(b <= a + APEX_GAIN * DROP for a, b in zip(apex, apex[1:]))
    assert max(apex, default=RADIUS) <= RADIUS + DROP * (1 + APEX_GAIN)


def test_the_shipped_1m_guidewire_is_the_guidewire_device_with_implicit_contact():
    """mesh-arch-guidewire-1m: the rod and rest shape of ``guidewire(1.0, 101, bend=(20, 0.03, 0))``, held
    by a hub, in the long meshed arch with implicit contact; its first samples run with the wire
    within 5 % of its radius of the wall."""
    sc = load_scenario("mesh-arch-guidewire-1m")
    device = guidewire(1.0, 101, bend=(20.0, 0.03, 0.0), origin=(0.0, -0.0054, -1.02), direction=(0.0, 0.0, 1.0),
                       normal=(0.0, 1.0, 0.0))
    np.testing.assert_allclose(sc.setup.reference.positions, device.reference.positions, rtol=0, atol=1e-12)
    ours, theirs = sc.setup.rod.lumped(), device.rod.lumped()
    for key in theirs:
        np.testing.assert_allclose(ours[key], theirs[key], rtol=1e-12, err_msg=key)
    assert sc.setup.contact.implicit and sc.config.integrator.name == "implicit"
    mesh = sc.setup.contact.obstacles[0]
    assert mesh.file.endswith("mesh-arch-long.vtu")
    assert mesh.vertices[:, 2].min() == pytest.approx(-1.05 - 0.006, abs=0.002)   # the descending aorta's cap
    run = Simulator(sc.setup).run(replace(sc.config, n_samples=4))
    radius = sc.setup.rod.node_properties()["radius"]
    assert all(mesh.gap(p, radius)[0].min() > -0.05 * radius.max() for p in run.positions)
