"""The navigation environment's settings: the device (``Guidewire``: a wire with a soft, shaped tip)
and the task (``NavigateConfig``: hub rates, step length, reward, termination), frozen and validated.

Every default is an assumption, said where it is set (docs/guide/envs.md collects them).
"""

import math
from dataclasses import dataclass, field

import numpy as np

from ..errors import bad, integer, nonnegative, positive
from ..rod import NodeOverride, RodShape, RodSpec, polyline
from .fluoro import Fluoroscopy

OBSERVATIONS = ("state", "image")
"""The observations a ``NavigateConfig`` may choose."""


@dataclass(frozen=True, kw_only=True)
class Guidewire:
    """A guidewire's part beyond the hub: a uniform core with a soft, pre-shaped (angled) tip.

    Attributes
    ----------
    length : float
        length from the hub to the tip [m] (0.15: the part that moves in the vessel)
    n_nodes : int
        nodes (31: 5 mm segments, three of them in the tip)
    radius : float
        radius [m] (0.45 mm: a 0.035 inch wire)
    youngs_modulus : float
        effective E of the core [Pa] (1 GPa over the section, E I = 3.2e-5 N m^2: a 0.3 mm nitinol
        core in a polymer jacket, as the ``vessel-guidewire`` scenario)
    tip_youngs_modulus : float
        effective E of the tip's nodes [Pa] (0.25 GPa: a tip four times softer than the core)
    density : float
        effective density [kg/m^3] (2000: nitinol in a polymer jacket)
    poisson_ratio : float
        nu [-]
    tip_segments : int
        segments of the shaped tip (the last ones), >= 1
    tip_angle : float
        the tip's total bend in its stress-free shape [deg], in [0, 90) (30: an angled tip, its
        bend shared equally by the tip's nodes)
    """

    length: float = 0.15
    n_nodes: int = 31
    radius: float = 0.00045
    youngs_modulus: float = 1e9
    tip_youngs_modulus: float = 0.25e9
    density: float = 2000.0
    poisson_ratio: float = 0.33
    tip_segments: int = 3
    tip_angle: float = 30.0

    def __post_init__(self):
        integer("device.n_nodes", self.n_nodes, 3)
        integer("device.tip_segments", self.tip_segments, 1)
        if self.tip_segments >= self.n_nodes - 1:
            raise bad("device.tip_segments", self.tip_segments, f"fewer than the {self.n_nodes - 1} segments")
        if not 0.0 <= self.tip_angle < 90.0:
            raise bad("device.tip_angle", self.tip_angle, "a bend in [0, 90) degrees")
        self.spec()  # validates the rest

    def spec(self) -> RodSpec:
        """The rod: the core's material, the tip's nodes softer (a ``NodeOverride``)."""
        first = self.n_nodes - 1 - self.tip_segments
        return RodSpec(length=self.length, radius=self.radius, youngs_modulus=self.youngs_modulus,
                       density=self.density, n_nodes=self.n_nodes, poisson_ratio=self.poisson_ratio,
                       overrides=(NodeOverride(first=first, last=self.n_nodes - 1,
                                               youngs_modulus=self.tip_youngs_modulus),))

    def shape(self, origin, direction, bend) -> RodShape:
        """The stress-free shape from the hub at ``origin`` (3,) [m] along ``direction`` (3,), the
        tip bent toward ``bend`` (3,), orthogonal to it; d1 points along ``bend``."""
        d = np.asarray(direction, dtype=float) / np.linalg.norm(direction)
        b = np.asarray(bend, dtype=float)
        b = b - (b @ d) * d
        b /= np.linalg.norm(b)
        l = self.length / (self.n_nodes - 1)
        turn = math.radians(self.tip_angle) / self.tip_segments
        angles = np.concatenate([np.zeros(self.n_nodes - 1 - self.tip_segments),
                                 turn * np.arange(1, self.tip_segments + 1)])
        steps = l * (np.cos(angles)[:, None] * d + np.sin(angles)[:, None] * b)
        points = np.asarray(origin, dtype=float) + np.concatenate([np.zeros((1, 3)), np.cumsum(steps, axis=0)])
        return polyline(points, normal=b)

    def tip_offset(self) -> float:
        """How far the tip stands off the core's axis in the stress-free shape [m]."""
        l = self.length / (self.n_nodes - 1)
        turn = math.radians(self.tip_angle) / self.tip_segments
        return float(l * np.sum(np.sin(turn * np.arange(1, self.tip_segments + 1))))


