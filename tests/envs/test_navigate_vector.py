"""The vectorised navigation environment (softrnn.envs.NavigateVectorEnv): N environments in one
batched kernel call give what N single environments give, step for step, through the autoreset;
gymnasium's make_vec builds it; the scripted controller reaches the target branch."""

import numpy as np
import pytest

gymnasium = pytest.importorskip("gymnasium")

from softrnn.envs import (  # noqa: E402 (after the skip)
    ENV_ID,
    Guidewire,
    NavigateConfig,
    NavigateEnv,
    NavigateVectorEnv,
    ScriptedNavigator,
)
from softrnn.errors import SoftrnnInputError  # noqa: E402

SMALL = NavigateConfig(device=Guidewire(length=0.06, n_nodes=13, tip_segments=2, tip_angle=20.0), step_time=0.01,
                       checks_per_step=2, kept_nodes=3, max_steps=3)
"""Short episodes (3 steps), so that the run goes through the autoreset."""


def _actions(k: int, n: int) -> np.ndarray:
    """A fixed sequence of actions (n, 2) that differ between the environments."""
    i = np.arange(n)
    return np.stack([np.cos(0.7 * k + i), np.sin(1.3 * k - i)], axis=1).astype(np.float32)


def test_the_vector_env_equals_n_single_envs_step_for_step():
    n, steps = 3, 8
    vector = NavigateVectorEnv(n, SMALL)
    singles = [NavigateEnv(SMALL) for _ in range(n)]
    obs, infos = vector.reset(seed=7)
    for b, env in enumerate(singles):
        one, info = env.reset(seed=7 + b)
        assert np.array_equal(obs[b], one) and infos["target"][b] == info["target"]
    ended = np.zeros(n, dtype=bool)
    for k in range(steps):
        actions = _actions(k, n)
        obs, reward, terminated, truncated, infos = vector.step(actions)
        for b, env in enumerate(singles):
            if ended[b]:   # next-step autoreset: this step resets the environment
                one, info = env.reset()
                assert reward[b] == 0.0 and not terminated[b] and not truncated[b]
            else:
                one, r, term, trunc, info = env.step(actions[b])
                assert (reward[b], terminated[b], truncated[b]) == (r, term, trunc)
            assert np.array_equal(obs[b], one)
            assert infos["progress"][b] == info["progress"] and infos["target"][b] == info["target"]
        ended = terminated | truncated
    assert vector.episodes.steps.max() <= SMALL.max_steps


def test_make_vec_builds_the_batched_env():
    envs = gymnasium.make_vec(ENV_ID, num_envs=2, vectorization_mode="vector_entry_point", config=SMALL)
    obs, _ = envs.reset(seed=0)
    assert obs.shape == (2,) + envs.single_observation_space.shape
    obs, reward, *_ = envs.step(envs.action_space.sample())
    assert obs.dtype == np.float32 and reward.shape == (2,)


def test_the_vector_env_refuses_actions_out_of_bounds_in_one_line():
    envs = NavigateVectorEnv(2, SMALL)
    envs.reset(seed=0)
    with pytest.raises(SoftrnnInputError) as err:
        envs.step(np.array([[0.0, 0.0], [0.0, 2.0]]))
    assert "\n" not in str(err.value) and "[-1, 1]" in str(err.value)
    with pytest.raises(SoftrnnInputError, match="action"):
        envs.step(np.zeros((3, 2)))


@pytest.mark.slow
def test_the_scripted_navigator_reaches_either_branch():
    envs = NavigateVectorEnv(2, NavigateConfig())
    pilot = ScriptedNavigator(episodes=envs.episodes)
    obs, _ = envs.reset(seed=0, options={})
    envs.episodes.reset(0, np.random.default_rng(0), "left")
    envs.episodes.reset(1, np.random.default_rng(0), "right")
    obs = envs.episodes.observe()
    done = np.zeros(2, dtype=bool)
    success = np.zeros(2, dtype=bool)
    for _ in range(NavigateConfig().max_steps):
        obs, _, terminated, truncated, infos = envs.step(pilot(obs))
        success |= ~done & infos["success"]
        done |= terminated | truncated
        if done.all():
            break
    assert success.all()


def test_the_examples_success_rate_counts_each_episode_once():
    """examples/navigate_rl.py's evaluation: with episodes of at most 3 steps and a policy that never
    reaches the target, every one of the episodes asked for ends truncated at 3 steps, counted once,
    though the environments keep running past the count (an odd count over 2 environments)."""
    import runpy
    from pathlib import Path

    example = runpy.run_path(str(Path(__file__).resolve().parents[2] / "examples" / "navigate_rl.py"))
    envs = NavigateVectorEnv(2, SMALL)
    held = np.zeros((2, 2), np.float32)
    assert example["success_rate"](envs, lambda obs: held[: len(obs)], 5) == (0.0, 3.0)


def test_the_benchmark_reports_both_runs_and_the_goal():
    from softrnn.bench.envs import PUBLISHED, format_envs_table, run_envs_benchmark

    result = run_envs_benchmark(span_s=0.0, config=SMALL, n_envs=2)
    single, vector = result["single"], result["vector"]
    assert single["envs"] == 1 and vector["envs"] == 2 and vector["vector_steps"] >= 3
    assert result["speedup"] == pytest.approx(vector["steps_per_s"] / single["steps_per_s"])
    assert vector["real_time_factor"] == pytest.approx(vector["steps_per_s"] / 2 * SMALL.step_time)
    assert result["goal"]["met"] == (result["speedup"] >= 10.0)
    assert 0.0 < single["kernel_fraction"] <= 1.0 and result["bound"]["speedup_limit"] > 0
    assert all(p["env_steps_per_s"] is None or p["env_steps_per_s"] > 0 for p in PUBLISHED.values())
    table = format_envs_table(result)
    assert "NavigateVectorEnv" in table and "stEVE" in table and "CathSim" in table
