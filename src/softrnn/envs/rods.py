"""The physics of the navigation environments: B copies of one device in one vessel, each driven at
its hub (``softrnn.rod.hub.Hub.commanded``, its insertion within the travel), stepped together by
one call of the batched implicit kernel (``envs._kernels.advance_rods``).

Each rod is the ``Setup`` of ``RodBatch.setup`` (the device clamped at node 0 to its hub, the
vessel's contact, drag and gravity), started as ``softrnn.rod.Simulator`` starts it (at rest, the
implicit half kick) and stepped as ``Simulator.advance`` with the implicit integrator steps it:
one rod of the batch follows the same trajectory as that simulator (tests/envs check it).
"""

import time

import numpy as np

from ..errors import bad
from ..geometry.contact import Contact
from ..rod import Damping, RunConfig, Setup, Simulator
from ..rod.hub import Hub
from ..rod.integrators import Implicit
from ..rod.kernels import OK, StateArrays, StepInputs
from ..rod.state import empty_samples
from ..rod.threads import over_rods
from ._kernels import advance_rods, stacked_work
from .config import NavigateConfig
from .track import Track

START_DEPTH = 0.02
"""How far inside the vessel's entry the hub starts [m]."""


def _unit(v: np.ndarray) -> np.ndarray:
    return v / np.linalg.norm(v)


