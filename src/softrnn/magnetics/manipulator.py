"""The magnetic manipulator in the dynamic simulator: a clamped PMC-770 rod with two embedded magnets,
driven by coil currents (Tariverdi et al. 2021, Fig. 9; defaults of magnetic.md §1.3).

The rod is the Lie-group Cosserat rod of ``softrnn.rod``, run by its ``Simulator`` with one magnetic
load (``magnetic_load``: ``softrnn.rod.magnetic.MagneticDipoles``), whose kernels recompute the magnet
wrenches from the magnets' current poses and the coil currents at every solver step.

Modelling choices (assumptions, with numbers for the defaults):

* Magnet segments: the nodes covering a magnet (its ends snapped to the nearest nodes) form a stiff
  segment. The true 41.4 GPa limits the explicit step to 2.5e-7 s (26 nodes); the default caps its
  Young's modulus at ``magnet_stiffness_factor`` = 100 times the rod's (250 MPa): a magnet segment
  then bends 1% as much as the same length of rod, the two 2 mm segments add 0.08% to the
  compliance of the 50 mm rod, and the step is 3.2e-6 s (about 13 times fewer steps). Over 0.1 s
  of random currents the capped and the true rod differ by 5 micrometres at most.
* Magnet mass: the covered nodes get the density that conserves the mass of rod material plus
  magnet over their lumped length (2698 kg/m^3 for the proximal, 3263 kg/m^3 for the distal
  magnet by default), so gravity and inertia see the magnets' 5.6e-5 kg each.
* Damping: light viscous drag on the rod (``DEFAULT_DAMPING``), about 5% of critical on the first
  bending mode (6.9 Hz); the rubber's real loss factor is not known.
* The magnets are point dipoles at their centres (uniform magnetisation, no induced magnetisation,
  no magnet-magnet coupling: ~0.1 mT at 25 mm, under 1% of the applied field, magnetic.md §1.3).
* Contact: with ``ManipulatorSpec.contact`` the rod moves among obstacles (e.g. inside a vessel or
  a ``Bifurcation``), with the contact loads of ``softrnn.rod.contact`` evaluated at every solver
  step beside the magnet loads; the explicit step then also respects the contact springs.
* Insertion: with ``ManipulatorSpec.advance`` (a ``BaseAdvance``) the base is a clamp that moves
  along its own axis (+x) by a smoothstep profile and turns about it by the same profile (held
  without a ``rotation``; a ``Clamp`` with a motion), as a hub inserts and rotates a device.
"""

import math
from dataclasses import dataclass, field, replace

import numpy as np

from ..errors import bad, finite, nonnegative, positive, vec3
from ..progress import Progress
from ..rod.boundary import Clamp
from ..rod.contact import Contact, node_parameters, step_limit
from ..rod.hub import axis_rotation
from ..rod.integrators import Explicit, Implicit, as_integrator
from ..rod.loads import smoothstep
from ..rod.magnetic import MagneticDipoles
from ..rod.magnetic import MagnetSamples as MagnetSamples
from ..rod.shapes import RodShape, straight
from ..rod.simulation import Damping, RunConfig, Setup, Simulator, Trajectory, check_run_size
from ..rod.spec import NodeOverride, RodSpec
from ..rod.stability import DEFAULT_SAFETY, omega_max, stable_step
from .coils import CoilLayout, bigmag_like
from .currents import CurrentSchedule as CurrentSchedule
from .currents import currents_for_field as currents_for_field
from .currents import random_currents as random_currents
from .magnets import Magnet, default_magnets

DEFAULT_DAMPING = Damping(translational=0.05, rotational=0.0)
"""Light viscous drag [N s/m^2] of the default manipulator: about 5% of critical on the first bending
mode (6.9 Hz; measured 2.1% at 0.02 N s/m^2); higher modes get less (the ratio falls as 1/omega)."""

DRIVE_BLOCK_STEPS = 65536
"""Solver steps per chunk of ``simulate_manipulator``'s run (``Simulator.run``'s chunk_samples,
rounded down to whole samples, at least one): a fraction of a second of stepping (6 samples of the
magnetic experiment), so that progress reports and Ctrl-C come between chunks. The results do not
depend on it."""

