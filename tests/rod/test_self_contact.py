"""Contact between a rod's own segments (``Contact(self_contact=True)``, docs/lgvi.md §2.11): a
hairpin closed by two opposite end forces stops where its ends touch, at the static penetration of
the two contact springs in series, in both integrators; the pair forces are equal and opposite (the
contact loads sum to zero, the momentum of a free rod stays zero); a straight rod thicker than its
segments are long never touches itself; without self-contact the ends pass through each other; the
option survives the data set record and the scenario table."""

import math

import numpy as np
import pytest

from softrnn.errors import SoftrnnInputError
from softrnn.io.schema import contact_from_record, contact_record
from softrnn.rod import Constant, Contact, Plane, RunConfig, Simulator
from softrnn.rod.contact import self_contact_gap
from softrnn.rod.loads import NodalLoad
from softrnn.rod.shapes import polyline, straight
from softrnn.rod.simulation import Damping, Setup
from softrnn.rod.spec import RodSpec

R, F, N = 0.004, 0.02, 41


def _hairpin(leg=0.1, half=0.02):
    """Nodes (N, 3) of a hairpin in the xy-plane: two legs along x, 2 half apart, joined by a half
    circle; and its length [m]."""
    length = 2 * leg + math.pi * half
    out = []
    for s in np.linspace(0.0, length, N):
        if s < leg:
            out.append((leg - s, -half, 0.0))
        elif s < leg + math.pi * half:
            phi = (s - leg) / half
            out.append((-half * math.sin(phi), -half * math.cos(phi), 0.0))
        else:
            out.append((s - leg - math.pi * half, half, 0.0))
    return np.array(out), length


def _closed_hairpin(self_contact: bool, integrator: str = "explicit"):
    """The hairpin, free, without gravity, its two ends pushed toward each other by F [N] each."""
    points, length = _hairpin()
    rod = RodSpec(length=length, radius=R, youngs_modulus=2.5e6, density=1000.0, n_nodes=N)
    setup = Setup(rod=rod, reference=polyline(points, normal=(0.0, 0.0, 1.0)), gravity=(0.0, 0.0, 0.0),
                  loads=(NodalLoad(0, force=Constant((0.0, F, 0.0))), NodalLoad(N - 1, force=Constant((0.0, -F, 0.0)))),
                  contact=Contact(self_contact=True) if self_contact else None,
                  damping=Damping(translational=0.05))
    traj = Simulator(setup).run(RunConfig(dt=0.005, n_samples=301, integrator=integrator))
    return traj, rod


@pytest.mark.parametrize("integrator", ["explicit", "implicit"])
def test_a_hairpin_closes_until_its_ends_touch(integrator):
    traj, rod = _closed_hairpin(True, integrator)
    gap = np.linalg.norm(traj.positions[:, 0] - traj.positions[:, -1], axis=1) - 2 * R
    cf = traj.contact_forces
    touching = np.flatnonzero(np.abs(cf[-1]).max(axis=1) > 0)
    assert touching.tolist() == [0, N - 1]                       # the two end nodes only
    # nearly at rest the end nodes' springs (each the default: its weight under 9.81 m/s^2 sinks
    # 0.5 % of r) act in series against the contact force (the bent hairpin carries the rest of F)
    k = rod.lumped()["mass"][0] * 9.81 / (0.005 * R)
    f = np.linalg.norm(cf[-1, 0])
    assert 0.2 * F < f < F
    assert gap[-1] == pytest.approx(-f / (k / 2), rel=0.05)
    assert gap.min() > -0.5 * R                                  # the impact stays shallow
    np.testing.assert_allclose(cf.sum(axis=1), 0.0, atol=1e-12 * np.abs(cf).max())   # equal and opposite


def test_without_self_contact_the_ends_pass_through_each_other():
    traj, _ = _closed_hairpin(False)
    gap = np.linalg.norm(traj.positions[:, 0] - traj.positions[:, -1], axis=1) - 2 * R
    assert gap.min() < -R and gap[-1] > 0                        # through, and out the other side


def test_self_contact_keeps_the_momentum_of_a_free_rod():
    traj, rod = _closed_hairpin(True)
    m = rod.lumped()["mass"]
    p = (traj.velocities * m[None, :, None]).sum(axis=1)
    scale = (np.linalg.norm(traj.velocities, axis=2) * m[None]).sum(axis=1).max()
    assert np.abs(p).max() < 1e-12 * scale


def test_a_thick_straight_rod_never_touches_itself():
    rod = RodSpec(length=0.1, radius=0.006, youngs_modulus=2.5e6, density=1000.0, n_nodes=21)   # r > l
    assert self_contact_gap(rod) == 2 + math.ceil(2 * 0.006 / 0.005)
    setup = Setup(rod=rod, reference=straight(21, 0.1, direction=(1.0, 0.0, 0.0), normal=(0.0, 0.0, 1.0)),
                  gravity=(0.0, 0.0, -9.81), contact=Contact(self_contact=True))
    traj = Simulator(setup).run(RunConfig(dt=0.002, n_samples=51))
    assert np.all(traj.contact_forces == 0)


def test_the_option_survives_the_record_and_the_scenario_table():
    c = Contact(obstacles=Plane((0, 0, 0), (0, 0, 1)), self_contact=True)
    back = contact_from_record(contact_record(c))
    assert back.self_contact and len(back.obstacles) == 1
    assert "self_contact" not in contact_record(Contact(obstacles=Plane((0, 0, 0), (0, 0, 1))))
    with pytest.raises(SoftrnnInputError, match="self_contact"):
        Contact(self_contact=1)
    with pytest.raises(SoftrnnInputError, match="contact.obstacles"):
        Contact()
    from softrnn.scenarios.scenario import load_scenario, parse_scenario, scenario_text

    text = scenario_text("contact-plane")
    sc = parse_scenario(text.replace("[contact]\n", "[contact]\nself_contact = true\n"))
    assert sc.setup.contact.self_contact
    with pytest.raises(SoftrnnInputError, match="contact.self_contact"):
        parse_scenario(text.replace("[contact]\n", "[contact]\nself_contact = 1\n"))
    assert not load_scenario("contact-plane").setup.contact.self_contact
