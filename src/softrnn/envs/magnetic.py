"""The magnetic navigation environment (``softrnn/MagneticNavigate-v0``): the magnetic manipulator's rod
(``softrnn.magnetics.ManipulatorSpec``: PMC-770 rubber with two embedded magnets) inserted at its hub
into a bifurcation inside the six electromagnets, steered by the field they make
(docs/guide/envs.md).

Action (5,) in [-1, 1]: the hub's insertion and rotation rates (as ``NavigateEnv``'s) and the field
(x, y, z) at the coils' workspace centre, as fractions of ``max_field``; a field beyond
``max_field`` in magnitude is scaled back onto it. The coils' currents are the minimum-norm currents
of that field at the workspace centre (``currents_for_field``'s map), held over the step (zero-order
hold, as ``magnetics.stepper``); the field and its gradient at the magnets follow from the coils'
dipole model at every solver step (``rod.magnetic``). Observation: ``NavigateEnv``'s, with the
applied field (3, fractions of ``max_field``) at its end, or the image. Reward, success,
perforation and timeout: ``NavigateEnv``'s (``softrnn.envs.episodes``).

The vector environment steps all its rods in one call of the batched kernel, in parallel over the
rods (``envs._kernels.advance_rods``, as ``NavigateVectorEnv``): each rod has its own coil currents
and magnet buffers (``rod.kernels.magnet_rows``), the magnets and coils are shared
(docs/guide/envs.md, Throughput).
"""

import math
from dataclasses import dataclass, field

import numpy as np

from ..errors import bad, positive
from ..geometry.obstacles import Bifurcation
from ..magnetics.coils import unit_field_maps
from ..magnetics.currents import CurrentSchedule
from ..magnetics.manipulator import ManipulatorSpec, magnetic_load
from ..rod import RodShape, RodSpec, straight
from ..rod.kernels import StepInputs
from .config import NavigateConfig
from .episodes import Episodes
from .fluoro import point_at
from .navigate import NavigateEnv
from .rods import RodBatch
from .scripted import ScriptedNavigator
from .vector import NavigateVectorEnv

MAGNET_STIFFNESS = 10.0
"""The default rod's cap on its magnet segments' Young's modulus, times the rod's (the manipulator's
default is 100): the implicit integrator's automatic step resolves the stiffest segment's bending
modes, so the cap sets the solver step (3,492 steps per 0.1 s at 10, 11,042 at 100); the two 2 mm
segments then add under 1 % to the 50 mm rod's bending compliance."""


def _manipulator() -> ManipulatorSpec:
    """The default rod: the manipulator's, its magnet segments capped at ``MAGNET_STIFFNESS``."""
    return ManipulatorSpec(magnet_stiffness_factor=MAGNET_STIFFNESS)


@dataclass(frozen=True, kw_only=True)
class MagneticRod:
    """The magnetic manipulator's rod as a navigation device: its rod, magnets and coils are those of
    ``manipulator``; its base, contact, insertion, gravity and damping are the environment's.

    Attributes
    ----------
    manipulator : ManipulatorSpec
        the manipulator (default: 50 mm of PMC-770, 3 mm thick, N42 and N45 magnets at 25 and
        49 mm, magnetised along the rod, the six coils of ``bigmag_like``; its magnet segments
        capped at ``MAGNET_STIFFNESS`` times the rod's Young's modulus)
    """

    manipulator: ManipulatorSpec = field(default_factory=_manipulator)

    def __post_init__(self):
        if not isinstance(self.manipulator, ManipulatorSpec):
            raise bad("device.manipulator", type(self.manipulator).__name__, "a softrnn.magnetics.ManipulatorSpec")

    @property
    def n_nodes(self) -> int:
        """The rod's nodes."""
        return self.manipulator.n_nodes

    @property
    def radius(self) -> float:
        """The rod's radius [m]."""
        return 0.5 * self.manipulator.diameter

    @property
    def length(self) -> float:
        """The rod's length from the hub to the tip [m]."""
        return self.manipulator.length

    def spec(self) -> RodSpec:
        """The rod, its magnet segments stiff and heavy (``ManipulatorSpec.rod_spec``)."""
        return self.manipulator.rod_spec()

    def shape(self, origin, direction, bend) -> RodShape:
        """The straight stress-free rod from ``origin`` (3,) [m] along ``direction`` (3,), d1 along
        ``bend`` (3,)."""
        return straight(self.n_nodes, self.length, origin=origin, direction=direction, normal=bend)

    def tip_offset(self) -> float:
        """How far the tip stands off the rod's axis in the stress-free shape [m]: 0 (straight)."""
        return 0.0

    def field_map(self) -> np.ndarray:
        """The minimum-norm coil currents per tesla of field at the coils' workspace centre (n_c, 3) [A/T]."""
        return np.linalg.pinv(unit_field_maps(self.manipulator.coils, np.zeros(3))[0])