SETTLE_DAMPING = Damping(translational=1.0, rotational=0.0)
"""Heavy drag [N s/m^2] used only while settling before a run: about critical on the first mode, so
every mode decays at about 30/s or faster."""

# the base frame: tangent d3 = +x, d1 = +z (so d2 = -y), as the rod's straight() builds it
_AXIS = (1.0, 0.0, 0.0)
_NORMAL = (0.0, 0.0, 1.0)


@dataclass(frozen=True)
class BaseAdvance:
    """Insertion and rotation of the manipulator at its base, its hub: the base moves ``distance`` [m]
    along its own axis (+x) and turns ``rotation`` [rad] about it, starting at ``start`` [s] and
    reaching both ``ramp`` [s] later by a C2 smoothstep (``softrnn.rod.loads.smoothstep``).

    Attributes
    ----------
    distance : float
        how far the base advances [m], >= 0 (> 0 unless it only turns)
    start : float
        when the advance begins [s], >= 0 (the base is still before; also while settling)
    ramp : float
        how long the advance takes [s], > 0
    rotation : float
        how far the base turns about its axis [rad] (right-handed about +x; default 0: its
        rotation is held)
    """

    distance: float
    start: float = 0.0
    ramp: float = 1.0
    rotation: float = 0.0

    def __post_init__(self):
        object.__setattr__(self, "distance", nonnegative("advance.distance", self.distance, "m"))
        object.__setattr__(self, "start", nonnegative("advance.start", self.start, "s"))
        object.__setattr__(self, "ramp", positive("advance.ramp", self.ramp, "s"))
        object.__setattr__(self, "rotation", finite("advance.rotation", self.rotation, "rad"))
        if self.distance == 0 and self.rotation == 0:
            raise bad("advance.distance", self.distance, "a positive insertion in m, or a nonzero rotation in rad "
                                                         "(an advance that moves nothing is no advance: None)")

    def offset(self, t) -> np.ndarray:
        """The distance advanced (K,) [m] at times t (K,) [s]."""
        t = np.atleast_1d(np.asarray(t, dtype=float))
        return self.distance * smoothstep((t - self.start) / self.ramp)

    def angle(self, t) -> np.ndarray:
        """The angle turned about the axis (K,) [rad] at times t (K,) [s]."""
        t = np.atleast_1d(np.asarray(t, dtype=float))
        return self.rotation * smoothstep((t - self.start) / self.ramp)

    @property
    def end(self) -> float:
        """When the base stops, start + ramp [s]."""
        return self.start + self.ramp


@dataclass(frozen=True)
class _AdvancingBase:
    """The pose motion of an advancing base (``Clamp.motion``): position ``base`` + offset(t) along
    ``axis``, rotation ``rotation`` (3 rows of 3, a tuple so that equal motions compare equal) turned
    by angle(t) about the axis (held without a rotation); t (K,) -> (K, 3) [m], (K, 3, 3)."""

    base: tuple
    axis: tuple
    rotation: tuple
    advance: BaseAdvance

    def __call__(self, t):
        t = np.atleast_1d(np.asarray(t, dtype=float))
        pos = np.asarray(self.base) + self.advance.offset(t)[:, None] * np.asarray(self.axis)
        held = np.array(self.rotation, dtype=float)
        if self.advance.rotation == 0:
            return pos, np.broadcast_to(held, (t.size, 3, 3)).copy()
        return pos, axis_rotation(np.asarray(self.axis, dtype=float), self.advance.angle(t)) @ held

    def parameters(self) -> np.ndarray:
        """The motion's profile array (10,): base (3) [m], axis (3), distance [m], start, ramp [s],
        rotation [rad]."""
        a = self.advance
        return np.array([*self.base, *self.axis, a.distance, a.start, a.ramp, a.rotation], dtype=float)


