"""``ScriptedNavigator``: a hand-written controller of the navigation environments, the baseline a
learned policy has to beat. It turns the hub until the shaped tip's bend points toward the target
branch (across the centreline where the tip stands), inserts while it does, waits at the fork while
it does not, points the tip away from another branch whose fork comes first (an aortic arch's), and
pulls back out of a wrong branch.
"""

from dataclasses import dataclass

import numpy as np

from ..errors import bad
from .episodes import Episodes


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

    def _branch_direction(self, j: int) -> np.ndarray:
        """Branch j's direction (3,) from its fork to its end [m]."""
        paths = self.episodes.paths
        return paths.lines[j][-1] - paths.lines[j][np.searchsorted(paths.arc[j], paths.fork[j])]

    def _geometry(self, target: np.ndarray, progress: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """The local insertion axis (B, 3): the target centreline's direction where the tip stands on
        it (at most at its fork), the direction (B, 3) to aim the tip at across it: away from another
        branch whose fork comes first, from 2 ``approach`` before that fork to ``approach`` past it,
        else toward the target branch, and whether it avoids such a branch (B,) bool."""
        paths = self.episodes.paths
        axis = np.empty((len(target), 3))
        want = np.empty((len(target), 3))
        avoiding = np.zeros(len(target), dtype=bool)
        for i, (j, s) in enumerate(zip(target, progress)):
            line, arc = paths.lines[j], paths.arc[j]
            k = int(np.clip(np.searchsorted(arc, min(s, paths.fork[j])) - 1, 0, len(line) - 2))
            axis[i] = (line[k + 1] - line[k]) / np.linalg.norm(line[k + 1] - line[k])
            want[i] = self._branch_direction(j)
            before = [m for m in range(len(paths.branches)) if paths.fork[m] < paths.fork[j] - self.approach
                      and -2.0 * self.approach < s - paths.fork[m] < self.approach]
            if before:
                want[i] = -self._branch_direction(min(before, key=lambda m: abs(s - paths.fork[m])))
                avoiding[i] = True
        return axis, want, avoiding

    def _across(self, v: np.ndarray, axis: np.ndarray) -> np.ndarray:
        """The parts (B, 3) of v (B, 3) across each row's ``axis`` (B, 3), unit (0 where there is none)."""
        u = v - np.sum(v * axis, axis=1)[:, None] * axis
        size = np.linalg.norm(u, axis=1, keepdims=True)
        return np.divide(u, size, out=np.zeros_like(u), where=size > 1e-12)

    def __call__(self, observation) -> np.ndarray:
        """The actions for ``observation`` (D,) or (B, D) of the environment."""
        obs = np.asarray(observation, dtype=float)
        x = np.atleast_2d(obs)
        J = len(self.episodes.paths.branches)
        tip, heading, target = x[:, 0:3], x[:, 3:6], np.argmax(x[:, 9:9 + J], axis=1)
        progress, branch = self.episodes.paths.standing(tip, target)
        axis, want, _ = self._geometry(target, progress)
        want, have = self._across(want, axis), self._across(heading, axis)
        error = np.arctan2(np.sum(np.cross(have, want) * axis, axis=1), np.sum(have * want, axis=1))
        error = np.where(np.any(want != 0, axis=1) & np.any(have != 0, axis=1), error, 0.0)
        c = self.episodes.config
        turn = np.clip(self.gain * error / (c.max_rotation_speed * c.step_time), -1.0, 1.0)
        fork = self.episodes.paths.fork[target]
        near = (progress > fork - self.approach) & (branch != target)
        insert = np.where(near & (np.abs(error) > self.aim), 0.0, 1.0)
        wrong = (branch >= 0) & (branch != target)
        # out of a wrong branch whose fork comes first (an arch's): turn the tip while pulling back, for another try
        first = wrong & (self.episodes.paths.fork[np.maximum(branch, 0)] < fork - self.approach)
        action = np.stack([np.where(wrong, -1.0, insert), np.where(first, 1.0, np.where(wrong, 0.0, turn))], axis=1)
        return action.astype(np.float32).reshape(obs.shape[:-1] + (2,))