@dataclass(frozen=True, kw_only=True)
class MagneticNavigateConfig(NavigateConfig):
    """The magnetic navigation task: ``NavigateConfig``'s settings, defaults for the magnetic rod, and
    the field's bound.

    Attributes
    ----------
    device : MagneticRod
        the rod (its magnets and coils)
    max_field : float
        the field's magnitude at action norm 1 [T] (0.015: the magnetic demonstration's, 5 A in
        the coils); checked against the coils' current limit in every direction
    max_insertion_speed : float
        [m/s] (0.02: the demonstration's insertion, 17 mm/s on average)
    travel : float
        [m] (0.05: the tip then ends past the default vessel's goals, short of its branches' ends)
    max_steps : int
        (100: 10 s)
    contact_stiffness : float
        [N/m^2] (5e4: the rubber rod's weight sinks it 0.1 % of its radius into the wall, the
        magnets' loads up to about 10 % while the scripted controller steers; the solver step is set
        by the rod's bending modes, not by this)
    goal_depth : float
        [m] (0.012: 12 mm into a 30 mm branch)
    """

    device: MagneticRod = field(default_factory=MagneticRod)
    max_field: float = 0.015
    max_insertion_speed: float = 0.02
    travel: float = 0.05
    max_steps: int = 100
    contact_stiffness: float = 5e4
    goal_depth: float = 0.012

    def _check_device(self) -> None:
        if not isinstance(self.device, MagneticRod):
            raise bad("device", self.device, "a softrnn.envs.MagneticRod")

    def __post_init__(self):
        super().__post_init__()
        positive("max_field", self.max_field, "T")
        coils = self.device.manipulator.coils
        peak = float(np.max(np.linalg.norm(self.device.field_map(), axis=1)))
        if self.max_field * peak > coils.current_limit:
            raise bad("max_field", self.max_field, f"at most {coils.current_limit / peak:.4g} T: the coils' "
                                                   f"{coils.current_limit:g} A limit in the worst direction")


def magnetic_vessel() -> Bifurcation:
    """The magnetic environment's vessel: the magnetic demonstration's phantom (7 mm lumen, branches at
    +-20 degrees in the horizontal plane, left toward +y) with its junction at the coils' workspace
    centre (the origin), a 90 mm trunk along +x (the rod starts 20 mm before the junction) and 30 mm
    branches."""
    a = math.radians(20.0)

    def arm(side):
        return [[t * 0.03 * math.cos(a), side * t * 0.03 * math.sin(a), 0.0] for t in (0.5, 1.0)]
    return Bifurcation(trunk=[[-0.09, 0.0, 0.0], [0.0, 0.0, 0.0]], left=arm(1), right=arm(-1), radius=0.0035)