@dataclass(frozen=True, kw_only=True)
class ManipulatorSpec:
    """The physical magnetic manipulator (magnetic.md §1.3; rod material of Tariverdi et al. 2021).

    Attributes
    ----------
    length, diameter : float
        free length L and circular section diameter D of the rod [m]
    youngs_modulus, poisson_ratio, density : float
        PMC-770 urethane rubber [Pa], [-], [kg/m^3]
    magnets : tuple of Magnet or None
        ``Magnet`` entries (None: N42 at L/2 and N45 at L - 1 mm, 2 mm cubes, axial;
        resolved here, so ``replace(spec, length=...)`` keeps them: pass magnets=None)
    coils : CoilLayout
        the electromagnets (``bigmag_like()`` by default)
    n_nodes : int
        rod nodes (26: 2 mm segments, one per default magnet)
    base : tuple or None
        clamped base position [m] (None: (-L/2, 0, 0)); the rod points along +x
    gravity : tuple
        gravitational acceleration (3,) [m/s^2]
    damping : Damping
        rod damping (``DEFAULT_DAMPING``)
    magnet_stiffness_factor : float or None
        cap on the magnet segments' Young's modulus as a multiple of the rod's
        (None: the magnets' own modulus, e.g. 41.4 GPa; see the module docstring)
    contact : softrnn.rod.Contact or None
        obstacles around the rod (e.g. a ``Vessel`` or ``Bifurcation`` it lies in), with the
        contact law of ``softrnn.rod.contact``; None: none (the rod moves freely)
    advance : BaseAdvance or None
        insertion: the base advances along +x (``BaseAdvance``); None: the base stays fixed
    """

    length: float = 0.05
    diameter: float = 3e-3
    youngs_modulus: float = 2.5e6
    poisson_ratio: float = 0.5
    density: float = 1000.0
    magnets: tuple | None = None
    coils: CoilLayout = field(default_factory=bigmag_like)
    n_nodes: int = 26
    base: tuple | None = None
    gravity: tuple = (0.0, 0.0, -9.81)
    damping: Damping = DEFAULT_DAMPING
    magnet_stiffness_factor: float | None = 100.0
    contact: Contact | None = None
    advance: BaseAdvance | None = None

    def __post_init__(self):
        for name in ("length", "diameter", "youngs_modulus", "density"):
            value = getattr(self, name)
            if isinstance(value, bool) or not isinstance(value, (int, float)) or not np.isfinite(value) or value <= 0:
                raise bad(name, value, "a positive finite number (SI units)")
        if self.magnet_stiffness_factor is not None and (
                isinstance(self.magnet_stiffness_factor, bool)
                or not isinstance(self.magnet_stiffness_factor, (int, float))
                or not np.isfinite(self.magnet_stiffness_factor) or self.magnet_stiffness_factor < 1):
            raise bad("magnet_stiffness_factor", self.magnet_stiffness_factor,
                      "a factor >= 1 times the rod's Young's modulus, or None for the magnets' own modulus")
        if not isinstance(self.coils, CoilLayout):
            raise bad("coils", type(self.coils).__name__, "a CoilLayout (see softrnn.magnetics.bigmag_like)")
        if not isinstance(self.damping, Damping):
            raise bad("damping", self.damping, "a softrnn.rod.Damping")
        if self.contact is not None and not isinstance(self.contact, Contact):
            raise bad("contact", type(self.contact).__name__, "a softrnn.rod.Contact, or None for no obstacles")
        if self.advance is not None and not isinstance(self.advance, BaseAdvance):
            raise bad("advance", self.advance, "a softrnn.magnetics.BaseAdvance, or None for a fixed base")
        try:
            magnets = default_magnets(self.length) if self.magnets is None else tuple(self.magnets)
        except TypeError:
            raise bad("magnets", self.magnets, "a tuple of Magnet entries, or None for the defaults") from None
        object.__setattr__(self, "magnets", magnets)
        base = (-0.5 * self.length, 0.0, 0.0) if self.base is None else self.base
        object.__setattr__(self, "base", vec3("base", base, "the clamped base position in m"))
        object.__setattr__(self, "gravity", vec3("gravity", self.gravity, "in m/s^2, e.g. (0, 0, -9.81)"))
        # RodSpec checks n_nodes, poisson_ratio and the radius/length ratio
        RodSpec(length=self.length, radius=0.5 * self.diameter, youngs_modulus=self.youngs_modulus,
                density=self.density, n_nodes=self.n_nodes, poisson_ratio=self.poisson_ratio)
        self._check_magnets()
        self._check_workspace()
        if self.contact is not None:
            self.setup()  # the rod's straight start inside the obstacles (rod.contact.check_initial)

    # ------------------------------------------------------------------ validation
    def _check_magnets(self) -> None:
        L, D = self.length, self.diameter
        ranges = []
        for j, m in enumerate(self.magnets):
            if not isinstance(m, Magnet):
                raise bad(f"magnets[{j}]", m, "a softrnn.magnetics.Magnet")
            half = 0.5 * m.length
            tol = 1e-9 * L
            if m.arc_length - half < -tol or m.arc_length + half > L + tol:
                raise bad(f"magnets[{j}].arc_length", m.arc_length,
                          f"a centre in [{half:.4g}, {L - half:.4g}] m so that the {m.length:.4g} m long magnet "
                          f"lies inside the {L:.4g} m rod")
            diag = math.hypot(m.size[0], m.size[1])
            if diag > D * (1 + 1e-9):
                raise bad(f"magnets[{j}].size", m.size,
                          f"a cross-section that fits inside the rod: its diagonal {diag * 1e3:.3g} mm exceeds "
                          f"the diameter {D * 1e3:.3g} mm")
            ranges.append(self.magnet_node_range(j))
        order = np.argsort([a for a, _ in ranges])
        for i0, i1 in zip(order[:-1], order[1:]):
            if ranges[i1][0] <= ranges[i0][1]:
                raise bad("magnets", f"magnets[{i0}] and magnets[{i1}] on nodes {ranges[i0]} and {ranges[i1]}",
                          "magnets that do not share rod nodes (move them apart or use more n_nodes)")

    def _check_workspace(self) -> None:
        s = np.linspace(0.0, self.length, self.n_nodes)
        advanced = [] if self.advance is None else [("advance.distance", self.advance.distance)]
        for name, shift in [("base", 0.0)] + advanced:  # the straight rod at the start and fully advanced
            pts = np.asarray(self.base) + (s[:, None] + shift) * np.asarray(_AXIS)
            reach = float(np.max(np.linalg.norm(pts, axis=1)))
            if reach > self.coils.workspace_radius:
                raise bad(name, self.base if name == "base" else shift,
                          f"a rod inside the coils' workspace: it reaches {reach:.4g} m from the centre"
                          f"{'' if name == 'base' else ' when fully advanced'}, beyond "
                          f"workspace_radius = {self.coils.workspace_radius:.4g} m")

    # ------------------------------------------------------------------ derived quantities
    @property
    def segment_length(self) -> float:
        """l = L / (n_nodes - 1) [m]."""
        return self.length / (self.n_nodes - 1)

    def magnet_node_range(self, j: int) -> tuple[int, int]:
        """Nodes (first, last) covered by magnet j: its ends snapped to the nearest nodes."""
        m = self.magnets[j]
        l = self.segment_length
        first = int(math.floor((m.arc_length - 0.5 * m.length) / l + 0.5))
        last = int(math.floor((m.arc_length + 0.5 * m.length) / l + 0.5))
        return max(first, 0), min(last, self.n_nodes - 1)

    def magnet_anchor(self, j: int) -> tuple[int, float]:
        """(a, t): magnet j's centre lies a fraction t of the way from node a to node a + 1."""
        x = self.magnets[j].arc_length / self.segment_length
        a = min(int(math.floor(x)), self.n_nodes - 2)
        return a, float(x - a)

    def rod_spec(self) -> RodSpec:
        """The rod with one ``NodeOverride`` per magnet (stiff segment, mass-conserving density)."""
        l = self.segment_length
        area = math.pi * (0.5 * self.diameter) ** 2
        overrides = []
        for j, m in enumerate(self.magnets):
            first, last = self.magnet_node_range(j)
            weights = np.ones(self.n_nodes)
            weights[0] = weights[-1] = 0.5
            lumped = area * l * float(np.sum(weights[first:last + 1]))
            rho = self.density + (m.density - self.density) * m.volume / lumped
            E = m.youngs_modulus if self.magnet_stiffness_factor is None else \
                min(m.youngs_modulus, self.magnet_stiffness_factor * self.youngs_modulus)
            overrides.append(NodeOverride(first=first, last=last, youngs_modulus=E,
                                          poisson_ratio=m.poisson_ratio, density=rho))
        return RodSpec(length=self.length, radius=0.5 * self.diameter, youngs_modulus=self.youngs_modulus,
                       density=self.density, n_nodes=self.n_nodes, poisson_ratio=self.poisson_ratio,
                       overrides=tuple(overrides))

    def reference_shape(self) -> RodShape:
        """The straight, stress-free rod from ``base`` along +x (d1 = +z)."""
        return straight(self.n_nodes, self.length, origin=self.base, direction=_AXIS, normal=_NORMAL)

    def setup(self) -> Setup:
        """The rod problem without magnetic loads (base clamped, or with ``advance`` a clamp that
        follows the insertion; gravity, damping, the obstacles of ``contact``): a plain
        ``softrnn.rod.Simulator`` on it gives the zero-current motion."""
        reference = self.reference_shape()
        clamp = Clamp(0) if self.advance is None else Clamp(0, motion=self.base_motion(reference))
        return Setup(rod=self.rod_spec(), reference=reference, boundary=(clamp,),
                     damping=self.damping, gravity=self.gravity, contact=self.contact)

    def base_motion(self, reference: RodShape | None = None) -> "_AdvancingBase | None":
        """The advancing base's pose motion (``Clamp.motion``: t (K,) -> positions (K, 3) [m],
        rotations (K, 3, 3), the rotation of ``reference`` at node 0, default the straight rod's),
        or None for a fixed base."""
        if self.advance is None:
            return None
        reference = self.reference_shape() if reference is None else reference
        rotation = tuple(tuple(float(x) for x in row) for row in reference.rotations[0])
        return _AdvancingBase(base=self.base, axis=_AXIS, rotation=rotation, advance=self.advance)

    def stable_step(self, safety: float = DEFAULT_SAFETY) -> float:
        """Largest accepted solver step h [s]; with ``contact``, the contact springs and dampers
        add to the fastest node's frequency (``softrnn.rod.contact.step_limit``)."""
        lumped = self.rod_spec().lumped()
        h = stable_step(lumped, self.segment_length, self.damping.kelvin_voigt, safety)
        if self.contact is None:
            return h
        nodes = node_parameters(self.contact, self.rod_spec(), self.gravity)
        omega = omega_max(lumped, self.segment_length)
        return min(h, safety * step_limit(nodes, lumped["mass"], omega))

    def scaled(self, *, stiffness: float = 1.0, remanence: float = 1.0, damping: float = 1.0,
               density: float = 1.0) -> "ManipulatorSpec":
        """A perturbed copy (e.g. the 'real robot' a few % off the nominal model): the rod's Young's
        modulus, every magnet's remanence, every damping coefficient and the rod's density multiplied
        by the given factors."""
        factors = {"stiffness": stiffness, "remanence": remanence, "damping": damping, "density": density}
        for name, f in factors.items():
            if isinstance(f, bool) or not isinstance(f, (int, float)) or not np.isfinite(f) or f <= 0:
                raise bad(name, f, "a positive scale factor (1 = nominal)")
        d = self.damping
        return replace(self, youngs_modulus=self.youngs_modulus * stiffness, density=self.density * density,
                       magnets=tuple(m.scaled(remanence) for m in self.magnets),
                       damping=Damping(translational=d.translational * damping, rotational=d.rotational * damping,
                                       kelvin_voigt=d.kelvin_voigt * damping))


