"""The magnetic vector environment steps its rods in one call of the batched kernel, in parallel over
the rods (softrnn.envs.MagneticNavigateVectorEnv): each rod with its own field gives, to the bit,
what a single environment gives with the same actions and seed, and a rod whose magnet comes too
close to a coil fails alone."""

import numpy as np
import pytest

gymnasium = pytest.importorskip("gymnasium")

import softrnn.envs.rods as rods_module  # noqa: E402 (after the skip)
import softrnn.rod.threads as threads_module  # noqa: E402
from softrnn.envs import MagneticNavigateConfig, MagneticNavigateEnv, MagneticNavigateVectorEnv, MagneticRod  # noqa: E402
from softrnn.magnetics import CurrentSchedule, ManipulatorSpec  # noqa: E402
from softrnn.magnetics.manipulator import magnetic_load  # noqa: E402
from softrnn.rod.status import KernelStatus  # noqa: E402

SMALL = MagneticNavigateConfig(device=MagneticRod(manipulator=ManipulatorSpec(n_nodes=14, magnet_stiffness_factor=3.0)),
                               step_time=0.02, checks_per_step=2, kept_nodes=3, max_steps=20)
"""As tests/envs/test_magnetic_env.py: a coarser rod and short steps."""

ACTIONS = np.array([[1.0, 0.0, 0.0, 1.0, 0.0], [0.5, 0.2, 0.0, -1.0, 0.3], [0.8, -0.3, 0.7, 0.2, -0.5],
                    [0.3, 0.1, -0.4, 0.0, 0.9]], dtype=np.float32)
"""Four rods, each its own hub rates and field (insertion, rotation, field x, y, z)."""


@pytest.fixture
def all_threads(monkeypatch):
    """One thread per rod for the batched kernel (whatever numba's thread count), so that rods sharing
    a buffer would race."""
    monkeypatch.setattr(threads_module, "thread_count", lambda n_rods: n_rods)


def _counting(monkeypatch) -> list:
    """The rods' batch sizes of every call of the batched kernel from now on (one call: its blocks of
    rods run at once on numba's threads)."""
    calls = []
    run = rods_module.over_rods

    def counted(kernel, n_rods, *args):
        assert kernel is rods_module.advance_rods
        calls.append(n_rods)
        return run(kernel, n_rods, *args)
    monkeypatch.setattr(rods_module, "over_rods", counted)
    return calls


def test_the_rods_stepped_in_one_parallel_call_equal_single_envs_to_the_bit(all_threads, monkeypatch):
    n, steps = len(ACTIONS), 3
    vector = MagneticNavigateVectorEnv(n, SMALL)
    singles = [MagneticNavigateEnv(SMALL) for _ in range(n)]
    obs, _ = vector.reset(seed=11)
    for b, env in enumerate(singles):
        assert np.array_equal(obs[b], env.reset(seed=11 + b)[0])
    calls = _counting(monkeypatch)
    for k in range(steps):
        actions = ACTIONS * (1.0 - 0.1 * k)
        calls.clear()
        obs, reward, terminated, truncated, _ = vector.step(actions)
        assert calls == [n]   # one call of the batched kernel for the n rods
        for b, env in enumerate(singles):
            one, r, term, trunc, _ = env.step(actions[b])
            assert np.array_equal(obs[b], one) and (reward[b], terminated[b], truncated[b]) == (r, term, trunc)
    rods = vector.episodes.rods
    for b, env in enumerate(singles):
        mine = env.episodes.rods
        assert np.array_equal(rods.state.positions[b], mine.state.positions[0])
        assert np.array_equal(rods.state.rotations[b], mine.state.rotations[0])
        assert np.array_equal(rods.currents[b], mine.currents[0])
        assert np.array_equal(rods.magnet_buffers["magnet_fields"][b], mine.magnet_buffers["magnet_fields"][0])
    fields = rods.magnet_buffers["magnet_fields"][:, 0]   # (B, M, 3): the field at each rod's magnets, first check
    assert all(np.abs(fields[i] - fields[j]).max() > 1e-4 for i in range(n) for j in range(i))   # each its own
    assert np.all(rods.status == KernelStatus.OK) and np.all(rods.magnet_failed == -1)


def _magnet_at_a_coil(env: MagneticNavigateVectorEnv, b: int, j: int) -> None:
    """Move rod ``b`` (rigidly) so that its magnet ``j`` sits on the first coil."""
    manipulator = SMALL.device.manipulator
    load = magnetic_load(manipulator, CurrentSchedule(np.zeros(1), np.zeros((1, manipulator.coils.n_coils))))
    r = env.episodes.rods.state.positions[b]
    t = load.fractions[j]
    magnet = (1.0 - t) * r[load.nodes[j]] + t * r[load.nodes[j] + 1]
    r += manipulator.coils.positions[0] - magnet


def test_a_rod_whose_magnet_comes_too_close_fails_alone():
    n = 3
    clean, broken = MagneticNavigateVectorEnv(n, SMALL), MagneticNavigateVectorEnv(n, SMALL)
    clean.reset(seed=4)
    broken.reset(seed=4)
    _magnet_at_a_coil(broken, 1, 1)
    moved = broken.episodes.rods.state.positions[1].copy()
    _, _, terminated, _, _ = broken.step(ACTIONS[:n])
    clean.step(ACTIONS[:n])
    rods = broken.episodes.rods
    assert rods.status.tolist() == [KernelStatus.OK, KernelStatus.MAGNET_TOO_CLOSE, KernelStatus.OK]
    assert rods.magnet_failed.tolist() == [-1, 1, -1] and rods.failed.tolist() == [False, True, False]
    assert np.array_equal(rods.state.positions[1], moved)   # the failed step left it where it was
    assert terminated.tolist() == [False, True, False]
    for b in (0, 2):   # the others as without the broken rod
        assert np.array_equal(rods.state.positions[b], clean.episodes.rods.state.positions[b])
        field = clean.episodes.rods.magnet_buffers["magnet_fields"][b]
        assert np.array_equal(rods.magnet_buffers["magnet_fields"][b], field)