class MagneticRodBatch(RodBatch):
    """``RodBatch`` of the magnetic rod: each rod's coils driven by its own field.

    Attributes
    ----------
    field : (B, 3)
        each rod's field at the workspace centre [T], held over the last step
    currents : (B, n_c)
        the coils' currents that make it [A]
    magnet_buffers : dict of (B, ...) arrays
        each rod's magnet outputs (``StepInputs``' magnet_positions .. magnet_failed): rows 0 ..
        checks_per_step - 1 at the last step's contact checks, the last row the solver's scratch
    magnet_failed : (B,) int64
        each rod's magnet that came too close to a coil, -1: none
    """

    def __init__(self, config: MagneticNavigateConfig, track, n_rods: int):
        super().__init__(config, track, n_rods)
        device = config.device
        self._map = device.field_map()
        n_c = self._map.shape[0]
        load = magnetic_load(device.manipulator, CurrentSchedule(np.zeros(1), np.zeros((1, n_c))))
        arrays = load.kernel_arrays(np.zeros(1))
        self._magnets = {k: arrays[k] for k in ("magnet_node", "magnet_body", "source_positions", "source_moments")}
        self.magnet_buffers = {k: np.repeat(a[None], n_rods, axis=0)
                               for k, a in load.buffers(config.checks_per_step).items()}
        self._check_workspace(load)
        self.field = np.zeros((n_rods, 3))
        self.currents = np.zeros((n_rods, n_c))

    def _check_workspace(self, load) -> None:
        """A one-line error unless the magnets start inside the coils' workspace (where the field the
        action asks for is made)."""
        r = self._start.positions
        magnets = (1.0 - load.fractions[:, None]) * r[load.nodes] + load.fractions[:, None] * r[load.nodes + 1]
        reach = float(np.max(np.linalg.norm(magnets, axis=1)))
        limit = self.config.device.manipulator.coils.workspace_radius
        if reach > limit:
            raise bad("vessel", f"magnets starting {reach:.4g} m from the coils' centre",
                      f"a vessel whose entry puts the rod's magnets within the coils' workspace of radius {limit:g} m "
                      "around the origin (e.g. magnetic_vessel())")

    def reset(self, b: int) -> None:
        """Rod ``b`` back at its start, its coils off, its magnet buffers cleared."""
        super().reset(b)
        self.field[b] = 0.0
        self.currents[b] = 0.0
        for a in self.magnet_buffers.values():
            a[b] = 0
        self.magnet_buffers["magnet_failed"][b] = -1

    def step(self, rates: np.ndarray) -> None:
        """Advance every rod one step with (B, 5): the hub's rates [m/s, rad/s] and the field [T]
        (its magnitude capped at ``max_field``)."""
        b = np.asarray(rates[:, 2:5], dtype=float)
        size = np.linalg.norm(b, axis=1, keepdims=True)
        cap = self.config.max_field
        self.field = b * np.minimum(1.0, np.divide(cap, size, out=np.ones_like(size), where=size > cap))
        # row by row, each a fresh (1, 3) product: a BLAS product's rounding depends on its shape, and so
        # every rod's currents round as a single environment's, in a batch of any size
        self.currents = np.concatenate([self.field[b:b + 1].copy() @ self._map.T for b in range(len(self.field))])
        super().step(np.ascontiguousarray(rates[:, :2]))

    @property
    def magnet_failed(self) -> np.ndarray:
        """Each rod's magnet (B,) int64 that came too close to a coil (status ``MAGNET_TOO_CLOSE``;
        -1: none since its reset)."""
        return self.magnet_buffers["magnet_failed"][:, 0].copy()

    def _inputs(self, rates: np.ndarray) -> StepInputs:
        """``RodBatch._inputs`` with the magnets and coils, each rod's currents held over the step
        (B, K, n_c) and its own magnet buffers (``rod.kernels.magnet_rows``)."""
        currents = np.repeat(self.currents[:, None], self.substeps, axis=1)
        return super()._inputs(rates)._replace(**self._magnets, **self.magnet_buffers, source_currents=currents)