# --------------------------------------------------------------------------- run configuration and result
@dataclass(frozen=True, kw_only=True)
class ManipulatorRun:
    """How to run: saved interval dt [s], n_samples (the first at t = 0), solver substeps per
    interval (None: the fewest that are stable), stability safety factor, and an optional settling
    phase of ``settle`` [s] before t = 0 with the currents held at their t = 0 value and
    ``settle_damping`` (heavy drag), so that a run can start from the sagged equilibrium; the
    ``integrator`` of both (``softrnn.rod.integrators``: ``Explicit()``, the default, or
    ``Implicit()``; the names work too)."""

    dt: float
    n_samples: int
    substeps: int | None = None
    safety: float = DEFAULT_SAFETY
    settle: float = 0.0
    settle_damping: Damping = SETTLE_DAMPING
    integrator: Explicit | Implicit = Explicit()

    def __post_init__(self):
        if isinstance(self.dt, bool) or not isinstance(self.dt, (int, float)) or not np.isfinite(self.dt) \
                or self.dt <= 0:
            raise bad("dt", self.dt, "a positive saved interval in s")
        if isinstance(self.n_samples, bool) or not isinstance(self.n_samples, (int, np.integer)) or self.n_samples < 1:
            raise bad("n_samples", self.n_samples, "an integer >= 1")
        if self.substeps is not None and (isinstance(self.substeps, bool)
                                          or not isinstance(self.substeps, (int, np.integer)) or self.substeps < 1):
            raise bad("substeps", self.substeps, "an integer >= 1, or None to choose automatically")
        if not (isinstance(self.safety, (int, float)) and 0 < self.safety <= 1):
            raise bad("safety", self.safety, "a factor in (0, 1] applied to 2/omega_max")
        if isinstance(self.settle, bool) or not isinstance(self.settle, (int, float)) or not np.isfinite(self.settle) \
                or self.settle < 0:
            raise bad("settle", self.settle, "a settling time >= 0 in s")
        if not isinstance(self.settle_damping, Damping):
            raise bad("settle_damping", self.settle_damping, "a softrnn.rod.Damping")
        object.__setattr__(self, "integrator", as_integrator(self.integrator))

    @property
    def duration(self) -> float:
        """Time of the last sample, (n_samples - 1) dt [s]."""
        return (self.n_samples - 1) * self.dt


