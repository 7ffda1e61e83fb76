"""The navigation environment (softrnn.envs.NavigateEnv): gymnasium's checks, seeded determinism, the
reward as progress along the target's centreline, the end on a perforation, the refusal of an action
out of bounds, the physics as the simulator's, and the vessel protocol."""

import dataclasses
import subprocess
import sys

import numpy as np
import pytest

gymnasium = pytest.importorskip("gymnasium")

from softrnn.envs import (  # noqa: E402 (after the skip)
    ENV_ID,
    BifurcationTrack,
    Guidewire,
    HubMotion,
    NavigateConfig,
    NavigateEnv,
    default_vessel,
)
from softrnn.envs.track import Paths  # noqa: E402
from softrnn.errors import SoftrnnInputError  # noqa: E402
from softrnn.geometry import Vessel  # noqa: E402
from softrnn.rod import Clamp, Simulator  # noqa: E402
from softrnn.rod.hub import Hub, axis_rotation  # noqa: E402
from softrnn.rod.integrators import Implicit  # noqa: E402

SMALL = NavigateConfig(device=Guidewire(length=0.06, n_nodes=13, tip_segments=2, tip_angle=20.0), step_time=0.01,
                       checks_per_step=2, kept_nodes=3, max_steps=20)
"""A short wire and short steps: the same code paths at a fraction of the cost."""


def test_the_environment_passes_gymnasiums_checks():
    from gymnasium.utils.env_checker import check_env

    env = NavigateEnv(SMALL)
    check_env(env, skip_render_check=True)
    assert env.observation_space.shape == (9 + 2 + 3 * 3,)


def test_it_is_registered_with_gymnasium():
    env = gymnasium.make(ENV_ID, config=SMALL)
    obs, info = env.reset(seed=1)
    assert obs.shape == env.observation_space.shape and info["target"] in ("left", "right")


def _rollout(seed: int, steps: int = 4):
    env = NavigateEnv(SMALL)
    obs, _ = env.reset(seed=seed)
    out = [obs]
    for k in range(steps):
        obs, reward, *_ = env.step(np.array([1.0, 0.5 * (-1) ** k], dtype=np.float32))
        out += [obs, np.array([reward])]
    return np.concatenate(out)


def test_a_seed_gives_the_same_episode():
    assert np.array_equal(_rollout(3), _rollout(3))


def test_the_reward_is_the_progress_along_the_target_centreline():
    env = NavigateEnv(SMALL)
    _, info = env.reset(seed=0, options={"target": "left"})
    start = before = info["progress"]
    for _ in range(3):
        _, reward, terminated, truncated, info = env.step(np.array([1.0, 0.0], dtype=np.float32))
        assert info["branch"] == "" and not terminated and not truncated
        assert reward == pytest.approx((info["progress"] - before) / SMALL.reward_length, rel=1e-12, abs=1e-12)
        before = info["progress"]
    pushed = 3 * SMALL.step_time * SMALL.max_insertion_speed
    assert 0.3 * pushed < before - start < 1.5 * pushed      # the tip follows the hub along the trunk


def test_a_contact_force_above_the_threshold_ends_the_episode_as_a_perforation():
    config = NavigateConfig(device=SMALL.device, step_time=SMALL.step_time, checks_per_step=2, kept_nodes=3,
                            perforation_force=1e-6)   # the wire's weight on the floor is more
    env = NavigateEnv(config)
    env.reset(seed=0)
    _, reward, terminated, truncated, info = env.step(np.zeros(2, dtype=np.float32))
    assert terminated and not truncated and info["perforated"] and not info["success"]
    assert info["contact_force"] > 1e-6
    assert reward == pytest.approx(-config.perforation_penalty, abs=1.0)


def test_an_episode_is_truncated_at_its_step_limit():
    config = NavigateConfig(device=SMALL.device, step_time=SMALL.step_time, checks_per_step=2, kept_nodes=3,
                            max_steps=2)
    env = NavigateEnv(config)
    env.reset(seed=0)
    assert env.step(np.zeros(2, dtype=np.float32))[3] is False
    assert env.step(np.zeros(2, dtype=np.float32))[3] is True


