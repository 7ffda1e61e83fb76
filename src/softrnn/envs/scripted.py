"""``ScriptedNavigator``: a hand-written controller of the navigation environments, the baseline a
learned policy has to beat. It turns the hub until the shaped tip's bend points toward the target
branch, inserts while it does, waits at the fork while it does not, and pulls back out of a wrong
branch.
"""

from dataclasses import dataclass

import numpy as np

from ..errors import bad
from .episodes import Episodes


def _lateral(v: np.ndarray, axis: np.ndarray) -> np.ndarray:
    """The parts (B, 3) of vectors v (B, 3) across ``axis`` (3,), unit (0 where there is none)."""
    u = v - (v @ axis)[:, None] * axis
    size = np.linalg.norm(u, axis=1, keepdims=True)
    return np.divide(u, size, out=np.zeros_like(u), where=size > 1e-12)


@dataclass(frozen=True, kw_only=True)
class ScriptedNavigator:
    """The scripted controller of an ``Episodes`` (``env.unwrapped.episodes``): observations
    (D,) or (B, D) -> actions (2,) or (B, 2) in [-1, 1].

    Attributes
    ----------
    episodes : Episodes
        the environment's episodes (its vessel's branches and the observation's layout)
    approach : float
        how far before a fork the tip must point at the target to go on [m]
    aim : float
        the largest error of the tip's direction, about the insertion axis, at which it inserts
        near a fork [rad]
    gain : float
        the rotation commanded per rad of error, as a fraction of the largest rotation in one step
    """

    episodes: Episodes
    approach: float = 0.015
    aim: float = 0.35
    gain: float = 0.5

    def __post_init__(self):
        if not isinstance(self.episodes, Episodes):
            raise bad("episodes", type(self.episodes).__name__, "an environment's episodes (env.unwrapped.episodes)")

    def _geometry(self, target: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """The insertion axis (3,) and each target's direction (B, 3) across it, from its fork."""
        paths = self.episodes.paths
        line = paths.lines[0]
        axis = (line[1] - line[0]) / np.linalg.norm(line[1] - line[0])
        want = np.empty((len(target), 3))
        for i, j in enumerate(target):
            fork = paths.lines[j][np.searchsorted(paths.arc[j], paths.fork[j])]
            want[i] = paths.lines[j][-1] - fork
        return axis, _lateral(want, axis)

    def __call__(self, observation) -> np.ndarray:
        """The actions for ``observation`` (D,) or (B, D) of the environment."""
        obs = np.asarray(observation, dtype=float)
        x = np.atleast_2d(obs)
        J = len(self.episodes.paths.branches)
        tip, heading, target = x[:, 0:3], x[:, 3:6], np.argmax(x[:, 9:9 + J], axis=1)
        axis, want = self._geometry(target)
        have = _lateral(heading, axis)
        error = np.arctan2(np.cross(have, want) @ axis, np.sum(have * want, axis=1))
        error = np.where(np.any(want != 0, axis=1) & np.any(have != 0, axis=1), error, 0.0)
        c = self.episodes.config
        turn = np.clip(self.gain * error / (c.max_rotation_speed * c.step_time), -1.0, 1.0)
        progress, branch = self.episodes.paths.standing(tip, target)
        fork = self.episodes.paths.fork[target]
        near = (progress > fork - self.approach) & (branch != target)
        insert = np.where(near & (np.abs(error) > self.aim), 0.0, 1.0)
        wrong = (branch >= 0) & (branch != target)
        action = np.stack([np.where(wrong, -1.0, insert), np.where(wrong, 0.0, turn)], axis=1)
        return action.astype(np.float32).reshape(obs.shape[:-1] + (2,))
