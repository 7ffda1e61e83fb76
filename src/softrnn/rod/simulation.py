"""Simulation driver: a physical ``Setup`` plus a ``RunConfig`` -> a ``Trajectory``.

Python evaluates the time-dependent inputs (loads, PD targets, prescribed motions) chunk by chunk
into arrays (``rod.inputs``); ``kernels.advance`` runs the steps of a chunk in one numba call on the
rod's lumped arrays, built once (``rod.lumped``). The saved interval
``dt`` is split into ``substeps`` solver steps h = dt / substeps below the stability limit.
"""

import os
import time
from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np

from ..errors import SoftrnnInputError, bad, nonnegative
from ..files import size_text as _size
from ..progress import Progress
from . import implicit
from .boundary import Clamp, Pin
from .contact import Contact, check_initial, step_limit
from .hub import hub_of, with_hub
from .inputs import SetupInputs
from .integrators import BY_NAME, Explicit, Implicit, as_integrator
from .kernels import MIN_DIPOLE_DISTANCE, PINNED, Samples
from .loads import NodalLoad, PDTracking
from .lumped import lumped_rod
from .magnetic import MagneticDipoles, magnet_samples, start_wrench
from .shapes import RodShape
from .spec import RodSpec
from .stability import DEFAULT_SAFETY, omega_max, stable_step
from .state import RodState, empty_samples, initial_state
from .status import KernelStatus, raise_for_status
from .tendons import Tendon, check_offset
from .trajectory import RunStats as RunStats
from .trajectory import Trajectory as Trajectory
from .trajectory import concatenate_chunks, to_trajectory

INTEGRATORS = tuple(BY_NAME)
"""The names of the solver integrators a ``RunConfig`` may take (``rod.integrators``)."""

_CHUNK_STEPS = 65536
_CHUNK_SAMPLES = 4096

# ------------------------------------------------------------------ run size
MAX_SOLVER_STEPS = 10**10          # rod-steps of one run (about a day of stepping for a 100-node rod)
MAX_ARRAY_BYTES = 8 * 2**30        # arrays a run may hold at once (less on a machine with under 16 GiB)
SAMPLE_VALUES = 7 * 3 + 4          # float64 values per saved node and sample: r, v, w, f, t, rf, rt, q