@dataclass(frozen=True, kw_only=True)
class NavigateConfig:
    """The navigation task (docs/guide/envs.md).

    Attributes
    ----------
    device : Guidewire
        the device
    step_time : float
        simulated time per environment step [s] (0.1: a 10 Hz controller)
    max_insertion_speed : float
        the hub's insertion rate at action +-1 [m/s] (0.05: a slow manual push)
    max_rotation_speed : float
        the hub's rotation rate at action +-1 [rad/s] (pi: half a turn per second)
    travel : float or None
        how far the hub may advance from its start [m] (0.1: the tip then ends short of the default
        vessel's branch ends); it may come back to the start, not behind. None: sized from the
        vessel (``envs.rods.hub_travel``: until a straight device's tip would reach the end of its
        longest branch)
    max_steps : int
        steps of an episode before it is truncated
    friction : float
        Coulomb friction of the vessel wall [-] (0.1: a hydrophilic-coated wire)
    contact_stiffness : float
        penalty stiffness per length of rod [N/m^2] (2e5: the wall forces of steering sink the wire
        a few % of its radius into the wall at a solver step five times the ``vessel-guidewire``
        scenario's)
    contact_damping : float
        normal damping per length of rod [N s/m^2] (10: 0.3 of critical for the default wire and
        stiffness, which allows a solver step about twice as long as critical damping does)
    drag : float
        viscous drag per length [N s/m^2] (0.05: blood, as ``vessel-guidewire``)
    gravity : tuple
        (3,) [m/s^2]
    perforation_force : float
        a contact force on one node above this ends the episode as a perforation [N] (0.5: the
        order of the forces that puncture an arterial wall with a wire's tip)
    goal_depth : float
        the target is reached when the tip is this far into the target branch past its fork [m]
    reward_length : float
        progress along the target's centreline per unit of reward [m]
    wrong_branch_penalty : float
        reward taken per step while the tip is in another branch
    success_reward : float
        reward of reaching the target
    perforation_penalty : float
        reward taken on a perforation (or a diverged step)
    kept_nodes : int
        nodes in the observation, evenly spaced from the hub to the tip (the tip included), >= 2
    checks_per_step : int
        samples of the contact forces per step checked for a perforation, >= 1
    target : str or None
        the target branch, or None: one drawn per episode from the vessel's branches
    observation : str
        "state" (default: the tip, the hub, the target and the kept nodes, a float vector) or "image"
        (a fluoroscopy image of the rod in the lumen, uint8, ``image``; ``softrnn.envs.fluoro``)
    image : Fluoroscopy
        the image's size and view (used with ``observation="image"``)
    implicit_contact : bool
        the wall's normal force linearly implicit in the solver step (``Contact(implicit=True)``):
        a longer solver step in a meshed vessel (False: explicit, as the default vessel's figures)
    """

    device: Guidewire = field(default_factory=Guidewire)
    step_time: float = 0.1
    max_insertion_speed: float = 0.05
    max_rotation_speed: float = math.pi
    travel: float | None = 0.1
    max_steps: int = 150
    friction: float = 0.1
    contact_stiffness: float = 2e5
    contact_damping: float = 10.0
    drag: float = 0.05
    gravity: tuple = (0.0, 0.0, -9.81)
    perforation_force: float = 0.5
    goal_depth: float = 0.03
    reward_length: float = 0.01
    wrong_branch_penalty: float = 0.1
    success_reward: float = 10.0
    perforation_penalty: float = 10.0
    kept_nodes: int = 6
    checks_per_step: int = 10
    target: str | None = None
    observation: str = "state"
    image: Fluoroscopy = field(default_factory=Fluoroscopy)
    implicit_contact: bool = False

    def _check_device(self) -> None:
        """A one-line error unless ``device`` is this task's kind of device."""
        if not isinstance(self.device, Guidewire):
            raise bad("device", self.device, "a softrnn.envs.Guidewire")

    def __post_init__(self):
        self._check_device()
        if self.observation not in OBSERVATIONS:
            raise bad("observation", self.observation, f"one of {', '.join(OBSERVATIONS)}")
        if not isinstance(self.image, Fluoroscopy):
            raise bad("image", self.image, "a softrnn.envs.Fluoroscopy")
        for name, unit in (("step_time", "s"), ("max_insertion_speed", "m/s"), ("max_rotation_speed", "rad/s"),
                           ("travel", "m"), ("contact_stiffness", "N/m^2"), ("perforation_force", "N"),
                           ("goal_depth", "m"), ("reward_length", "m")):
            if name != "travel" or self.travel is not None:
                positive(name, getattr(self, name), unit)
        if not isinstance(self.implicit_contact, bool):
            raise bad("implicit_contact", self.implicit_contact, "True or False")
        for name in ("friction", "contact_damping", "drag", "wrong_branch_penalty", "success_reward",
                     "perforation_penalty"):
            nonnegative(name, getattr(self, name))
        integer("max_steps", self.max_steps, 1)
        integer("kept_nodes", self.kept_nodes, 2)
        integer("checks_per_step", self.checks_per_step, 1)
        if self.kept_nodes > self.device.n_nodes:
            raise bad("kept_nodes", self.kept_nodes, f"at most the device's {self.device.n_nodes} nodes")
        if self.target is not None and not isinstance(self.target, str):
            raise bad("target", self.target, "a branch name of the vessel, or None to draw one per episode")
        g = np.asarray(self.gravity, dtype=float)
        if g.shape != (3,) or not np.all(np.isfinite(g)):
            raise bad("gravity", self.gravity, "a finite 3-vector in m/s^2")
        object.__setattr__(self, "gravity", tuple(float(c) for c in g))

    def kept(self) -> np.ndarray:
        """The observed nodes (k,) int64, hub to tip."""
        return np.unique(np.round(np.linspace(0, self.device.n_nodes - 1, self.kept_nodes)).astype(np.int64))
