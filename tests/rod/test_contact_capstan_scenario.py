"""The shipped contact-capstan scenario obeys the capstan relation: a rope pulled over a fixed drum,
wrapped by 180 degrees, slips over it while the pin pulls T2 = T1 exp(mu theta) (Euler-Eytelwein),
at the scenario's friction and at the top of its sweep; the loaded end rises and no node sinks 1 %
of the rope's radius into the drum; softrnn simulate saves the contact and softrnn show reports it."""

import math
from dataclasses import replace

import numpy as np
import pytest

from softrnn.rod import Simulator
from softrnn.scenarios.scenario import load_scenario

from helpers import run_cli

STEADY = 0.15          # s: the pull is at speed from 0.05 s, the axial waves have died down by then
RATIO_TOL = 0.02       # measured -0.5 % at mu = 0.3 and -1.1 % at mu = 0.5 (a rope of finite radius: O(r / R))
PENETRATION_TOL = 0.01  # of the rope's radius: the deepest node at any saved sample (measured 0.48 %, 0.85 %)


def _unit(v):
    return v / np.linalg.norm(v)


@pytest.mark.parametrize("mu", [None, 0.5], ids=["as-shipped", "top-of-sweep"])
def test_the_shipped_rope_over_a_drum_obeys_the_capstan_relation(mu):
    sc = load_scenario("contact-capstan")
    setup = sc.setup
    if mu is not None:
        assert sc.randomize["contact.friction"] == ("uniform", [0.1, mu])
        setup = replace(setup, contact=replace(setup.contact, friction=mu))
    mu = setup.contact.friction
    (load,), (pin,) = setup.loads, setup.boundary
    n, r = setup.rod.n_nodes, setup.rod.radius
    assert load.node == 0 and pin.node == n - 1
    # the wrap angle from the reference: the rope leaves the drum along its two legs
    ref = setup.reference.positions
    theta = math.acos(np.dot(_unit(ref[1] - ref[0]), _unit(ref[-1] - ref[-2])))
    assert theta == pytest.approx(math.pi, abs=1e-3)
    t1 = -float(load.force(np.array([1.0]))[0, 2])  # the weight on the free end, at full strength

    traj = Simulator(setup).run(sc.config)
    steady = traj.time >= STEADY
    assert steady.sum() > 100
    loaded, pulled = traj.positions[:, 0, 2], traj.positions[:, -1, 2]
    assert np.all(np.diff(loaded[steady]) > 0)                     # the loaded end rises: the rope slips
    assert loaded[-1] - loaded[0] > 0.04 and pulled[0] - pulled[-1] > 0.05
    speed = -traj.velocities[steady, -1, 2].mean()
    assert speed == pytest.approx(0.2, rel=1e-3)
    t2 = -traj.reaction_forces[steady, -1, 2]                        # the pin's pull
    assert np.ptp(t2) < RATIO_TOL * t2.mean()
    belt = setup.rod.density * math.pi * r**2 * speed**2            # lambda v^2, taken off both tensions
    ratio = (t2.mean() - belt) / (t1 - belt)
    assert ratio == pytest.approx(math.exp(mu * theta), rel=RATIO_TOL)
    gaps = np.array([setup.contact.gaps(p, np.full(n, r))[:, 0] for p in traj.positions])
    assert gaps.min() > -PENETRATION_TOL * r
    # the drum carries both tensions: the contact forces on the rope add up to T1 + T2 upward
    pressed = traj.contact_forces[steady].sum(axis=1).mean(axis=0)
    assert pressed[2] == pytest.approx(t1 + t2.mean(), rel=0.005)
    assert abs(pressed[0]) < 0.01 * t1


def test_simulate_saves_the_drum_and_show_reports_the_contact(tmp_path, capsys):
    """softrnn simulate contact-capstan -o (the first 50 ms) stores the contact forces and the drum,
    and softrnn show reports them."""
    out = tmp_path / "c.h5"
    assert run_cli(["simulate", "contact-capstan", "-o", str(out), "--samples", "51", "--quiet"]) == 0
    assert f"wrote {out}" in capsys.readouterr().out
    assert run_cli(["show", str(out)]) == 0
    shown = capsys.readouterr().out
    assert "contact: contact_forces, contact_torques" in shown and "obstacles: cylinder" in shown