def start_pose(config: NavigateConfig, track: Track) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The hub's start (3,) [m], the insertion axis (3,) and the tip's bend direction (3,): the
    device lies straight along the entry's centreline on the lumen's floor (toward gravity; any
    side without gravity), its tip bent up, away from the floor."""
    line = np.asarray(track.centreline(track.branches[0]), dtype=float)
    axis = _unit(line[1] - line[0])
    g = np.asarray(config.gravity, dtype=float)
    down = g - (g @ axis) * axis
    if np.linalg.norm(down) < 1e-9 * max(1.0, np.linalg.norm(g)):
        down = np.cross(axis, [1.0, 0.0, 0.0] if abs(axis[0]) < 0.9 else [0.0, 1.0, 0.0])
    down = _unit(down)
    room = track.entry_radius - config.device.radius
    if config.device.tip_offset() + config.device.radius > track.entry_radius + room:
        raise bad("device.tip_angle", config.device.tip_angle,
                  f"a tip that fits the entry's lumen of radius {track.entry_radius:.4g} m (its bend stands "
                  f"{config.device.tip_offset():.4g} m off the wire): a smaller angle or a shorter tip")
    return line[0] + START_DEPTH * axis + room * down, axis, -down


def hub_travel(config: NavigateConfig, track: Track) -> float:
    """How far the hub may advance [m]: ``config.travel``, or for None until the tip of the device,
    straight from its start (``START_DEPTH`` along the entry), would reach the end of the track's
    longest branch (its centreline's length)."""
    if config.travel is not None:
        return config.travel
    longest = max(float(np.sum(np.linalg.norm(np.diff(np.asarray(track.centreline(b), dtype=float), axis=0), axis=1)))
                  for b in track.branches)
    room = longest - START_DEPTH - config.device.length
    if room <= 0.0:
        raise bad("travel", None, f"a travel in m: the device ({config.device.length:g} m) reaches past the vessel's "
                                  f"longest branch ({longest:.3g} m from the entry) from its start")
    return room


class RodBatch:
    """B rods of ``config.device`` in ``track``'s vessel, stepped together.

    Attributes
    ----------
    travel : float
        the hub's travel [m] (``hub_travel``)
    hubs : list of Hub
        each rod's hub (``Hub.commanded``: insertion and rotation rates, the insertion in [0, travel])
    setups : list of Setup
        each rod's setup (its ``Clamp`` follows its hub)
    h : float
        the solver step [s]
    substeps : int
        solver steps per environment step
    state : StateArrays
        the rods' states, (B, ...) each
    time : (B,)
        each rod's time since its reset [s]
    contact_force : (B,)
        the largest contact force on a node [N] at the checks of the last step
    failed : (B,) bool
        the rods whose last step failed (diverged, a magnet too close to a coil): to be reset
    status : (B,) int64
        each rod's kernel status of its last step (OK, or the failure's code)
    kernel_seconds : float
        wall time spent in the kernel so far [s] (what a benchmark splits the physics from the rest by)
    """

    def __init__(self, config: NavigateConfig, track: Track, n_rods: int):
        self.config = config
        self.track = track
        origin, axis, bend = start_pose(config, track)
        shape = config.device.shape(origin, axis, bend)
        contact = Contact(obstacles=tuple(track.obstacles), friction=config.friction,
                          stiffness=config.contact_stiffness, damping=config.contact_damping,
                          implicit=config.implicit_contact)
        self.travel = hub_travel(config, track)
        self.hubs = [Hub.commanded(origin, axis, shape.rotations[0], travel=self.travel) for _ in range(n_rods)]
        self.setups = [Setup(rod=config.device.spec(), reference=shape, boundary=(hub.clamp(0),),
                             damping=Damping(translational=config.drag), gravity=config.gravity, contact=contact)
                       for hub in self.hubs]
        sim = Simulator(self.setups[0])
        self._integrator = Implicit()
        checks = config.checks_per_step
        substeps = self._integrator.resolve_substeps(sim, RunConfig(dt=config.step_time, n_samples=2))
        self.substeps = -(-substeps // checks) * checks
        self.h = config.step_time / self.substeps
        sim.start(self.h, self._integrator)
        self.rod = sim.elastic_rod
        self._tau = self.setups[0].damping.kelvin_voigt
        self._contact = sim.inputs.contact
        self._start = sim.state.copy()
        self._start_work = [a.copy() for a in sim.implicit_work()]
        n, B = config.device.n_nodes, n_rods
        self.state = StateArrays(*(np.repeat(a[None], B, axis=0) for a in self._start.arrays()))
        self._segment = np.repeat(self._start.contact_segment[None], B, axis=0)
        self._samples = empty_samples(np.arange(n, dtype=np.int64), checks, n, lead=(B,))
        self._contact_samples = np.zeros((B, checks, n, 6))
        self._applied = np.zeros((B, n, 6))
        self._work = stacked_work(B, n, len(self._start_work[-1]) > 0)
        for a, start in zip(self._work, self._start_work):
            a[:] = start
        self._status = np.zeros((B, 2), dtype=np.int64)
        self._steps = np.zeros(B, dtype=np.int64)
        self.contact_force = np.zeros(B)
        self.failed = np.zeros(B, dtype=bool)
        self.kernel_seconds = 0.0

    @property
    def time(self) -> np.ndarray:
        """Each rod's time since its reset (B,) [s]."""
        return self._steps * self.h

    @property
    def status(self) -> np.ndarray:
        """Each rod's kernel status of its last step (B,) int64: ``rod.kernels.OK`` (0), or the code of
        its failure (``rod.status.KernelStatus``)."""
        return self._status[:, 0].copy()

    def reset(self, b: int) -> None:
        """Put rod ``b`` back at its start, at rest, its hub still at insertion 0, angle 0."""
        self.hubs[b].reset_commands()
        for a, start in zip(self.state, self._start.arrays()):
            a[b] = start
        self._segment[b] = self._start.contact_segment
        for a, start in zip(self._work, self._start_work):
            a[b] = start
        self._applied[b] = 0.0
        self._steps[b] = 0
        self.contact_force[b] = 0.0
        self.failed[b] = False

    def _inputs(self, rates: np.ndarray) -> StepInputs:
        """The step inputs of every rod for the next ``substeps`` steps with hub rates (B, 2)
        [m/s, rad/s]; the hubs take the rates from each rod's time on."""
        B, K = len(self.hubs), self.substeps
        presc_r = np.empty((B, K + 1, 1, 3))
        presc_R = np.empty((B, K + 1, 1, 3, 3))
        offsets = self.h * np.arange(K + 1)
        for b, hub in enumerate(self.hubs):
            t = self._steps[b] * self.h
            hub.command(t, insertion_rate=rates[b, 0], rotation_rate=rates[b, 1])
            presc_r[b, :, 0], presc_R[b, :, 0] = hub(t + offsets)
        empty = np.zeros((B, K, 0))
        return StepInputs(ext_idx=np.zeros(0, dtype=np.int64), ext_w=np.zeros((B, K, 0, 12)),
                          pd_idx=np.zeros(0, dtype=np.int64), pd_target=np.zeros((B, K, 0, 3)),
                          pd_gain=np.zeros((0, 2)), presc_idx=np.zeros(1, dtype=np.int64), presc_r=presc_r,
                          presc_R=presc_R, tendon_tension=empty, tendon_displacement=empty, **self._contact,
                          contact_segment=self._segment, contact_samples=self._contact_samples,
                          contact_applied=self._applied)

    def step(self, rates: np.ndarray) -> None:
        """Advance every rod one environment step with hub rates (B, 2) [m/s, rad/s]; a rod whose
        step fails is marked in ``failed`` (its state is then meaningless until ``reset``)."""
        stride = self.substeps // self.config.checks_per_step
        self._contact_samples[:] = 0.0
        inputs = self._inputs(rates)
        start = time.perf_counter()
        self._advance(inputs, stride)
        self.kernel_seconds += time.perf_counter() - start
        self._steps += self.substeps
        self.failed = self._status[:, 0] != OK
        force = np.linalg.norm(self._contact_samples[..., :3], axis=-1).max(axis=(1, 2))
        self.contact_force = np.where(self.failed | ~np.isfinite(force), np.inf, force)

    def _advance(self, inputs: StepInputs, stride: int) -> None:
        """Every rod ``substeps`` solver steps with ``inputs`` in one call of the batched kernel, the
        contact sampled every ``stride`` steps."""
        over_rods(advance_rods, len(self.state.positions), self.rod, self.state, inputs, self._samples, self.h, 1,
                  self.substeps, stride, 1, self._work, self._integrator.beta, self._integrator.theta, self._tau,
                  self._status)

    def gaps(self, b: int) -> np.ndarray:
        """The gaps (n,) [m] of rod ``b``'s surface to the vessel's wall (the least over its
        obstacles; negative: in the wall)."""
        radius = self.setups[0].rod.node_properties()["radius"]
        return self.setups[0].contact.gaps(self.state.positions[b], radius).min(axis=1)
