"""B navigation episodes over one ``RodBatch``: the actions' check and scaling, the observations,
the reward, the ends of an episode. ``NavigateEnv`` runs one, ``NavigateVectorEnv`` many; both
through this class, so that they agree step for step.

Observation (float32, (9 + J + 3 k,)): the tip's position (3) [m] and heading (3, unit: d3 of the
last node), the hub's insertion [m] and angle (cos, sin), the target branch one-hot (J), the kept
nodes' positions (k, 3) [m], hub to tip, flattened. Reward: the progress along the target's
centreline per ``reward_length``, less ``wrong_branch_penalty`` per step in another branch, plus
``success_reward`` on reaching the target, less ``perforation_penalty`` on a perforation (a contact
force above ``perforation_force``, or a failed step). With ``observation="image"`` the observation is
the fluoroscopy image (H, W, 1) uint8 instead (``softrnn.envs.fluoro``).
"""

import numpy as np

from ..errors import bad
from ..geometry.obstacles import Bifurcation, Vessel
from .config import NavigateConfig
from .fluoro import Fluoroscope
from .rods import RodBatch
from .track import BifurcationTrack, Paths, Track, default_vessel

ACTION_TOLERANCE = 1e-6
"""How far outside [-1, 1] an action may stand (rounding) before it is refused."""


def as_track(vessel) -> Track:
    """A ``Track`` of ``vessel``: the default vessel for None, a ``Bifurcation`` or ``Vessel``
    adapted (``BifurcationTrack``), a ``Track`` as it is."""
    if vessel is None:
        vessel = default_vessel()
    if isinstance(vessel, (Bifurcation, Vessel)):
        return BifurcationTrack(vessel)
    if not isinstance(vessel, Track):
        raise bad("vessel", type(vessel).__name__, "a Bifurcation, a Vessel or a softrnn.envs.Track "
                                                   "(obstacles, branches, entry_radius, centreline(branch))")
    return vessel


