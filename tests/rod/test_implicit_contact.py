"""Linearly implicit contact (``Contact(implicit=True)`` with the implicit integrator): the same rest
penetration as explicit contact (plane, meshed tube), stable bounces far beyond the explicit contact step, the option's
records and scenario key, and explicit contact unchanged."""

import math
from dataclasses import replace

import numpy as np
import pytest

from softrnn.errors import SimulationError, SoftrnnInputError
from softrnn.geometry._marching import tube_tree_surface
from softrnn.geometry.contact import contact_from_record, contact_record
from softrnn.rod import Contact, Plane, RodSpec, RunConfig, Setup, Simulator, straight
from softrnn.rod.contact import MeshVessel, step_limit
from softrnn.rod.implicit import accuracy_step
from softrnn.scenarios import load_scenario, parse_scenario, scenario_text

G = 9.81
RADIUS = 0.005
LENGTH = 0.2
N = 21

REST_RTOL = 0.02          # rest penetration, implicit against explicit contact
BOUNCE_FACTOR = 20        # the bouncing run's step, a multiple of the explicit contact limit
DROP = 0.005             # drop height [m] of the bouncing rod
REBOUND_GAIN = 0.01      # rebound height above the drop height, of the drop height


def _rod():
    return RodSpec(length=LENGTH, radius=RADIUS, youngs_modulus=1e6, density=1000.0, n_nodes=N)


def _on_plane(height, implicit, **contact):
    """A free, straight, horizontal rod whose surface is ``height`` [m] above the plane z = 0."""
    shape = straight(N, LENGTH, origin=(0.0, 0.0, RADIUS + height), direction=(1.0, 0.0, 0.0),
                     normal=(0.0, 0.0, 1.0))
    return Setup(rod=_rod(), reference=shape, gravity=(0.0, 0.0, -G),
                 contact=Contact(obstacles=(Plane((0.0, 0.0, 0.0), (0.0, 0.0, 1.0)),), implicit=implicit,
                                 **contact))


def _penetration(setup, positions):
    """Deepest penetration [m] over samples (S, n, 3)."""
    radius = np.full(N, RADIUS)
    return max(-setup.contact.gaps(p, radius).min() for p in positions)


def test_a_rod_at_rest_settles_to_the_explicit_contact_penetration():
    """Dropped from 0.2 % of r onto a plane: implicit contact at 10x the explicit contact step settles
    to the rest penetration of explicit contact (0.5 % of r at the default stiffness) and carries the
    weight (a damper that would pull keeps acting while the node is in the wall: no chatter)."""
    explicit = _on_plane(0.002 * RADIUS, False)
    sim = Simulator(explicit)
    ref = sim.run(RunConfig(dt=4e-3, n_samples=76, integrator="implicit"))
    imp = Simulator(replace(explicit, contact=replace(explicit.contact, implicit=True)))
    run = imp.run(RunConfig(dt=4e-3, n_samples=76, integrator="implicit", substeps=1))
    assert run.step > 5 * ref.step
    radius = np.full(N, RADIUS)
    p_ref = -explicit.contact.gaps(ref.positions[-1], radius).min()
    p_imp = -explicit.contact.gaps(run.positions[-1], radius).min()
    assert p_imp == pytest.approx(p_ref, rel=REST_RTOL)
    assert p_imp == pytest.approx(0.005 * RADIUS, rel=0.05)
    weight = imp.mass.sum() * G
    assert run.contact_forces[-1].sum(axis=0)[2] == pytest.approx(weight, rel=0.01)


def test_a_rod_in_a_meshed_tube_settles_as_with_explicit_contact():
    """A rod dropped onto the floor of a frictionless meshed tube: implicit contact at a 1 ms step
    (over 10x the explicit contact's automatic one) rests at the penetration of explicit contact
    (to 2 % of it) and at its height (to 1 % of r; it may rest elsewhere across the floor). Frictionless,
    the rod keeps rolling a little across the floor's facets (an undamped mode), each roll over an edge
    a small impact: the rest penetration is the median over the last 0.1 s."""
    R, r, n, length = 0.003, 0.0005, 9, 0.04
    axis = np.array([[0.0, 0, 0], [0.06, 0, 0]])
    mesh = MeshVessel(*tube_tree_surface([(axis, R)], 0.0006))
    rod = RodSpec(length=length, radius=r, youngs_modulus=1e7, density=1500.0, n_nodes=n)
    shape = straight(n, length, origin=(0.01, 0.0, -0.002), direction=(1.0, 0.0, 0.0), normal=(0.0, 0.0, 1.0))
    runs = []
    for implicit, substeps in ((False, None), (True, 5)):
        setup = Setup(rod=rod, reference=shape, gravity=(0.0, 0.0, -G),
                      contact=Contact(obstacles=(mesh,), implicit=implicit))
        runs.append(Simulator(setup).run(RunConfig(dt=0.005, n_samples=61, integrator="implicit", substeps=substeps)))
    assert runs[1].step > 10 * runs[0].step
    assert np.abs(runs[1].positions[-1, :, 2] - runs[0].positions[-1, :, 2]).max() < 0.01 * r
    gaps = [np.median([mesh.gap(p, np.full(n, r))[0].min() for p in t.positions[-21:]]) for t in runs]
    assert gaps[0].min() < 0
    assert gaps[1].min() == pytest.approx(gaps[0].min(), rel=REST_RTOL)