@dataclass(frozen=True, eq=False)
class ManipulatorTrajectory:
    """A run of the magnetic manipulator. S samples, n nodes, M magnets, n_c coils; world frame.

    Attributes
    ----------
    rod : Trajectory
        the rod's ``Trajectory`` (time (S,), positions (S, n, 3), quaternions (S, n, 4),
        velocities, applied forces/torques including the magnetic ones, reactions, energy; with
        ``ManipulatorSpec.contact``, contact_forces and contact_torques (S, n, 3) [N], [N m])
    currents : (S, n_c) [A]
        the coil currents
    magnet_positions : (S, M, 3) [m]
        magnet centres
    magnet_rotations : (S, M, 3, 3)
        magnet rotations, body -> world
    magnet_moments : (S, M, 3) [A m^2]
        magnet moments
    fields : (S, M, 3) [T]
        field at the magnets
    gradients : (S, M, 3, 3) [T/m]
        field gradient at the magnets
    wrenches : (S, M, 6) [N, N m]
        force G mu and torque mu x B on each magnet
    step : float
        sample interval [s]
    substeps : int
        solver substeps per sample
    wall_time : float
        wall time [s] of the recorded part, settling excluded
    """

    rod: Trajectory
    currents: np.ndarray
    magnet_positions: np.ndarray
    magnet_rotations: np.ndarray
    magnet_moments: np.ndarray
    fields: np.ndarray
    gradients: np.ndarray
    wrenches: np.ndarray
    step: float
    substeps: int
    wall_time: float

    @property
    def time(self) -> np.ndarray:
        """rod.time (S,) [s]."""
        return self.rod.time

    @property
    def positions(self) -> np.ndarray:
        """rod.positions (S, n, 3) [m]."""
        return self.rod.positions

    @property
    def quaternions(self) -> np.ndarray:
        """rod.quaternions (S, n, 4), unit, scalar first, body -> world."""
        return self.rod.quaternions


