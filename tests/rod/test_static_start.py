"""A dynamic run started from the static equilibrium of its own setup (``softrnn.statics.static_start``):
it stays at rest up to the discretisation's difference from the continuum (while the straight start
swings), the start keeps the static solution's frames and twist, the loads and the clamp are taken at
the given time, and setups the static solver does not model are refused in one line."""

import dataclasses

import numpy as np
import pytest

from softrnn.errors import SoftrnnInputError
from softrnn.rod import (
    Clamp,
    Constant,
    Damping,
    NodalLoad,
    NodeOverride,
    PDTracking,
    Pin,
    RodSpec,
    RunConfig,
    Setup,
    Simulator,
    Tendon,
    Window,
    arc,
    polyline,
    straight,
)
from softrnn.rod.so3 import axis_rotation
from softrnn.statics import PointLoad, StaticLoads, StaticRod, solve, static_solution, static_start

L, RADIUS, E, RHO, NU = 0.2, 0.01, 1e7, 1000.0, 0.5
EI = E * np.pi * RADIUS**4 / 4
GJ = E / (2 * (1 + NU)) * np.pi * RADIUS**4 / 2
N = 21
GRAVITY = (0.0, 0.0, -9.81)
TIP_FORCE = (0.0, 0.3, -EI / L**2)      # N: with gravity, a 3-D deflection of ~0.2 L
REST_TOL = 1e-3                         # the static start's largest node move / L at 21 nodes (measured 3.8e-4)
SWING = 0.1                             # the straight start's tip swings by more than this / L (measured 0.34)
FRAME_TOL = 1e-9                        # start frames vs an independent static solve


def cantilever(n=N, loads=(), gravity=GRAVITY, tendons=(), boundary=None, **rod):
    """A cantilever along +x (d1 = +z), heavily damped (clamped at node 0 unless ``boundary``)."""
    boundary = (Clamp(0),) if boundary is None else boundary
    spec = RodSpec(length=L, radius=RADIUS, youngs_modulus=E, density=RHO, n_nodes=n, poisson_ratio=NU, **rod)
    return Setup(rod=spec, reference=straight(n, L, direction=(1, 0, 0), normal=(0, 0, 1)), boundary=boundary,
                 damping=Damping(translational=30.0, rotational=1e-3), gravity=gravity, loads=tuple(loads),
                 tendons=tuple(tendons))


def run(setup, n_samples=11):
    return Simulator(setup).run(RunConfig(dt=0.05, n_samples=n_samples))


def largest_move(traj, start) -> float:
    """The largest distance of any node from its start over the run, / L."""
    return float(np.linalg.norm(traj.positions - start.positions, axis=2).max() / L)


def twist(rotations) -> np.ndarray:
    """The angle [rad] of each frame's d1 about d3 relative to the first frame (straight rods)."""
    rel = np.einsum("ji,njk->nik", rotations[0], rotations)
    return np.arctan2(rel[:, 1, 0], rel[:, 0, 0])


# --------------------------------------------------------------------------- at rest
def test_a_static_start_stays_at_rest_and_the_straight_start_does_not():
    setup = cantilever(loads=[NodalLoad(-1, force=Constant(TIP_FORCE))])
    start = static_start(setup)
    assert start.n_nodes == N
    np.testing.assert_array_equal(start.positions[0], setup.reference.positions[0])
    np.testing.assert_allclose(start.rotations[0], setup.reference.rotations[0], atol=1e-15)
    assert np.linalg.norm(start.positions[-1] - setup.reference.positions[-1]) > 0.2 * L  # well bent
    moved = largest_move(run(dataclasses.replace(setup, initial=start)), start)
    assert moved < REST_TOL, moved
    swung = largest_move(run(setup, n_samples=3), setup.reference)
    assert swung > SWING, swung


def test_the_mismatch_is_the_discretisation_and_shrinks_with_the_node_spacing_squared():
    moves = []
    for n in (21, 41):
        setup = cantilever(n, loads=[NodalLoad(-1, force=Constant(TIP_FORCE))])
        start = static_start(setup)
        moves.append(largest_move(run(dataclasses.replace(setup, initial=start), n_samples=6), start))
    assert 3.0 < moves[0] / moves[1] < 5.0, moves


def test_a_helical_tendon_with_gravity_starts_at_rest():
    td = Tendon(name="h", offset=(0.008, 0.0), tension=5.0, routing="helical", pitch=0.4)
    setup = cantilever(tendons=[td])
    start = static_start(setup)
    assert np.linalg.norm(start.positions[-1] - [L, 0.0, 0.0]) > 0.02 * L
    assert largest_move(run(dataclasses.replace(setup, initial=start)), start) < REST_TOL


