"""Navigate a guidewire into a target branch: the scripted controller, then a small policy trained with
stable-baselines3 (PPO), each with its success rate.

    python examples/navigate_rl.py                       # scripted controller, then PPO for 4000 steps
    python examples/navigate_rl.py --scripted-only       # no RL (no stable-baselines3 needed)
    python examples/navigate_rl.py --steps 20000 --envs 8

Needs the optional extras ``envs`` (gymnasium) and, for the training, ``rl`` (stable-baselines3):
``pip install 'softrnn[envs,rl]'``. The training steps the environments in one batched kernel call
(``NavigateVectorEnv``) through the small adapter below, which gives stable-baselines3 the vector
interface it expects (its autoreset happens in the same step, with the last observation in
``terminal_observation``).
"""

import argparse

import numpy as np

from softrnn.envs import NavigateConfig, NavigateVectorEnv, ScriptedNavigator


def success_rate(envs: NavigateVectorEnv, policy, episodes: int, seed: int = 1) -> tuple[float, float]:
    """The fraction of ``episodes`` episodes that reach their target and the mean episode length
    [steps], with ``policy`` (observations (N, D) -> actions (N, 2)) on ``envs``."""
    obs, _ = envs.reset(seed=seed)
    started, ended, reached, lengths = envs.num_envs, 0, 0, []
    running = np.ones(envs.num_envs, dtype=bool)   # counts only the first `episodes` episodes
    while ended < episodes:
        obs, _, terminated, truncated, infos = envs.step(policy(obs))
        for b in np.flatnonzero(terminated | truncated):
            if running[b]:
                ended += 1
                reached += bool(infos["success"][b])
                lengths.append(int(envs.episodes.steps[b]))
            running[b] = started < episodes
            started += 1
    return reached / ended, float(np.mean(lengths))


def sb3_vec_env(envs: NavigateVectorEnv):
    """``envs`` as a stable-baselines3 ``VecEnv`` (same-step autoreset)."""
    from stable_baselines3.common.vec_env.base_vec_env import VecEnv  # optional extra: rl

    class Batched(VecEnv):
        def __init__(self):
            super().__init__(envs.num_envs, envs.single_observation_space, envs.single_action_space)
            self._actions = None
            self._rng = np.random.default_rng(0)

        def reset(self):
            obs, _ = envs.reset(seed=int(self._rng.integers(2**31)))
            return obs

        def step_async(self, actions):
            self._actions = np.clip(actions, -1.0, 1.0)

        def step_wait(self):
            ep = envs.episodes
            reward, terminated, truncated = ep.step(ep.check_actions(self._actions, self.num_envs))
            obs = ep.observe()
            infos = [ep.info(b) for b in range(self.num_envs)]
            for b in np.flatnonzero(terminated | truncated):
                infos[b]["terminal_observation"] = obs[b].copy()
                infos[b]["TimeLimit.truncated"] = bool(truncated[b] and not terminated[b])
                ep.reset(b, self._rng)
            return ep.observe(), reward.astype(np.float32), terminated | truncated, infos

        def close(self):
            pass

        def get_attr(self, name, indices=None):
            return [getattr(envs, name)] * len(self._indices(indices))

        def set_attr(self, name, value, indices=None):
            setattr(envs, name, value)

        def env_method(self, method, *args, indices=None, **kwargs):
            return [getattr(envs, method)(*args, **kwargs)] * len(self._indices(indices))

        def env_is_wrapped(self, wrapper_class, indices=None):
            return [False] * len(self._indices(indices))

        def _indices(self, indices):
            return range(self.num_envs) if indices is None else ([indices] if isinstance(indices, int) else indices)

    return Batched()


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--steps", type=int, default=4000, help="PPO's environment steps (all environments)")
    parser.add_argument("--envs", type=int, default=8, help="environments stepped together")
    parser.add_argument("--episodes", type=int, default=20, help="episodes of each evaluation")
    parser.add_argument("--scripted-only", action="store_true", help="evaluate the scripted controller only")
    args = parser.parse_args()
    config = NavigateConfig()
    envs = NavigateVectorEnv(args.envs, config)
    rate, length = success_rate(envs, ScriptedNavigator(episodes=envs.episodes), args.episodes)
    print(f"scripted controller: {100 * rate:.0f} % of {args.episodes} episodes reach the target branch "
          f"(mean length {length:.1f} steps of {config.step_time:g} s)")
    if args.scripted_only:
        return
    from stable_baselines3 import PPO  # optional extra: rl

    model = PPO("MlpPolicy", sb3_vec_env(envs), n_steps=64, batch_size=64, learning_rate=3e-4, seed=0, verbose=0)
    model.learn(total_timesteps=args.steps)
    rate, length = success_rate(envs, lambda obs: model.predict(obs, deterministic=True)[0], args.episodes)
    print(f"PPO after {args.steps} steps: {100 * rate:.0f} % of {args.episodes} episodes reach the target branch "
          f"(mean length {length:.1f} steps)")


if __name__ == "__main__":
    main()