# --------------------------------------------------------------------------- simulation
def magnetic_load(spec: ManipulatorSpec, schedule: CurrentSchedule) -> MagneticDipoles:
    """The magnets of ``spec`` in the field of its coils driven by ``schedule``, as a rod load
    (``softrnn.rod.magnetic.MagneticDipoles``: magnet j at ``spec.magnet_anchor(j)``)."""
    anchors = [spec.magnet_anchor(j) for j in range(len(spec.magnets))]
    return MagneticDipoles(nodes=np.array([a for a, _ in anchors], dtype=np.int64),
                           fractions=np.array([t for _, t in anchors], dtype=float),
                           moments=np.array([m.moment_body for m in spec.magnets], dtype=float).reshape(-1, 3),
                           source_positions=spec.coils.positions, source_moments=spec.coils.moments_per_ampere,
                           times=schedule.times, currents=schedule.values)


def manipulator_simulator(spec: ManipulatorSpec, schedule: CurrentSchedule, h: float, *, settle: float = 0.0,
                          settle_damping: Damping = SETTLE_DAMPING, integrator="explicit") -> Simulator:
    """A ``softrnn.rod.Simulator`` of the manipulator (``spec.setup()`` with its ``magnetic_load``),
    started at rest with the solver step ``h`` [s] and, with ``settle`` > 0 [s], settled for
    ceil(settle / h) steps before t = 0 with ``settle_damping`` (a simulator of the setup with
    that damping, whose state it continues; the currents and the base as the schedule and the
    advance give them at t < 0; stepped by ``integrator``)."""
    setup = replace(spec.setup(), loads=(magnetic_load(spec, schedule),))
    sim = Simulator(setup)
    if settle > 0:
        n_settle = int(math.ceil(settle / h))
        settler = Simulator(replace(setup, damping=settle_damping))
        settler.state.time = -n_settle * h
        settler.advance(n_settle, h, integrator)
        sim.continue_from(settler)
    return sim


