"""simulate_batch: each rod of a batch matches an individual ``simulate`` run (each in its own
meshed vessel too); incompatible setups are refused with a message naming what differs."""

import numpy as np
import pytest

from softrnn.errors import SimulationError, SoftrnnInputError
from softrnn.geometry._marching import tube_tree_surface
from softrnn.rod import (
    Clamp,
    Constant,
    Contact,
    Damping,
    NodalLoad,
    PDTracking,
    RodSpec,
    RunConfig,
    Setup,
    Sinusoid,
    arc,
    simulate,
    simulate_batch,
    straight,
)
from softrnn.rod import batch as batch_module
from softrnn.rod import simulation as simulation_module
from softrnn.rod import threads as threads_module
from softrnn.rod.contact import MeshVessel, Plane

N = 12
FIELDS = ("positions", "quaternions", "velocities", "angular_velocities", "forces", "torques",
          "reaction_forces", "reaction_torques", "energy")


def _rod(**kw):
    args = dict(length=0.5, radius=0.01, youngs_modulus=1e6, density=1000.0, n_nodes=N)
    args.update(kw)
    return RodSpec(**args)


def _setup(loads=(), rod=None, initial=None, boundary=None, **kw):
    boundary = (Clamp(0),) if boundary is None else boundary
    rod = _rod() if rod is None else rod
    ref = straight(N, rod.length, direction=(1.0, 0.0, 0.0), normal=(0.0, 0.0, 1.0))
    return Setup(rod=rod, reference=ref, initial=initial, boundary=boundary, loads=tuple(loads),
                 gravity=(0.0, 0.0, -9.81), damping=Damping(translational=0.05, kelvin_voigt=1e-3), **kw)


def _assert_same(a, b):
    np.testing.assert_array_equal(a.time, b.time)
    np.testing.assert_array_equal(a.nodes, b.nodes)
    assert a.substeps == b.substeps and a.step == b.step
    for name in FIELDS:
        x, y = getattr(a, name), getattr(b, name)
        assert x.shape == y.shape, name
        np.testing.assert_allclose(x, y, rtol=1e-12, atol=1e-12, err_msg=name)


@pytest.fixture
def small_chunks(monkeypatch):
    """Force several chunks per run in both the batch and the single-rod driver."""
    if hasattr(simulation_module, "_CHUNK_STEPS"):
        monkeypatch.setattr(simulation_module, "_CHUNK_STEPS", 64)
    monkeypatch.setattr(batch_module, "_CHUNK_ROD_STEPS", 3 * 64)


def test_batch_matches_individual_runs(small_chunks):
    bent = arc(N, 0.5, 2.0, tangent=(1.0, 0.0, 0.0), inward=(0.0, 0.0, 1.0))
    setups = [
        _setup([NodalLoad(-1, force=Constant((0.0, 0.01, 0.0)))]),
        _setup([NodalLoad(5, force=Sinusoid((0.0, 0.0, 0.02), 3.0), frame="body"),
                NodalLoad(5, torque=Constant((0.0, 1e-3, 0.0)))], initial=bent),
        _setup([NodalLoad(-1, torque=Sinusoid((1e-3, 0.0, 0.0), 2.0, phase=0.3))]),
    ]
    config = RunConfig(dt=0.01, n_samples=21, save_nodes=(0, 5, -1))
    calls = []
    batch = simulate_batch(setups, config, progress=lambda i, n: calls.append((i, n)))
    assert len(batch) == 3
    assert calls[-1] == (21, 21) and len(calls) > 2  # several chunks
    singles = [simulate(s, config) for s in setups]
    for got, want in zip(batch, singles):
        _assert_same(got, want)
    # the loads really differ, so the rods do too
    tips = [t.positions[-1, -1] for t in batch]
    assert np.linalg.norm(tips[0] - tips[1]) > 1e-3 and np.linalg.norm(tips[0] - tips[2]) > 1e-4