class MagneticEpisodes(Episodes):
    """``Episodes`` of the magnetic rod: the field in the action and the observation."""

    rod_batch = MagneticRodBatch
    actions = "insertion, rotation and field (x, y, z)"

    def __init__(self, config: MagneticNavigateConfig, vessel, n: int):
        if not isinstance(config, MagneticNavigateConfig):
            raise bad("config", type(config).__name__, "a softrnn.envs.MagneticNavigateConfig")
        super().__init__(config, magnetic_vessel() if vessel is None else vessel, n)
        self.scale = np.array([config.max_insertion_speed, config.max_rotation_speed] + 3 * [config.max_field])

    def step(self, actions: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """``Episodes.step``, with a success only where the tip is clear of the carina: nearer the
        target's centreline than any other branch's by the rod's radius (the straight, symmetric rod
        pushed without a field sinks into the carina's crease, as near one branch as the other)."""
        reward, terminated, truncated = super().step(actions)
        _, d = self.paths.progress(self.tip)
        rows = np.arange(len(d))
        mine = d[rows, self.target]
        d[rows, self.target] = np.inf
        blurred = self.outcome[:, 0] & ~(d.min(axis=1) - mine > self.config.device.radius)
        self.outcome[:, 0] &= ~blurred
        terminated = terminated & ~blurred
        return (reward - self.config.success_reward * blurred, terminated,
                ~terminated & (self.steps >= self.config.max_steps))

    def limits(self) -> str:
        """The largest rates and field, as the bounds' error says them."""
        return f"{super().limits()}, {self.config.max_field:g} T"

    @property
    def size(self) -> int:
        """The observation's length: 9 + J + 3 k + 3 (the field)."""
        return super().size + 3

    def observe(self) -> np.ndarray:
        """``Episodes.observe`` with the field (B, 3) as fractions of ``max_field`` at its end (not
        with images)."""
        obs = super().observe()
        if self.camera is not None:
            return obs
        return np.concatenate([obs, (self.rods.field / self.config.max_field).astype(np.float32)], axis=1)


class MagneticNavigateEnv(NavigateEnv):
    """The magnetic rod in a vessel, inserted at its hub and steered by the coils' field toward a
    target branch (``MagneticNavigateConfig``; vessel None: ``magnetic_vessel()``); otherwise as
    ``NavigateEnv``."""

    config_type = MagneticNavigateConfig
    episodes_type = MagneticEpisodes


class MagneticNavigateVectorEnv(NavigateVectorEnv):
    """``num_envs`` copies of ``MagneticNavigateEnv`` (as ``NavigateVectorEnv``: their rods stepped in
    one call of the batched kernel, each with its own field)."""

    config_type = MagneticNavigateConfig
    episodes_type = MagneticEpisodes


@dataclass(frozen=True, kw_only=True)
class MagneticNavigator(ScriptedNavigator):
    """The scripted controller of the magnetic environments: it inserts at full speed with the field
    across the trunk toward the target branch (as the magnetic demonstration), along that branch once
    the tip is in it, and pulls back out of a wrong branch; the hub is not turned. Observations (D,)
    or (B, D) -> actions (5,) or (B, 5)."""

    def __call__(self, observation) -> np.ndarray:
        """The actions for ``observation`` (D,) or (B, D) of the environment."""
        obs = np.asarray(observation, dtype=float)
        x = np.atleast_2d(obs)
        paths = self.episodes.paths
        tip, target = x[:, 0:3], np.argmax(x[:, 9:9 + len(paths.branches)], axis=1)
        axis, across = self._trunk(target)
        along = np.stack([_unit_or_zero(paths.lines[j][-1] - point_at(paths.lines[j], paths.arc[j], paths.fork[j]))
                          for j in target])
        _, branch = paths.standing(tip, target)
        inside = branch == target
        wrong = (branch >= 0) & ~inside
        direction = np.where(inside[:, None], along, across)
        action = np.concatenate([np.where(wrong, -1.0, 1.0)[:, None], np.zeros((len(x), 1)), direction], axis=1)
        return np.clip(action, -1.0, 1.0).astype(np.float32).reshape(obs.shape[:-1] + (5,))

    def _trunk(self, target: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """The trunk's axis (3,) and each target's direction (B, 3) across it, from its fork to its
        end, unit."""
        paths = self.episodes.paths
        axis = _unit_or_zero(paths.lines[0][1] - paths.lines[0][0])
        want = np.stack([paths.lines[j][-1] - paths.lines[j][np.searchsorted(paths.arc[j], paths.fork[j])]
                         for j in target])
        return axis, self._across(want, np.broadcast_to(axis, want.shape))


def _unit_or_zero(v: np.ndarray) -> np.ndarray:
    size = np.linalg.norm(v)
    return v / size if size > 0 else np.zeros(3)