def _schedule(spec: ManipulatorSpec, run: ManipulatorRun, currents) -> CurrentSchedule:
    """A validated CurrentSchedule from a schedule or sampled currents (n_samples, n_c) at the save times."""
    if not isinstance(currents, CurrentSchedule):
        try:
            values = np.asarray(currents, dtype=float)
        except (TypeError, ValueError):
            raise bad("currents", type(currents).__name__,
                      f"a CurrentSchedule or an array (n_samples, {spec.coils.n_coils}) in A") from None
        if values.ndim != 2 or values.shape[0] != run.n_samples:
            raise bad("currents.shape", values.shape,
                      f"(n_samples, n_coils) = ({run.n_samples}, {spec.coils.n_coils}): one row per saved sample, "
                      f"or a CurrentSchedule")
        currents = CurrentSchedule(run.dt * np.arange(run.n_samples), values)
    if currents.n_coils != spec.coils.n_coils:
        raise bad("currents.shape", currents.values.shape, f"(T, {spec.coils.n_coils}): one column per coil")
    spec.coils.check_currents(currents.values)
    if currents.times[-1] < run.duration - 1e-9 * max(run.duration, 1.0) and currents.times.size > 1:
        raise bad("currents.times", f"ending at {currents.times[-1]:.6g} s",
                  f"a schedule that covers the run to t = {run.duration:.6g} s")
    return currents