def test_batch_pd_targets_and_prescribed_motion_may_differ(small_chunks):
    ref_R = straight(N, 0.5, direction=(1.0, 0.0, 0.0), normal=(0.0, 0.0, 1.0)).rotations[0]

    def clamp(amp):
        def f(t):
            pos = np.zeros((t.size, 3))
            pos[:, 1] = amp * np.sin(4.0 * t)
            return pos, np.broadcast_to(ref_R, (t.size, 3, 3)).copy()
        return Clamp(0, motion=f)

    setups = [
        _setup([PDTracking(-1, Constant((0.45, 0.05, 0.0)), stiffness=2.0, damping=0.1)],
               boundary=(clamp(0.01),)),
        _setup([PDTracking(-1, Sinusoid((0.0, 0.0, 0.05), 1.0, offset=(0.45, 0.0, 0.0)), stiffness=2.0,
                           damping=0.1), NodalLoad(3, force=Constant((0.0, 0.0, 0.01)))],
               boundary=(clamp(0.02),)),
    ]
    config = RunConfig(dt=0.01, n_samples=16)
    for got, want in zip(simulate_batch(setups, config), [simulate(s, config) for s in setups]):
        _assert_same(got, want)


def test_batch_of_one_and_all_nodes_saved():
    setup = _setup([NodalLoad(-1, force=Constant((0.0, 0.01, 0.0)))])
    config = RunConfig(dt=0.005, n_samples=5)
    (got,) = simulate_batch([setup], config)
    _assert_same(got, simulate(setup, config))
    assert got.positions.shape == (5, N, 3)


def test_mismatched_rod_spec_is_refused():
    setups = [_setup(), _setup(rod=_rod(youngs_modulus=2e6))]
    with pytest.raises(SoftrnnInputError, match=r"setups\[1\]\.rod"):
        simulate_batch(setups, RunConfig(dt=0.01, n_samples=3))


@pytest.mark.parametrize("other, what", [
    (dict(boundary=(Clamp(0), Clamp(-1))), r"setups\[1\]\.boundary"),
    (dict(loads=(PDTracking(-1, Constant((0.5, 0.0, 0.0)), stiffness=3.0),)), r"PDTracking"),
    (dict(initial=None, reference_bent=True), r"setups\[1\]\.reference"),
])
def test_other_mismatches_are_refused(other, what):
    first = _setup(loads=(PDTracking(-1, Constant((0.5, 0.0, 0.0)), stiffness=2.0),))
    if other.pop("reference_bent", False):
        rod = _rod()
        bent = arc(N, rod.length, 2.0, tangent=(1.0, 0.0, 0.0), inward=(0.0, 0.0, 1.0))
        second = Setup(rod=rod, reference=bent, boundary=(Clamp(0),), loads=first.loads,
                       gravity=first.gravity, damping=first.damping)
    else:
        other.setdefault("loads", first.loads)
        second = _setup(**other)
    with pytest.raises(SoftrnnInputError, match=what):
        simulate_batch([first, second], RunConfig(dt=0.01, n_samples=3))


def test_empty_batch_is_refused():
    with pytest.raises(SoftrnnInputError, match="setups"):
        simulate_batch([], RunConfig(dt=0.01, n_samples=3))


def test_divergence_names_the_rod():
    ok = _setup()
    wild = _setup([NodalLoad(-1, force=Constant((0.0, 1e4, 0.0)))])
    with pytest.raises(SimulationError, match=r"setups\[1\]"):
        simulate_batch([ok, wild], RunConfig(dt=0.01, n_samples=11))


def _in_tube(mesh, z: float, load: float, obstacles=()) -> Setup:
    """A short soft rod lying free in a meshed tube along +x (radius 3 mm) at height z [m], pushed
    sideways at its tip by ``load`` [N]."""
    rod = RodSpec(length=0.04, radius=0.0005, youngs_modulus=1e7, density=1500.0, n_nodes=9)

    def shape(height):
        return straight(9, 0.04, origin=(0.01, 0.0, height), direction=(1.0, 0.0, 0.0), normal=(0.0, 0.0, 1.0))
    return Setup(rod=rod, reference=shape(-0.002), initial=shape(z), gravity=(0.0, 0.0, -9.81),
                 loads=(NodalLoad(-1, force=Constant((0.0, load, 0.0))),),
                 contact=Contact(obstacles=(mesh,) + tuple(obstacles), friction=0.2))