@pytest.mark.parametrize("action", [[1.5, 0.0], [0.0, -1.01], [np.nan, 0.0], [1.0, 0.0, 0.0]])
def test_an_action_outside_the_bounds_is_refused_in_one_line(action):
    env = NavigateEnv(SMALL)
    env.reset(seed=0)
    with pytest.raises(SoftrnnInputError) as err:
        env.step(np.array(action))
    text = str(err.value)
    assert "\n" not in text and text.startswith("action") and "[-1, 1]" in text


def test_the_physics_is_the_simulators():
    """The environment's batched kernel steps the rod as ``Simulator.advance`` with the implicit
    integrator does, given the same hub motion."""
    env = NavigateEnv(SMALL)
    env.reset(seed=0)
    rods = env.episodes.rods
    hub = Hub.commanded(rods.hubs[0].entry, rods.hubs[0].axis, rods.hubs[0].rotation0, travel=SMALL.travel)
    sim = Simulator(dataclasses.replace(rods.setups[0], boundary=(Clamp(0, motion=hub),)))
    sim.start(rods.h, Implicit())
    for action in ([1.0, 0.3], [0.5, -1.0], [-0.2, 0.0]):
        action = np.array(action, dtype=np.float32)
        env.step(action)
        hub.command(sim.state.time, insertion_rate=float(action[0]) * SMALL.max_insertion_speed,
                    rotation_rate=float(action[1]) * SMALL.max_rotation_speed)
        sim.advance(rods.substeps, rods.h, Implicit())
    np.testing.assert_allclose(rods.state.positions[0], sim.state.positions, rtol=0, atol=1e-12)
    np.testing.assert_allclose(rods.state.rotations[0], sim.state.rotations, rtol=0, atol=1e-12)


def test_the_hub_moves_continuously_within_its_travel():
    hub = HubMotion([0.0, 0.0, 0.0], np.eye(3), [1.0, 0.0, 0.0], travel=0.01)
    hub.command(0.0, 0.02, 1.0)
    pos, rot = hub(np.array([0.0, 0.25, 1.0]))
    np.testing.assert_allclose(pos[:, 0], [0.0, 0.005, 0.01])              # stops at the end of its travel
    np.testing.assert_allclose(rot[1] @ [0.0, 1.0, 0.0], [0.0, np.cos(0.25), np.sin(0.25)], atol=1e-15)
    hub.command(1.0, -0.01, 0.0)                                           # a new piece from where it is
    np.testing.assert_allclose(hub(np.array([1.0, 1.5]))[0][:, 0], [0.01, 0.005])
    assert hub.angle(np.array([3.0]))[0] == pytest.approx(1.0)


def test_progress_in_a_wrong_branch_counts_backwards():
    paths = Paths(BifurcationTrack(default_vessel()))
    assert paths.branches == ("left", "right") and np.allclose(paths.fork, 0.2)
    left = 0.02 * np.array([np.cos(np.pi / 6), np.sin(np.pi / 6), 0.0])
    progress, branch = paths.standing(np.stack([left, left * [1, -1, 1], [-0.05, 0, 0]]), np.zeros(3, dtype=int))
    np.testing.assert_allclose(progress, [0.22, 0.18, 0.15], atol=1e-9)
    assert branch.tolist() == [0, 1, -1]


def test_a_plain_vessel_is_a_track_of_one_branch_and_other_vessels_are_refused():
    vessel = Vessel([[-0.2, 0.0, 0.0], [0.05, 0.0, 0.0]], 0.004)
    env = NavigateEnv(SMALL, vessel=vessel)
    obs, info = env.reset(seed=0)
    assert info["target"] == "vessel" and obs.shape == (9 + 1 + 9,)
    with pytest.raises(SoftrnnInputError, match="vessel"):
        NavigateEnv(SMALL, vessel="aorta.stl")
    with pytest.raises(SoftrnnInputError, match="target"):
        NavigateEnv(NavigateConfig(target="middle", device=SMALL.device))


