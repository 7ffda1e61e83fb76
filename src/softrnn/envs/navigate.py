"""``NavigateEnv``: the gymnasium environment of a guidewire steered through a vessel from its hub
(docs/guide/envs.md).

Action (2,) in [-1, 1]: the hub's insertion rate and rotation rate, as fractions of
``NavigateConfig.max_insertion_speed`` and ``max_rotation_speed``, held over one step of
``step_time``. Observation, reward and ends: ``softrnn.envs.episodes``.
"""

import gymnasium  # optional extra: envs
import numpy as np

from .config import NavigateConfig
from .episodes import Episodes


def spaces(episodes: Episodes) -> tuple:
    """(action space, observation space) of one environment."""
    action = gymnasium.spaces.Box(-1.0, 1.0, shape=(len(episodes.scale),), dtype=np.float32)
    if episodes.camera is not None:
        return action, gymnasium.spaces.Box(0, 255, shape=episodes.camera.shape, dtype=np.uint8)
    observation = gymnasium.spaces.Box(-np.inf, np.inf, shape=(episodes.size,), dtype=np.float32)
    return action, observation


class NavigateEnv(gymnasium.Env):
    """A guidewire in a vessel, inserted and rotated at its hub toward a target branch.

    Parameters
    ----------
    config : NavigateConfig or None
        the task and the device (None: the defaults)
    vessel : Bifurcation, Vessel, Track or None
        the vessel (None: ``default_vessel()``, a bifurcation)
    render_mode : None
        no rendering (the fluoroscopy look of ``softrnn animate`` draws a saved run)

    Attributes
    ----------
    episodes : Episodes
        the one episode's state and physics
    """

    metadata = {"render_modes": []}
    config_type = NavigateConfig
    """The task's class, its defaults when ``config`` is None."""
    episodes_type = Episodes
    """The episodes' class (a subclass for another device)."""

    def __init__(self, config: NavigateConfig | None = None, vessel=None, render_mode=None):
        self.config = self.config_type() if config is None else config
        self.episodes = self.episodes_type(self.config, vessel, 1)
        self.action_space, self.observation_space = spaces(self.episodes)
        self.render_mode = render_mode

    def reset(self, *, seed: int | None = None, options: dict | None = None):
        """Start an episode; ``options={"target": name}`` picks the target branch."""
        super().reset(seed=seed)
        self.episodes.reset(0, self.np_random, (options or {}).get("target"))
        return self.episodes.observe()[0], self.episodes.info(0)

    def step(self, action):
        """One step of ``step_time`` with the hub's rates ``action`` (2,) in [-1, 1] (more components
        for another device); an action out of bounds is refused with a one-line ``SoftrnnInputError``."""
        a = self.episodes.check_actions(action, 1)
        reward, terminated, truncated = self.episodes.step(a)
        return (self.episodes.observe()[0], float(reward[0]), bool(terminated[0]), bool(truncated[0]),
                self.episodes.info(0))