def test_a_batch_of_rods_each_in_its_own_meshed_vessel_gives_exactly_their_single_runs(small_chunks):
    axis = np.array([[0.0, 0.0, 0.0], [0.06, 0.0, 0.0]])
    fine, coarse = (MeshVessel(*tube_tree_surface([(axis, 0.003)], spacing)) for spacing in (0.0006, 0.0009))
    assert len(fine.faces) != len(coarse.faces)            # the rods' mesh arrays differ in size
    setups = [_in_tube(fine, -0.002, 0.0), _in_tube(fine, -0.001, 2e-4), _in_tube(coarse, -0.002, -2e-4)]
    config = RunConfig(dt=0.005, n_samples=21, save_nodes=(0, 4, -1))
    batch = simulate_batch(setups, config)
    for got, want in zip(batch, [simulate(s, config) for s in setups]):
        assert got.substeps == want.substeps and got.step == want.step
        for name in FIELDS + ("contact_forces", "contact_torques"):
            np.testing.assert_array_equal(getattr(got, name), getattr(want, name), err_msg=name)
    assert all(np.abs(t.contact_forces[-1]).max() > 1e-6 for t in batch)      # each rests on its wall
    assert np.abs(batch[0].positions[-1] - batch[2].positions[-1]).max() > 1e-5


def test_a_batch_refuses_rods_with_other_numbers_of_obstacles_or_contact_stiffness():
    axis = np.array([[0.0, 0.0, 0.0], [0.06, 0.0, 0.0]])
    mesh = MeshVessel(*tube_tree_surface([(axis, 0.003)], 0.0009))
    first = _in_tube(mesh, -0.002, 0.0)
    floor = Plane((0.0, 0.0, -0.01), (0.0, 0.0, 1.0))
    stiffer = Setup(rod=first.rod, reference=first.reference, gravity=first.gravity, loads=first.loads,
                    contact=Contact(obstacles=(mesh,), friction=0.2, stiffness=1e5))
    for other, words in ((_in_tube(mesh, -0.002, 0.0, (floor,)), "kernel columns"), (stiffer, "stiffness")):
        with pytest.raises(SoftrnnInputError) as err:
            simulate_batch([first, other], RunConfig(dt=0.005, n_samples=3))
        assert "\n" not in str(err.value) and words in str(err.value) and "setups[1].contact" in str(err.value)


@pytest.mark.parametrize("threads", [2, 3])
def test_rods_on_several_threads_give_the_one_thread_figures_to_the_bit(threads, monkeypatch):
    """The blocks of rods run at once on threads (rod.threads.over_rods), each rod's arithmetic as on
    one thread: every sample of every rod equals the one-thread run's, to the bit."""
    setups = [_setup([NodalLoad(-1, force=Constant((0.0, 0.002 * (b + 1), 0.001 * b)))]) for b in range(5)]
    config = RunConfig(dt=0.01, n_samples=11, save_nodes=(0, 5, -1))
    monkeypatch.setattr(threads_module, "thread_count", lambda n_rods: 1)
    alone = simulate_batch(setups, config)
    blocks_run = []
    run = threads_module.over_rods

    def counted(kernel, n_rods, *args):
        blocks_run.append(min(threads, n_rods))
        return run(kernel, n_rods, *args)
    monkeypatch.setattr(threads_module, "thread_count", lambda n_rods: min(threads, n_rods))
    monkeypatch.setattr(batch_module, "over_rods", counted)
    together = simulate_batch(setups, config)
    assert blocks_run and set(blocks_run) == {threads}
    for got, want in zip(together, alone):
        for name in ("positions", "quaternions", "velocities", "angular_velocities", "forces", "torques"):
            assert np.array_equal(getattr(got, name), getattr(want, name)), name