def test_the_automatic_step_is_not_bounded_by_implicit_contact():
    """substeps = auto: a stiff explicit contact bounds the implicit integrator's step, implicit
    contact does not (the step resolves the rod's bending modes, ``accuracy_step``)."""
    config = RunConfig(dt=1e-3, n_samples=3, integrator="implicit")
    explicit = Simulator(_on_plane(0.0, False, penetration=1e-4))
    h_exp = explicit.run(config).step
    h_imp = Simulator(_on_plane(0.0, True, penetration=1e-4)).run(config).step
    assert h_imp > 2 * h_exp
    assert h_imp <= accuracy_step(explicit.rod)


def test_a_falling_rod_bounces_stably_far_beyond_the_explicit_contact_step():
    """Dropped from 5 mm onto a stiff plane (rest penetration 0.01 % of r), undamped in the normal
    direction (damping 0): at 20x the explicit contact limit the run stays finite, the penetration
    stays below one step's travel at the impact speed (a node enters the wall for one step before its
    spring is implicit), and the rod bounces no higher than its drop height (to 1 %)."""
    setup = _on_plane(DROP, True, damping=0.0, penetration=1e-4)
    sim = Simulator(setup)
    nodes = sim.inputs.contact["contact_node"]
    h_limit = step_limit(nodes, sim.rod.mass)
    substeps = 1
    dt = BOUNCE_FACTOR * h_limit
    run = sim.run(RunConfig(dt=dt, n_samples=int(math.ceil(0.3 / dt)), integrator="implicit", substeps=substeps))
    assert np.all(np.isfinite(run.positions))
    depth = run.step * math.sqrt(2 * G * DROP)
    assert _penetration(setup, run.positions) < depth
    z = run.positions[:, :, 2]
    assert z.min() < RADIUS  # it touched
    assert z[len(z) // 3:].max() < RADIUS + DROP * (1 + REBOUND_GAIN)
    # explicit contact at this step diverges (or penetrates deeper)
    explicit = Simulator(_on_plane(DROP, False, damping=0.0, penetration=1e-4))
    try:
        bad = explicit.run(RunConfig(dt=dt, n_samples=int(math.ceil(0.3 / dt)), integrator="implicit",
                                     substeps=substeps))
        assert not np.all(np.isfinite(bad.positions)) or _penetration(setup, bad.positions) > depth
    except SimulationError:   # diverged
        pass


def test_the_option_round_trips_through_records_and_is_checked():
    """``implicit`` is in the record only where set, reads back, and is refused unless a bool."""
    plane = Plane((0.0, 0.0, 0.0), (0.0, 0.0, 1.0))
    assert "implicit" not in contact_record(Contact(obstacles=(plane,)))
    record = contact_record(Contact(obstacles=(plane,), implicit=True))
    assert record["implicit"] is True
    assert contact_from_record(record).implicit is True
    with pytest.raises(SoftrnnInputError, match="contact.implicit"):
        Contact(obstacles=(plane,), implicit=1)


def test_the_scenario_key_sets_the_option():
    """``[contact] implicit = true`` sets it; a non-boolean is a one-line error; the default is off."""
    text = scenario_text("contact-plane")
    assert parse_scenario(text.replace("[contact]\n", "[contact]\nimplicit = true\n")).setup.contact.implicit
    with pytest.raises(SoftrnnInputError, match="contact.implicit"):
        parse_scenario(text.replace("[contact]\n", "[contact]\nimplicit = 1\n"))
    assert not load_scenario("contact-plane").setup.contact.implicit


def test_explicit_integrator_ignores_the_option():
    """The explicit integrator runs explicit contact either way: identical trajectories."""
    config = RunConfig(dt=1e-3, n_samples=21)
    a = Simulator(_on_plane(0.001, False)).run(config)
    b = Simulator(_on_plane(0.001, True)).run(config)
    assert a.positions.tobytes() == b.positions.tobytes()