# --------------------------------------------------------------------------- frames and twist
def test_the_start_frames_are_the_static_solution_frames():
    """World-frame torque about the rod's axis, a side force and gravity: positions and frames at the
    nodes equal an independently built static solve's."""
    torque, force = (GJ / L, 0.0, 0.0), (0.0, 0.2, 0.0)
    setup = cantilever(loads=[NodalLoad(-1, torque=Constant(torque)), NodalLoad(N - 1, force=Constant(force))])
    start = static_start(setup)
    rod = StaticRod(length=L, radius=RADIUS, youngs_modulus=E, density=RHO, poisson_ratio=NU, gravity=GRAVITY)
    nodes = [PointLoad(s=L * a / (N - 1)) for a in range(1, N - 1)]
    sol = solve(rod, StaticLoads(point_loads=(*nodes, PointLoad(s=L, force=force, torque=torque))),
                n_steps=4 * (N - 1), tol=1e-12).raise_for_status()
    idx = [sol.index(L * a / (N - 1)) for a in range(N)]
    np.testing.assert_allclose(start.positions, sol.positions[idx], atol=FRAME_TOL * L)
    np.testing.assert_allclose(start.rotations, sol.rotations[idx], atol=FRAME_TOL)
    assert abs(twist(start.rotations)[-1]) > 0.5  # twisted by ~1 rad


def test_a_body_frame_twist_is_kept_by_the_start_and_the_run():
    """A follower torque about the tangent twists the straight rod uniformly by T s / GJ; the run
    keeps it, while frames rebuilt from the chords (a polyline) lose it."""
    T = GJ / L  # 1 rad at the tip
    setup = cantilever(loads=[NodalLoad(-1, torque=Constant((0.0, 0.0, T)), frame="body")], gravity=(0, 0, 0))
    start = static_start(setup)
    s = np.linspace(0.0, L, N)
    np.testing.assert_allclose(twist(start.rotations), T * s / GJ, atol=1e-8)
    np.testing.assert_allclose(start.positions[:, 1:], 0.0, atol=1e-12)
    traj = run(dataclasses.replace(setup, initial=start))
    assert abs(twist(traj.rotations()[-1])[-1] - 1.0) < 1e-3
    assert abs(twist(polyline(start.positions, normal=(0, 0, 1)).rotations)[-1]) < 1e-6


# --------------------------------------------------------------------------- time and clamp
def test_the_loads_and_the_clamp_are_taken_at_the_given_time():
    push = Window(Constant((0.0, 0.0, -EI / L**2)), 1.0, 2.0)
    turn = axis_rotation("z", 0.3)
    base = straight(N, L, direction=(1, 0, 0), normal=(0, 0, 1))

    def motion(t):
        t = np.asarray(t, dtype=float)
        return np.zeros((t.size, 3)) + [0.0, 0.01, 0.0] * t[:, None], np.broadcast_to(turn @ base.rotations[0],
                                                                                       (t.size, 3, 3))

    setup = cantilever(loads=[NodalLoad(-1, force=push)], gravity=(0, 0, 0), boundary=(Clamp(0, motion=motion),))
    before, during = static_start(setup, time=0.5), static_start(setup, time=1.5)
    np.testing.assert_allclose(before.positions[0], [0.0, 0.005, 0.0], atol=1e-15)
    np.testing.assert_allclose(before.positions[-1], before.positions[0] + L * (turn @ [1.0, 0.0, 0.0]), atol=1e-12)
    np.testing.assert_allclose(during.positions[0], [0.0, 0.015, 0.0], atol=1e-15)
    np.testing.assert_allclose(during.rotations[0], turn @ base.rotations[0], atol=1e-15)
    assert during.positions[-1, 2] < -0.2 * L
    assert static_solution(setup, time=1.5).converged


# --------------------------------------------------------------------------- refused setups
REFUSED = [
    (dict(boundary=(Clamp(0), Pin(-1))), ["boundary", "pin at node 20", "cantilever"]),
    (dict(boundary=(Clamp(0), Clamp(-1))), ["boundary", "clamps at nodes [0, 20]", "exactly one clamp, at node 0"]),
    (dict(boundary=(Clamp(-1),)), ["clamps at nodes [20]"]),
    (dict(boundary=()), ["no clamp"]),
    (dict(loads=[NodalLoad(-1, force=Constant((0, 0, -1)))], boundary=(Clamp(0),)), None),
    (dict(loads=[PDTracking(-1, Constant((0.1, 0, 0)), stiffness=10.0)]), ["loads", "PD tracking", "nodal forces"]),
    (dict(overrides=(NodeOverride(first=18, last=20, density=5000.0),)), ["rod.overrides", "uniform rod"]),
]


@pytest.mark.parametrize("change, words", REFUSED)
def test_unsupported_setups_are_refused_in_one_line(change, words):
    setup = cantilever(**change)
    if words is None:  # the supported control case
        assert static_start(setup).n_nodes == N
        return
    with pytest.raises(SoftrnnInputError) as info:
        static_start(setup)
    message = str(info.value)
    assert len(message.splitlines()) == 1, message
    for w in words:
        assert w in message, message
    assert "give the initial shape explicitly" in message


def test_a_curved_reference_is_refused():
    spec = RodSpec(length=L, radius=RADIUS, youngs_modulus=E, density=RHO, n_nodes=N)
    setup = Setup(rod=spec, reference=arc(N, L, L / np.pi), boundary=(Clamp(0),))
    with pytest.raises(SoftrnnInputError, match="reference=.*straight, untwisted reference"):
        static_start(setup)