class Episodes:
    """B episodes of the navigation task, stepped together.

    Attributes
    ----------
    rods : RodBatch
        the physics
    paths : Paths
        the vessel's branches
    target : (B,) int64
        each episode's target branch (an index of ``paths.branches``)
    progress : (B,)
        the tip's progress toward the target [m] (``Paths.standing``)
    branch : (B,) int64
        the branch the tip is in, -1 before the forks
    steps : (B,) int64
        steps since the episode's reset
    scale : (A,)
        the action's units: each component's value at +-1 (insertion [m/s], rotation [rad/s])
    camera : Fluoroscope or None
        the image observation's renderer (``observation="image"``), else None
    """

    rod_batch = RodBatch
    """The physics' class (a subclass for another device)."""
    actions = "insertion and rotation"
    """The action's components, as the bounds' error names them."""

    def __init__(self, config: NavigateConfig, vessel, n: int):
        self.config = config
        self.track = as_track(vessel)
        self.paths = Paths(self.track)
        if config.target is not None:
            self.paths.index(config.target)
        self.rods = self.rod_batch(config, self.track, n)
        self.kept = config.kept()
        self.scale = np.array([config.max_insertion_speed, config.max_rotation_speed])
        self.camera = None if config.observation != "image" else \
            Fluoroscope(config.image, self.paths, self.rods.setups[0].contact, self.track.entry_radius,
                        config.device.radius, config.goal_depth, config.gravity)
        self.target = np.zeros(n, dtype=np.int64)
        self.progress = np.zeros(n)
        self.branch = np.full(n, -1, dtype=np.int64)
        self.steps = np.zeros(n, dtype=np.int64)
        self.tip = np.zeros((n, 3))
        self.outcome = np.zeros((n, 3), dtype=bool)  # success, perforated, diverged

    @property
    def size(self) -> int:
        """The observation's length: 9 + J + 3 k."""
        return 9 + len(self.paths.branches) + 3 * len(self.kept)

    def limits(self) -> str:
        """The largest values of the action's components, as the bounds' error says them."""
        return f"{self.config.max_insertion_speed:g} m/s, {self.config.max_rotation_speed:g} rad/s"

    def check_actions(self, actions, n: int) -> np.ndarray:
        """``actions`` as (n, A) floats in [-1, 1] (A = len(scale): insertion, rotation, ...); a
        one-line error naming the value and the bounds otherwise."""
        a = np.asarray(actions, dtype=float)
        k = len(self.scale)
        if a.size != k * n:
            raise bad("action", a.tolist(), f"{f'{k} values' if n == 1 else f'({n}, {k}) values'}: "
                                            f"{self.actions}, each in [-1, 1] (the "
                                            "fractions of the largest rates)")
        a = a.reshape(n, k)
        if not np.all(np.isfinite(a)) or np.any(np.abs(a) > 1.0 + ACTION_TOLERANCE):
            raise bad("action", a.tolist() if n > 1 else a[0].tolist(),
                      f"{self.actions} each in [-1, 1], the fractions of the largest rates ({self.limits()}); "
                      "clip the policy's output to the action space")
        return np.clip(a, -1.0, 1.0)

    def reset(self, b: int, rng: np.random.Generator, target: str | None = None) -> None:
        """Start episode ``b`` afresh: the device at its start, the target ``target`` (a branch name),
        else the config's, else one drawn from ``rng``."""
        name = target if target is not None else self.config.target
        self.target[b] = self.paths.index(name) if name is not None else int(rng.integers(len(self.paths.branches)))
        self.rods.reset(b)
        self.tip[b] = self.rods.state.positions[b, -1]
        progress, branch = self.paths.standing(self.tip[b:b + 1], self.target[b:b + 1])
        self.progress[b], self.branch[b] = progress[0], branch[0]
        self.steps[b] = 0
        self.outcome[b] = False

    def step(self, actions: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Advance every episode one step with checked ``actions`` (B, 2); returns the rewards (B,),
        terminated (B,) and truncated (B,)."""
        c = self.config
        self.rods.step(actions * self.scale)
        failed = self.rods.failed
        tip = self.rods.state.positions[:, -1]
        fine = ~failed & np.all(np.isfinite(tip), axis=1)
        self.tip[fine] = tip[fine]
        progress, self.branch = self.paths.standing(self.tip, self.target)
        reward = (progress - self.progress) / c.reward_length
        self.progress = progress
        wrong = (self.branch >= 0) & (self.branch != self.target)
        deep = self.progress >= self.paths.fork[self.target] + c.goal_depth
        success = fine & (self.branch == self.target) & deep
        perforated = ~fine | (self.rods.contact_force > c.perforation_force)
        success &= ~perforated
        reward = reward - c.wrong_branch_penalty * wrong + c.success_reward * success \
            - c.perforation_penalty * perforated
        self.steps += 1
        terminated = success | perforated
        self.outcome = np.stack([success, perforated, ~fine], axis=1)
        return reward, terminated, ~terminated & (self.steps >= c.max_steps)

    def observe(self) -> np.ndarray:
        """The observations (B, 9 + J + 3 k) float32, or the images (B, H, W, 1) uint8 (module docstring)."""
        st, B = self.rods.state, len(self.target)
        if self.camera is not None:
            return self.camera.render(st.positions, self.target)
        fine = np.all(np.isfinite(st.positions), axis=(1, 2))
        nodes = np.where(fine[:, None, None], st.positions[:, self.kept], 0.0)
        heading = np.where(fine[:, None], st.rotations[:, -1, :, 2], 0.0)
        t = self.rods.time
        hub = np.array([h.at(t[b]) for b, h in enumerate(self.rods.hubs)])
        onehot = np.zeros((B, len(self.paths.branches)))
        onehot[np.arange(B), self.target] = 1.0
        parts = [self.tip, heading, hub[:, :1], np.cos(hub[:, 1:]), np.sin(hub[:, 1:]), onehot,
                 nodes.reshape(B, -1)]
        return np.concatenate(parts, axis=1).astype(np.float32)

    def info(self, b: int) -> dict:
        """Episode ``b``'s state: target and branch names, progress [m], time [s], the largest
        contact force [N] of the last step, the deepest node in the wall [m], the outcome flags."""
        success, perforated, diverged = (bool(x) for x in self.outcome[b])
        branch = int(self.branch[b])
        finite = np.all(np.isfinite(self.rods.state.positions[b]))
        depth = float(max(0.0, -np.min(self.rods.gaps(b)))) if finite else float("inf")
        return {"target": self.paths.branches[self.target[b]], "branch": self.paths.branches[branch] if branch >= 0
                else "", "progress": float(self.progress[b]), "time": float(self.rods.time[b]),
                "contact_force": float(self.rods.contact_force[b]), "penetration": depth,
                "success": success, "perforated": perforated, "diverged": diverged}