def array_limit() -> int:
    """Bytes of arrays a run may hold: ``MAX_ARRAY_BYTES`` or half the machine's memory, the smaller."""
    try:
        ram = os.sysconf("SC_PAGE_SIZE") * os.sysconf("SC_PHYS_PAGES")
    except (AttributeError, OSError, ValueError):
        return MAX_ARRAY_BYTES
    return min(MAX_ARRAY_BYTES, ram // 2) if ram > 0 else MAX_ARRAY_BYTES


def check_run_size(*, n_samples: int, dt: float, substeps: int, n_saved: int, held_samples: int,
                   chunk_steps: int = 0, step_bytes: int = 0, batch: int = 1, extra_bytes: int = 0,
                   extra_steps: int = 0, streamed: bool = False, streamable: bool = True,
                   auto_substeps: bool = True, integrator: Explicit | Implicit | None = None) -> None:
    """Refuse, before anything is allocated or stepped, a run too large for this machine.

    Every simulation path calls it (``Simulator.run``, ``simulate_batch``, the magnetic
    ``simulate_manipulator``) with what it really holds at once: ``held_samples`` saved samples
    of ``n_saved`` nodes per rod (all of them without a sink, a chunk when streamed), the inputs of
    one chunk of ``chunk_steps`` solver steps at ``step_bytes`` each (per rod of a ``batch``), and
    ``extra_bytes`` (in all). ``streamable``: the caller could stream the samples (a sink) instead;
    ``auto_substeps``: the substeps were chosen automatically; ``integrator``: the run's, where the
    caller can switch it (an explicit run with too many steps is pointed to the implicit one), or None
    (batches, the magnetic manipulator). Raises SoftrnnInputError saying how
    large the run would be and what to change when the arrays exceed ``array_limit()`` or the
    solver steps ``MAX_SOLVER_STEPS``.
    """
    held = batch * (held_samples * (n_saved * SAMPLE_VALUES + 4) * 8 + chunk_steps * step_bytes) + extra_bytes
    steps = batch * (max(n_samples - 1, 0) * substeps + extra_steps)
    limit = array_limit()
    if held <= limit and steps <= MAX_SOLVER_STEPS:
        return
    over = []
    if held > limit:
        over.append(f"hold {_size(held)} of arrays in memory (limit {_size(limit)})")
    if steps > MAX_SOLVER_STEPS:
        over.append(f"take {steps:.3g} solver steps (limit {MAX_SOLVER_STEPS:.0e})")
    fixes = [f"fewer samples or a smaller dt (now {(n_samples - 1) * dt:.4g} s simulated at a solver step of "
             f"{dt / substeps:.3g} s{'' if auto_substeps else ', or fewer substeps'})"]
    samples_heavy = batch * held_samples * (n_saved * SAMPLE_VALUES + 4) * 8 > limit / 2
    if held > limit and samples_heavy and n_saved > 1:
        fixes.append("save fewer nodes (save_nodes)")
    if held > limit and samples_heavy and streamable and not streamed:
        fixes.append("write to a file, which streams the samples (softrnn simulate -o FILE.h5, or a sink)")
    if steps > MAX_SOLVER_STEPS and integrator is not None and integrator.step_advice:
        fixes.append(integrator.step_advice)
    if batch > 1:
        fixes.append("fewer rods per batch")
    raise SoftrnnInputError(
        f"the run n_samples={n_samples}, dt={dt:g} s is too large for this machine ({substeps:.3g} solver steps per "
        f"sample, {n_saved} saved node{'s' if n_saved != 1 else ''}"
        f"{f', {batch} rods' if batch > 1 else ''}): it would {' and '.join(over)}; use {'; or '.join(fixes)}")


@dataclass(frozen=True, kw_only=True)
class Damping:
    """Dissipation (docs/lgvi.md §2.6).

    Attributes
    ----------
    translational : float
        viscous drag per length c_t [N s/m^2] (force per node = -c_t w_a l v)
    rotational : float
        viscous drag per length c_r [N m s/m] (torque per node = -c_r w_a l omega)
    kelvin_voigt : float
        internal strain-rate damping, retardation time tau_d [s] (D = tau_d C)
    """

    translational: float = 0.0
    rotational: float = 0.0
    kelvin_voigt: float = 0.0

    def __post_init__(self):
        for name in ("translational", "rotational", "kelvin_voigt"):
            nonnegative(f"damping.{name}", getattr(self, name))


@dataclass(frozen=True, kw_only=True, eq=False)
class Setup:
    """The physical problem: rod, stress-free reference shape, initial shape (defaults to the
    reference), boundary conditions (``Clamp``, ``Pin``; at most one ``Clamp`` held by a
    ``softrnn.rod.hub.Hub``: insertion and rotation at the hub), loads, damping, gravity and ``tendons``
    (``softrnn.rod.tendons.Tendon`` entries with distinct names, routed from node 0).

    ``gravity`` is a constant (3,) [m/s^2], or a time function t (K,) [s] -> (K, 3) [m/s^2] (e.g.
    ``Scheduled(Constant((0, 0, -9.81)), ramp=0.5)``), applied as the world force m_a g(t) on every
    node with the nodal loads: ``Trajectory.forces`` then include it, and the gravitational term
    of ``Trajectory.energy`` (which counts a constant gravity only) is 0.

    ``contact`` (a ``softrnn.rod.contact.Contact``, default None: no obstacles) adds rigid obstacles
    with friction (docs/lgvi.md §2.11); the initial shape must not start deeper in one than the rod's
    radius."""

    rod: RodSpec
    reference: RodShape
    initial: RodShape | None = None
    boundary: tuple = ()
    loads: tuple = ()
    damping: Damping = field(default_factory=Damping)
    gravity: tuple | object = (0.0, 0.0, 0.0)
    tendons: tuple = ()
    contact: Contact | None = None

    def __post_init__(self):
        n = self.rod.n_nodes
        initial = self.reference if self.initial is None else self.initial
        object.__setattr__(self, "initial", initial)
        for name, shape in (("reference", self.reference), ("initial", initial)):
            if not isinstance(shape, RodShape):
                raise bad(name, type(shape).__name__, "a RodShape (see softrnn.rod.shapes)")
            if shape.n_nodes != n:
                raise bad(f"{name}.n_nodes", shape.n_nodes, f"{n} nodes to match rod.n_nodes")
        seg = np.linalg.norm(np.diff(self.reference.positions, axis=0), axis=1)
        l = self.rod.segment_length
        if np.max(np.abs(seg / l - 1.0)) > 0.05:
            raise bad("reference", f"segment lengths {seg.min():.4g}..{seg.max():.4g} m",
                      f"node spacing within 5% of length/(n_nodes-1) = {l:.4g} m (resample the shape)")
        if callable(self.gravity):
            g = np.asarray(self.gravity(np.zeros(1)), dtype=float)
            if g.shape != (1, 3) or not np.all(np.isfinite(g)):
                raise bad("gravity", self.gravity, "a time function t (K,) [s] -> (K, 3) of finite values in "
                                                   f"m/s^2 (at t = 0 it gave shape {g.shape})")
        else:
            g = np.asarray(self.gravity, dtype=float)
            if g.shape != (3,) or not np.all(np.isfinite(g)):
                raise bad("gravity", self.gravity, "a finite 3-vector in m/s^2, e.g. (0, 0, -9.81), or a time "
                                                   "function t (K,) -> (K, 3) in m/s^2")
            object.__setattr__(self, "gravity", tuple(g))
        object.__setattr__(self, "boundary", tuple(self.boundary))
        object.__setattr__(self, "loads", tuple(self.loads))
        seen = set()
        for bc in self.boundary:
            if not isinstance(bc, (Clamp, Pin)):
                raise bad("boundary", bc, "Clamp or Pin entries")
            a = self.node_index(bc.node, "boundary node")
            if a in seen:
                raise bad("boundary node", bc.node, "each node at most once in the boundary conditions")
            seen.add(a)
        hub_of(self)  # at most one hub (softrnn.rod.hub)
        for load in self.loads:
            if isinstance(load, MagneticDipoles):
                self._check_magnetic(load)
                continue
            if not isinstance(load, (NodalLoad, PDTracking)):
                raise bad("loads", load, "NodalLoad, PDTracking or MagneticDipoles entries")
            self.node_index(load.node, "load node")
        self._check_tendons()
        if self.contact is not None:
            if not isinstance(self.contact, Contact):
                raise bad("contact", self.contact, "a softrnn.rod.contact.Contact, or None for no obstacles")
            check_initial(self.contact, self.initial.positions, self.rod.node_properties()["radius"])

    def _check_magnetic(self, load: MagneticDipoles) -> None:
        """A magnetic load: the only one of the setup, its magnets on segments of the rod."""
        if sum(isinstance(other, MagneticDipoles) for other in self.loads) > 1:
            raise bad("loads", "several MagneticDipoles", "at most one (put every magnet and source in one)")
        if load.n_magnets and load.nodes.max() > self.rod.n_nodes - 2:
            raise bad("magnetic.nodes", load.nodes.tolist(), f"segment start nodes in [0, {self.rod.n_nodes - 2}]")

    def _check_tendons(self) -> None:
        """Tendons: ``Tendon`` entries, distinct names, terminations on the rod, offsets inside
        the cross-sections they pass."""
        object.__setattr__(self, "tendons", tuple(self.tendons))
        names = set()
        radii = self.rod.node_properties()["radius"]
        for td in self.tendons:
            if not isinstance(td, Tendon):
                raise bad("tendons", td, "Tendon entries (softrnn.rod.tendons.Tendon)")
            if td.name in names:
                raise bad("tendon name", td.name, "a name not used by another tendon of the setup")
            names.add(td.name)
        channels = set()
        for td in self.tendons:
            for channel in (td.channel, td.displacement_channel) if td.displacement_controlled else (td.channel,):
                if channel in channels:
                    raise bad("tendon name", td.name, f"a name whose actuation channel {channel!r} is not also "
                                                      "another tendon's (rename one)")
                channels.add(channel)
        for td in self.tendons:
            check_offset(td, radii, td.end_index(self.rod.n_nodes, self.rod.segment_length))

    def node_index(self, node: int, what: str = "node") -> int:
        """Normalise a node index (negative counts from the end), raising a clear error."""
        n = self.rod.n_nodes
        if isinstance(node, bool) or not isinstance(node, (int, np.integer)) or not -n <= node < n:
            raise bad(what, node, f"an integer in [-{n}, {n - 1}] for a rod of {n} nodes")
        return int(node) % n


@dataclass(frozen=True, kw_only=True)
class RunConfig:
    """How to run: saved interval ``dt`` [s], ``n_samples`` saved states (the first at the start),
    solver ``substeps`` per saved interval (None: chosen automatically), the nodes to save
    (None: all), the stability ``safety`` factor and the ``integrator`` (``rod.integrators``):

    * ``Explicit()`` (default): the LGVI step of ``rod.kernels``; substeps None gives the fewest
      stable ones, and an unstable choice is refused;
    * ``Implicit(beta=..., theta=...)``: the stiff-stable step of ``rod.implicit`` (elastic and
      Kelvin-Voigt forces implicit): any step is stable for the rod's own stiffness, and substeps
      None resolves its fourth bending mode (``rod.implicit.accuracy_step``).

    The names ``"explicit"`` and ``"implicit"`` are accepted and turned into those (with defaults).
    """

    dt: float
    n_samples: int
    substeps: int | None = None
    save_nodes: tuple | None = None
    safety: float = DEFAULT_SAFETY
    integrator: Explicit | Implicit = Explicit()

    def __post_init__(self):
        if not isinstance(self.dt, (int, float)) or not np.isfinite(self.dt) or self.dt <= 0:
            raise bad("dt", self.dt, "a positive saved interval in s")
        if isinstance(self.n_samples, bool) or not isinstance(self.n_samples, (int, np.integer)) or self.n_samples < 1:
            raise bad("n_samples", self.n_samples, "an integer >= 1")
        if self.substeps is not None and (
                isinstance(self.substeps, bool) or not isinstance(self.substeps, (int, np.integer))
                or self.substeps < 1):
            raise bad("substeps", self.substeps, "an integer >= 1, or None to choose automatically")
        if not (0 < self.safety <= 1):
            raise bad("safety", self.safety, "a factor in (0, 1] applied to 2/omega_max")
        if self.save_nodes is not None:
            object.__setattr__(self, "save_nodes", tuple(int(a) for a in self.save_nodes))
        object.__setattr__(self, "integrator", as_integrator(self.integrator))


def _from_rod(name: str, doc: str) -> property:
    """A read-only property giving the field ``name`` of the simulator's ``LumpedRod``."""
    return property(lambda self: getattr(self.rod, name), doc=doc)


class Simulator:
    """Steps a ``Setup`` forward. ``run`` continues from the current state each time it is called,
    so a control loop can alternate runs with changes of its own loads.

    Attributes
    ----------
    setup : Setup
        the setup it steps
    rod : LumpedRod
        the lumped arrays (``rod.lumped.lumped_rod``), shared with the kernels
    inputs : SetupInputs
        the loads and prescribed motions, evaluated chunk by chunk
    state : RodState
        the current state
    steps_done : int
        solver steps taken so far
    """

    def __init__(self, setup: Setup):
        self.setup = setup
        self.rod = with_hub(lumped_rod(setup), setup)  # a driven hub's node kind, mass and inertia
        self.inputs = SetupInputs(setup)
        self.state = initial_state(setup, self.rod, self.inputs)
        self.steps_done = 0
        self._started = False
        self._integrator = Explicit()
        self._work = None
        self._elastic = None

    seg_length = _from_rod("length", "Segment length l [m].")
    C1 = _from_rod("C1", "Shear and stretch stiffness (n - 1, 3) [N].")
    C2 = _from_rod("C2", "Bending and twist stiffness (n - 1, 3) [N m^2].")
    K0 = _from_rod("K0", "Stress-free curvature and twist (n - 1, 3) [1/m].")
    G0 = _from_rod("G0", "Stress-free shear and stretch (n - 1, 3) [-].")
    mass = _from_rod("mass", "Node masses (n,) [kg].")
    inertia = _from_rod("inertia", "Node inertias (n, 3) [kg m^2], body frame.")
    kind = _from_rod("kind", "Node kinds (n,) int64: kernels.FREE, CLAMPED, PINNED or a driven hub's HUB_*.")

    def stable_step(self, safety: float = DEFAULT_SAFETY) -> float:
        """Largest accepted solver step h [s] for this setup; with contact, the contact springs and
        dampers add to the fastest node's frequency (``rod.contact.step_limit``)."""
        h = stable_step(self.rod._asdict(), self.rod.length, self.setup.damping.kelvin_voigt, safety)
        if self.inputs.contact is None:
            return h
        omega = omega_max(self.rod._asdict(), self.rod.length)
        return min(h, safety * step_limit(self.inputs.contact["contact_node"], self.rod.mass, omega))

    def step_input_bytes(self) -> int:
        """Bytes of per-step inputs a chunk holds (``SetupInputs.step_bytes``)."""
        return self.inputs.step_bytes()

    def check_size(self, config: RunConfig, *, streamed: bool, extra_bytes_per_sample: int = 0) -> int:
        """Refuse a run too large for this machine (``check_run_size``) before anything is
        allocated; ``streamed``: the samples go to a sink chunk by chunk. Returns the substeps."""
        substeps = self.resolve_substeps(config)
        S = config.n_samples
        per_chunk = max(1, min(_CHUNK_SAMPLES, _CHUNK_STEPS // substeps))
        n_saved = self.setup.rod.n_nodes if config.save_nodes is None else len(config.save_nodes)
        if self.inputs.contact is not None and not streamed:  # contact_forces and contact_torques
            extra_bytes_per_sample += 6 * 8 * n_saved
        check_run_size(n_samples=S, dt=config.dt, substeps=substeps, n_saved=n_saved,
                       held_samples=min(S, per_chunk) if streamed else S, chunk_steps=per_chunk * substeps,
                       step_bytes=self.inputs.step_bytes(), extra_bytes=S * extra_bytes_per_sample,
                       streamed=streamed, auto_substeps=config.substeps is None, integrator=config.integrator)
        return substeps

    def resolve_substeps(self, config: RunConfig) -> int:
        """Solver steps per saved interval, as ``config.integrator`` chooses them (an unstable
        explicit choice is refused; ``rod.integrators``)."""
        return config.integrator.resolve_substeps(self, config)

    # ------------------------------------------------------------------ run
    def run(self, config: RunConfig, progress: Progress | None = None,
            sink: Callable[["Trajectory"], None] | None = None, *,
            chunk_samples: int | None = None) -> "Trajectory | RunStats":
        """Advance ``(n_samples - 1) * substeps`` steps from the current state; the first sample is
        the current time. Samples are produced in chunks of at most ``_CHUNK_SAMPLES`` (or
        ``chunk_samples``; the results do not depend on it): without a ``sink`` they are collected
        and returned as one ``Trajectory``; with one, each chunk goes to ``sink(chunk)`` (bounded
        memory, e.g. straight to a file) and ``RunStats`` is returned.
        ``progress(samples_done, n_samples)`` is called after every chunk. A run too large for this
        machine is refused first (``check_run_size``)."""
        substeps = self.check_size(config, streamed=sink is not None)
        h = config.dt / substeps
        self.start(h, config.integrator)
        nodes = save_nodes(self.setup, config)
        slot = save_slots(self.setup.rod.n_nodes, nodes)
        S = config.n_samples
        t0 = self.state.time
        k_start = self.steps_done
        chunks = []
        # compile (or load from the numba cache) outside the timed region: one step on a copy
        self._advance(self.state.copy(), t0, h, 0, 1, substeps, 0, empty_samples(slot, 1, nodes.size))
        start = time.perf_counter()
        per_chunk = max(1, min(_CHUNK_SAMPLES, _CHUNK_STEPS // substeps))
        if chunk_samples is not None:
            per_chunk = max(1, int(chunk_samples))
        j0 = 0
        while j0 < S:
            j1 = min(j0 + per_chunk, S - 1) if j0 < S - 1 else S
            chunk = self._chunk(t0, h, substeps, j0, j1, S, slot, nodes, config.dt)
            if j0 < S - 1:
                self.steps_done = k_start + j1 * substeps
                self.state.time = t0 + j1 * substeps * h
            if sink is None:
                chunks.append(chunk)
            else:
                sink(chunk)
            if progress is not None:
                progress(j1, S)
            j0 = j1
        stats = RunStats(n_samples=S, step=h, substeps=substeps, wall_time=time.perf_counter() - start,
                         n_nodes=self.setup.rod.n_nodes)
        return stats if sink is not None else concatenate_chunks(chunks, stats)

    def _chunk(self, t0: float, h: float, substeps: int, j0: int, j1: int, S: int, slot: np.ndarray,
               nodes: np.ndarray, dt: float) -> "Trajectory":
        """Samples j0 .. j1 - 1 of a run from t0 [s] (the state advanced to sample j1, except for the
        run's last sample, whose mid-step velocity needs one more step, taken on a copy)."""
        out = empty_samples(slot, j1 - j0, nodes.size)
        tensions = np.zeros((j1 - j0, len(self.setup.tendons))) if self.inputs.displaced else None
        contact = np.zeros((j1 - j0, nodes.size, 6)) if self.inputs.contact is not None else None
        magnetic = self.inputs.magnetic
        magnets = None if magnetic is None else dict(magnetic.buffers(j1 - j0),
                                                     currents=np.zeros((j1 - j0, magnetic.n_sources)))
        last = j0 >= S - 1
        self._advance(self.state.copy() if last else self.state, t0, h, j0 * substeps,
                      1 if last else (j1 - j0) * substeps, substeps, j0, out, tensions, contact, magnets)
        record = None if magnets is None else magnet_samples(magnets.pop("currents"), magnets)
        return to_trajectory(out, t0 + dt * np.arange(j0, j1), nodes, h, substeps, tensions, contact, record)

    def start(self, h: float, integrator: Explicit | Implicit | str = "explicit") -> None:
        """Use ``integrator`` from now on; a simulator not yet started starts its state at rest with
        the step ``h`` [s] (the integrator's half kick, as the first ``run`` or ``advance`` does)."""
        self._integrator = as_integrator(integrator)
        if isinstance(self._integrator, Implicit) and self.rod.kind.max(initial=0) > PINNED:
            raise bad("integrator", "implicit", "the explicit integrator for a setup with a hub driven by a force or "
                                                "a torque (softrnn.rod.hub)")
        if not self._started:
            self._half_kick(h)
            self._started = True

    def continue_from(self, other: "Simulator") -> None:
        """Take over the state of ``other`` (a simulator of a setup with the same rod, e.g. one that
        settled it with heavier damping), as if this one had stepped it."""
        self.state, self.steps_done, self._started = other.state, other.steps_done, other._started

    def advance(self, n_steps: int, h: float, integrator: Explicit | Implicit | str = "explicit") -> None:
        """Step the current state ``n_steps`` solver steps of ``h`` [s] without saving samples (e.g. a
        settling phase); from a fresh simulator, the state starts at rest as ``run`` starts it."""
        self.start(h, integrator)
        t0 = self.state.time
        none = save_slots(self.setup.rod.n_nodes, np.zeros(0, dtype=np.int64))
        done = 0
        while done < n_steps:
            k = min(_CHUNK_STEPS, n_steps - done)
            magnets = None if self.inputs.magnetic is None else dict(self.inputs.magnetic.buffers(1),
                                                                      currents=np.zeros((1, 0)))
            self._advance(self.state, t0, h, done, k, n_steps + 1, 0, empty_samples(none, 1, 0), None, None,
                          magnets)
            done += k
        self.steps_done += n_steps
        self.state.time = t0 + n_steps * h

    def implicit_work(self) -> "implicit.ImplicitWork":
        """The implicit step's scratch arrays, built on first use (``rod.integrators.Implicit``)."""
        if self._work is None:
            contact = self.setup.contact
            self._work = implicit.work_arrays(self.setup.rod.n_nodes, contact is not None and contact.implicit)
            self._elastic = self.rod._replace(kv_on=False)
        return self._work

    @property
    def elastic_rod(self):
        """The lumped rod with the explicit Kelvin-Voigt term off, for the implicit step (which takes
        it with the retardation time of ``setup.damping``)."""
        if self._elastic is None:
            self.implicit_work()
        return self._elastic

    def _half_kick(self, h: float) -> None:
        """Start the staggered velocities of a state at rest (the integrator's half kick); a magnet
        too close to a source at the start is refused (``rod.magnetic.start_wrench``)."""
        inputs = self.inputs.at(np.array([self.state.time]), h)
        if self.inputs.contact is not None:
            inputs = self.inputs.with_contact(inputs, self.state.contact_segment, np.zeros((0, 0, 6)))
        if self.inputs.magnetic is not None:
            start_wrench(self.state.rotations, self.state.positions, inputs)
        self._integrator.half_kick(self, inputs, h)

    def _advance(self, st: RodState, t0: float, h: float, k0: int, n_steps: int, stride: int, s0: int,
                 out: Samples, tensions: np.ndarray | None = None, contact: np.ndarray | None = None,
                 magnets: dict | None = None) -> None:
        """Steps k0 .. k0 + n_steps - 1 into ``out``; ``tensions`` (rows of out, m) [N], if given,
        receives the tendon tensions applied at the saved steps, ``contact`` (rows of out, saved
        nodes, 6), with contact, the contact force [N] and torque [N m] (a scratch one if None), and
        ``magnets``, with a magnetic load, its output buffers (``MagneticDipoles.buffers`` with
        ``currents`` (rows of out, n_c) [A]; scratch ones if None)."""
        t = t0 + (k0 + np.arange(n_steps)) * h
        inputs = self.inputs.at(t, h)
        if self.inputs.contact is not None:
            if contact is None:
                contact = np.zeros(out.positions.shape[:2] + (6,))
            inputs = self.inputs.with_contact(inputs, st.contact_segment, contact)
        if self.inputs.magnetic is not None:
            if magnets is None:
                magnets = dict(self.inputs.magnetic.buffers(len(out.energy)), currents=np.zeros((len(out.energy), 0)))
            inputs = inputs._replace(**{name: a for name, a in magnets.items() if name != "currents"})
        code, step = self._integrator.advance(self, st, inputs, out, h, k0, n_steps, stride, s0)
        context = {} if code != KernelStatus.MAGNET_TOO_CLOSE else dict(
            magnet=int(inputs.magnet_failed[0]), min_distance=MIN_DIPOLE_DISTANCE, more_fixes=("lower the currents",))
        raise_for_status(code, step=step, t0=t0, h=h, **context)
        k = k0 + np.arange(n_steps)
        saved = k % stride == 0
        if tensions is not None:
            tensions[k[saved] // stride - s0] = inputs.tendon_tension[saved]
        if magnets is not None and magnets["currents"].shape[1]:
            magnets["currents"][k[saved] // stride - s0] = inputs.source_currents[saved]


def save_nodes(setup: Setup, config: RunConfig) -> np.ndarray:
    """The saved nodes (s,) int64 of a run: ``config.save_nodes`` normalised, or every node."""
    if config.save_nodes is None:
        return np.arange(setup.rod.n_nodes)
    return np.array([setup.node_index(a, "save_nodes") for a in config.save_nodes], dtype=np.int64)


def save_slots(n_nodes: int, nodes: np.ndarray) -> np.ndarray:
    """Column of each of the n nodes in the outputs (n,) int64: slot[nodes[j]] = j, -1 if not saved."""
    slot = np.full(n_nodes, -1, dtype=np.int64)
    slot[nodes] = np.arange(nodes.size)
    return slot


def simulate(setup: Setup, config: RunConfig,
             progress: Progress | None = None) -> Trajectory:
    """Simulate ``setup`` from its initial shape at rest and return the saved trajectory."""
    return Simulator(setup).run(config, progress)
