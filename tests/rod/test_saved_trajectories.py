"""Saved output: quaternions match the state, samples land on the saved times, chunked sinks
equal the collected trajectory, continuation runs pick up where they stopped."""

import numpy as np
import pytest

from softrnn.rod import Clamp, Constant, NodalLoad, RodSpec, RunConfig, Setup, Simulator, Sinusoid, Window, straight
from softrnn.rod import simulation as simulation_mod
from softrnn.rod.so3 import matrix_to_quaternion, quaternion_to_matrix


def _setup(n=12):
    rod = RodSpec(length=0.3, radius=0.01, youngs_modulus=1e6, density=1000, n_nodes=n)
    return Setup(rod=rod, reference=straight(n, 0.3, direction=(1, 0, 0), normal=(0, 0, 1)),
                 boundary=(Clamp(0),), gravity=(0, 0, -9.81),
                 loads=(NodalLoad(-1, force=Sinusoid((0, 0.02, 0), 2.0)),
                        NodalLoad(-1, torque=Window(Constant((0.001, 0, 0)), 0.0, 0.05), frame="body")))


def test_quaternions_are_the_states_rotations():
    sim = Simulator(_setup())
    traj = sim.run(RunConfig(dt=1e-3, n_samples=51))
    q_state = matrix_to_quaternion(sim.state.rotations)
    np.testing.assert_allclose(traj.quaternions[-1], q_state, atol=1e-14)
    np.testing.assert_allclose(np.linalg.norm(traj.quaternions, axis=-1), 1.0, atol=1e-14)
    R = traj.rotations()
    assert R.shape == (51, 12, 3, 3)
    np.testing.assert_allclose(quaternion_to_matrix(traj.quaternions[-1]), sim.state.rotations, atol=1e-13)
    np.testing.assert_allclose(traj.positions[-1], sim.state.positions, atol=0)
    assert np.abs(traj.quaternions[-1] - traj.quaternions[0]).max() > 1e-3  # it did rotate


def test_sink_chunks_equal_collected_run_and_continuation(monkeypatch):
    monkeypatch.setattr(simulation_mod, "_CHUNK_SAMPLES", 7)  # many small chunks
    config = RunConfig(dt=1e-3, n_samples=40, save_nodes=(3, -1))
    whole = Simulator(_setup()).run(config)
    np.testing.assert_allclose(whole.time, 1e-3 * np.arange(40), atol=1e-15)
    assert whole.positions.shape == (40, 2, 3) and list(whole.nodes) == [3, 11]
    chunks = []
    stats = Simulator(_setup()).run(config, sink=chunks.append)
    assert len(chunks) == 7 and stats.n_samples == 40 and stats.n_steps == 39 * stats.substeps
    for name in ("positions", "quaternions", "velocities", "forces", "torques", "reaction_forces", "energy"):
        np.testing.assert_array_equal(np.concatenate([getattr(c, name) for c in chunks]), getattr(whole, name))
    # two runs of 20 + 21 samples (the shared sample counted once) equal one run of 40
    sim = Simulator(_setup())
    first = sim.run(RunConfig(dt=1e-3, n_samples=20, save_nodes=(3, -1)))
    second = sim.run(RunConfig(dt=1e-3, n_samples=21, save_nodes=(3, -1)))
    assert second.time[0] == pytest.approx(first.time[-1])
    np.testing.assert_array_equal(second.velocities[0], first.velocities[-1])
    joined = np.concatenate([first.positions, second.positions[1:]])
    np.testing.assert_allclose(joined, whole.positions, atol=1e-14)


def test_applied_loads_and_reactions_are_reported():
    setup = _setup()
    traj = Simulator(setup).run(RunConfig(dt=1e-3, n_samples=101))
    t = traj.time
    np.testing.assert_allclose(traj.forces[:, -1, 1], 0.02 * np.sin(2 * np.pi * 2.0 * t), atol=1e-15)
    assert np.all(traj.forces[:, :-1] == 0)
    # the body-frame torque is reported in the world frame with its magnitude
    on = t < 0.05
    np.testing.assert_allclose(np.linalg.norm(traj.torques[on, -1], axis=1), 1e-3, rtol=1e-12)
    assert np.all(traj.torques[~on, -1] == 0)
    # only the clamped node carries a reaction
    assert np.abs(traj.reaction_forces[:, 0]).max() > 0
    assert np.all(traj.reaction_forces[:, 1:] == 0)


def test_progress_reports_every_chunk(monkeypatch):
    monkeypatch.setattr(simulation_mod, "_CHUNK_SAMPLES", 10)
    seen = []
    Simulator(_setup()).run(RunConfig(dt=1e-3, n_samples=35, save_nodes=(-1,)),
                            progress=lambda done, total: seen.append((done, total)))
    assert seen[-1] == (35, 35)
    assert [d for d, _ in seen] == sorted(d for d, _ in seen)
    assert len(seen) >= 4


@pytest.mark.parametrize("bad_nodes", [(12,), (-13,)])
def test_bad_save_nodes(bad_nodes):
    with pytest.raises(ValueError, match="save_nodes"):
        Simulator(_setup()).run(RunConfig(dt=1e-3, n_samples=3, save_nodes=bad_nodes))