def resolve_substeps(spec: ManipulatorSpec, run: ManipulatorRun) -> int:
    """Solver steps per saved interval, stable for the run's damping and the settling damping;
    refuses an unstable explicit choice (the implicit integrator's as ``Simulator.resolve_substeps``)."""
    if not isinstance(run.integrator, Explicit):
        config = RunConfig(dt=run.dt, n_samples=2, substeps=run.substeps, safety=run.safety,
                           integrator=run.integrator)
        return Simulator(spec.setup()).resolve_substeps(config)
    limit = spec.stable_step(run.safety)
    if run.settle > 0:
        limit = min(limit, replace(spec, damping=run.settle_damping).stable_step(run.safety))
    if run.substeps is None:
        return max(1, math.ceil(run.dt / limit * (1 - 1e-12)))
    if run.dt / run.substeps > limit:
        raise bad("substeps", run.substeps, f"at least {math.ceil(run.dt / limit)}: dt/substeps = "
                  f"{run.dt / run.substeps:.3g} s exceeds the stable step {limit:.3g} s (or None for automatic)")
    return int(run.substeps)


def check_manipulator_run(spec: ManipulatorSpec, run: ManipulatorRun, extra_bytes: int = 0) -> int:
    """Refuse a run too large for this machine (``rod.simulation.check_run_size``: every node of every
    sample is held, with the magnets' and coils' outputs) before anything is allocated; ``extra_bytes``:
    what the caller holds besides (e.g. the current schedule). Returns the substeps."""
    substeps = resolve_substeps(spec, run)
    h = run.dt / substeps
    settle_steps = int(math.ceil(run.settle / h)) if run.settle > 0 else 0
    per_sample = 8 * (spec.coils.n_coils + 30 * len(spec.magnets))   # currents, p, R, B, G, W
    if spec.contact is not None:                                       # the contact loads, 6 per node
        per_sample += 8 * 6 * spec.n_nodes
    check_run_size(n_samples=run.n_samples, dt=run.dt, substeps=substeps, n_saved=spec.n_nodes,
                   held_samples=run.n_samples, extra_bytes=run.n_samples * per_sample + extra_bytes,
                   extra_steps=1 + settle_steps, streamable=False, auto_substeps=run.substeps is None,
                   integrator=run.integrator)
    return substeps


def simulate_manipulator(spec: ManipulatorSpec, currents, run: ManipulatorRun,
                         progress: Progress | None = None) -> ManipulatorTrajectory:
    """Simulate the manipulator (``manipulator_simulator``'s run) from rest, driven by ``currents``.

    Parameters
    ----------
    spec : ManipulatorSpec
        The manipulator.
    currents : CurrentSchedule or (run.n_samples, n_coils) array
        A schedule covering [0, run.duration], or currents [A] at the save times (linear between).
    run : ManipulatorRun
        How to run.
    progress : softrnn.progress.Progress or None
        Called as ``progress(done, run.n_samples)`` with the samples recorded so far: 0 at the
        start, then after each chunk of about ``DRIVE_BLOCK_STEPS`` solver steps.

    Returns
    -------
    ManipulatorTrajectory
        The recorded samples: node poses, magnet orientations and the currents applied.
    """
    if not isinstance(spec, ManipulatorSpec):
        raise bad("spec", type(spec).__name__, "a ManipulatorSpec")
    if not isinstance(run, ManipulatorRun):
        raise bad("run", type(run).__name__, "a ManipulatorRun")
    substeps = check_manipulator_run(spec, run)
    schedule = _schedule(spec, run, currents)
    h = run.dt / substeps
    sim = manipulator_simulator(spec, schedule, h, settle=run.settle, settle_damping=run.settle_damping,
                                integrator=run.integrator)
    if progress is not None:
        progress(0, run.n_samples)
    config = RunConfig(dt=run.dt, n_samples=run.n_samples, substeps=substeps, safety=run.safety,
                       integrator=run.integrator)
    traj = sim.run(config, progress, chunk_samples=max(1, DRIVE_BLOCK_STEPS // substeps))
    mag = traj.magnets
    mu = np.einsum("smij,mj->smi", mag.rotations, sim.inputs.magnetic.moments)
    return ManipulatorTrajectory(rod=traj, currents=mag.currents, magnet_positions=mag.positions,
                                 magnet_rotations=mag.rotations, magnet_moments=mu, fields=mag.fields,
                                 gradients=mag.gradients, wrenches=mag.wrenches, step=h, substeps=substeps,
                                 wall_time=traj.wall_time)