def test_without_gymnasium_the_package_names_its_extra(tmp_path):
    code = ("import sys\nsys.modules['gymnasium'] = None\n"
            "try:\n    import softrnn.envs\nexcept Exception as e:\n    print(type(e).__name__, e)\n")
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, cwd=tmp_path, timeout=120)
    assert done.stdout.startswith("SoftrnnInputError") and "pip install 'softrnn[envs]'" in done.stdout


def test_bench_names_the_missing_extra_in_one_line(tmp_path):
    code = ("import sys\nsys.modules['gymnasium'] = None\nfrom softrnn.cli.main import main\n"
            "sys.exit(main(['bench', '--only', 'envs', '--quick', '--json', 'b.json']))\n")
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, cwd=tmp_path, timeout=120)
    lines = done.stderr.strip().splitlines()
    assert done.returncode == 2 and len(lines) == 1 and "pip install 'softrnn[envs]'" in lines[0]
    assert not (tmp_path / "b.json").exists()


def test_a_track_may_say_where_its_branches_fork():
    class Track:
        obstacles, branches, entry_radius = (default_vessel(),), ("a", "b"), 0.004

        def centreline(self, branch):
            side = 1.0 if branch == "a" else -1.0      # the centrelines share only their first point
            return np.array([[-0.2, 0.0, 0.0], [-0.001, side * 1e-9, 0.0], [0.05, side * 0.03, 0.0]])

        def fork(self, branch):
            return 0.199

    paths = Paths(Track())
    np.testing.assert_allclose(paths.fork, [0.199, 0.199])
    assert paths.standing(np.array([[-0.05, 0.0, 0.0]]), np.array([1]))[1].tolist() == [-1]


def test_the_environments_hub_is_the_rods_hub_and_moves_piece_by_piece_within_its_travel():
    """The hub each rod follows (a ``softrnn.rod.Hub`` with a commanded insertion bounded by the
    travel) holds, to the last bit, the pose of the commanded rates: from where each step starts, the
    insertion s0 + v (t - t0) clipped to [0, travel] along the axis and the angle a0 + w (t - t0)."""
    config = dataclasses.replace(SMALL, travel=0.0008)
    env = NavigateEnv(config)
    env.reset(seed=2)
    rods = env.episodes.rods
    hub = rods.hubs[0]
    assert isinstance(hub, Hub) and rods.setups[0].boundary[0].motion is hub and rods.travel == 0.0008
    s0 = a0 = 0.0
    ends = []
    for action in ([1.0, 0.5], [1.0, -1.0], [-0.25, 0.0], [0.0, 0.125]):   # exact in float32
        t0 = float(rods.time[0])
        obs = env.step(np.array(action, dtype=np.float32))[0]
        v, w = action[0] * config.max_insertion_speed, action[1] * config.max_rotation_speed
        t = t0 + rods.h * np.arange(rods.substeps + 1)       # the solver steps' times, as the env takes them
        t1 = float(rods.time[0])                              # the next piece starts where this one is then
        t = np.append(t, t1)
        s = np.clip(s0 + v * (t - t0), 0.0, config.travel)
        a = a0 + w * (t - t0) if w != 0.0 else np.full(t.size, a0)
        pos, rot = hub(t[:-1])
        np.testing.assert_array_equal(pos, np.asarray(hub.entry) + s[:-1, None] * hub.axis)
        np.testing.assert_array_equal(rot, axis_rotation(hub.axis, a[:-1]) @ hub.rotation0)
        s0, a0 = float(s[-1]), float(a[-1])
        assert obs[6] == np.float32(s0) and obs[7] == np.float32(np.cos(a0)) and hub.at(t1) == (s0, a0)
        ends.append(s0)
    assert ends[1] == config.travel and ends[2] < config.travel   # it stopped at the end of its travel
    env.reset(seed=2)
    assert hub.at(0.5) == (0.0, 0.0)                             # a reset forgets the commands
