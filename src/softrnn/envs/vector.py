"""``NavigateVectorEnv``: N navigation environments stepped together, their rods advanced by one call
of the batched kernel (``envs._kernels``), in parallel over numba's threads.

It follows gymnasium's vector API with the next-step autoreset: the step after an episode ends
resets that environment (its action ignored, reward 0) and returns its first observation. With
the seeds s, s + 1, ..., s + N - 1 it gives what N ``NavigateEnv`` seeded so give, step for step.
"""

import gymnasium  # optional extra: envs
import numpy as np
from gymnasium.vector import AutoresetMode, VectorEnv  # optional extra: envs
from gymnasium.vector.utils import batch_space  # optional extra: envs

from ..errors import bad, integer
from .config import NavigateConfig
from .episodes import Episodes
from .navigate import spaces


class NavigateVectorEnv(VectorEnv):
    """``num_envs`` copies of ``NavigateEnv`` (same config and vessel) stepped in one batch.

    Parameters
    ----------
    num_envs : int
        the number of environments N
    config : NavigateConfig or None
        the task and the device (None: the defaults)
    vessel : Bifurcation, Vessel, Track or None
        the vessel (None: ``default_vessel()``)

    Attributes
    ----------
    episodes : Episodes
        the N episodes' state and physics
    """

    metadata = {"render_modes": [], "autoreset_mode": AutoresetMode.NEXT_STEP}
    config_type = NavigateConfig
    """The task's class, its defaults when ``config`` is None."""
    episodes_type = Episodes
    """The episodes' class (a subclass for another device)."""

    def __init__(self, num_envs: int = 1, config: NavigateConfig | None = None, vessel=None, render_mode=None):
        self.num_envs = integer("num_envs", num_envs, 1)
        self.config = self.config_type() if config is None else config
        self.episodes = self.episodes_type(self.config, vessel, self.num_envs)
        self.single_action_space, self.single_observation_space = spaces(self.episodes)
        self.action_space = batch_space(self.single_action_space, self.num_envs)
        self.observation_space = batch_space(self.single_observation_space, self.num_envs)
        self.render_mode = render_mode
        self._rngs = [np.random.default_rng() for _ in range(self.num_envs)]
        self._ended = np.zeros(self.num_envs, dtype=bool)

    def _seed(self, seed) -> None:
        """Per-environment generators: seed + i for an int, one each for a list, fresh for None."""
        if seed is None:
            return
        seeds = [seed + i for i in range(self.num_envs)] if isinstance(seed, int) else list(seed)
        if len(seeds) != self.num_envs:
            raise bad("seed", seed, f"an int or {self.num_envs} seeds")
        self._rngs = [gymnasium.utils.seeding.np_random(s)[0] for s in seeds]

    def reset(self, *, seed=None, options: dict | None = None):
        """Reset every environment; ``seed`` an int (environment i gets seed + i) or a list."""
        self._seed(seed)
        for b in range(self.num_envs):
            self.episodes.reset(b, self._rngs[b], (options or {}).get("target"))
        self._ended[:] = False
        return self.episodes.observe(), self._infos()

    def step(self, actions):
        """One step of every environment with ``actions`` (N, A) in [-1, 1] (A = 2: insertion and rotation;
        more for another device; next-step autoreset)."""
        a = self.episodes.check_actions(actions, self.num_envs)
        reward, terminated, truncated = self.episodes.step(a)
        for b in np.flatnonzero(self._ended):
            self.episodes.reset(b, self._rngs[b])
        reward[self._ended] = 0.0
        terminated[self._ended] = False
        truncated[self._ended] = False
        self._ended = terminated | truncated
        return self.episodes.observe(), reward, terminated, truncated, self._infos()

    def _infos(self) -> dict:
        """The environments' infos in gymnasium's vector form (arrays with their "_key" masks)."""
        infos: dict = {}
        for b in range(self.num_envs):
            infos = self._add_info(infos, self.episodes.info(b), b)
        return infos
