"""Tendons routed along the rod (Rucker & Webster 2011, "Statics and Dynamics of Continuum Robots
With General Tendon Routing and External Loading", IEEE T-RO 27(6)): the configuration
(``Tendon``), the tension profiles, and the NumPy reference of the loads the kernel applies.

Routing. A tendon runs through the cross-sections at the body-frame offset
rho(s) = Rz(phi(s)) (ox, oy, 0) from the centreline [m] (components along d1, d2), from the base
(s = 0) to its termination; ``straight`` routing keeps phi = 0, ``helical`` routing turns the
offset about d3 by phi(s) = 2 pi s / pitch (s the arc length of the stress-free rod, ``pitch`` the
signed length of one turn: positive turns right-handed about d3). The tendon is frictionless, so
its tension tau [N] is the same along it; it can only pull (tau >= 0).

Continuum model (Rucker & Webster). Where the tendon runs, it loads the rod with the distributed
force and moment of its curving path, and at its termination with the point force -tau t and the
moment rho x (-tau t) (t the tendon's unit tangent). Integrated from a section to the tip, these
loads are exactly the tendon's tension carried through the section: the rod's internal force and
moment are n = N - tau t and m = M - tau rho x t (world frame), where N, M are the resultants of
the external loads alone. The tendon is thus an active stress of the rod's constitutive law, with
t the unit vector of v + u x rho + rho' (v, u the rod's strains, rho' = d rho / ds): the rod's
elastic force and moment balance the external resultant plus the pull of the tendon.

Discrete model (the dynamic rod). The same active stress, as the exact derivative of a discrete
tendon length: the tension does the work of V = tau sum_{a < e} l |Gamma_a + K_a x rho_a + rho'_a|
(e the termination node, Gamma_a, K_a the segment strains of ``rod.discrete``, rho_a and rho'_a at
the segment's middle): the continuum tendon length with the midpoint rule. Its gradient adds
tau t_a to the segment's force resultant N_a and tau rho_a x t_a to its moment M_a (in
``rod.kernels._segment``), before they are turned into node forces and torques like the elastic
ones; the tension computed from the current configuration at every step. This is exact for the
discrete rod: the loads are the gradient of V (the tests check them against finite differences),
and a straight tendon on a straight free rod gives every segment the curvature K = tau |rho| / (E I)
exactly (M = E I K balances tau rho x t with no force left over). The distributed loads and the
termination load of Rucker & Webster are implicit: a node between two routed segments receives
the difference of their tendon terms (the distributed load), the termination node the last one
(the point load), and the base node 0 the first one, taken back by the actuator rigidly attached
to the base (a clamped base absorbs it). The tendon loads are internal to the rod, so a
``Trajectory``'s ``forces`` and ``torques`` (external loads) do not include them.

Displacement control. A tendon driven by a position-controlled servo gives its pulled-in length
q(t) [m] (``displacement``, positive: pulled in at the servo) instead of its tension, through the
series stiffness k [N/m] of servo and cable (``stiffness``). With l_0 the tendon's path length in
the stress-free reference configuration and l its length in the current one (the discrete length
above in the dynamic rod, the integral of |v + u x rho + rho'| ds up to the termination in the
static solver), the rod bending toward the tendon shortens its path by l_0 - l and the rest of the
pull-in stretches the spring: tau = k max(0, q - (l_0 - l)) (a slack tendon cannot push). The
dynamic kernel computes this tension from the configuration at the start of every step and then
applies it exactly as a prescribed tension (the gradient of V with tau frozen, which is the
gradient of the spring energy k max(0, q - l_0 + l)^2 / 2: undamped, rod energy plus spring energy
is conserved at constant q). ``Trajectory.tendon_tensions`` holds the tensions applied at the saved
samples; the static solver finds them with the equilibrium (``StaticSolution.tendon_tensions``).
A straight tendon at the offset r on a straight, weightless, free rod, terminated at the arc
length L_e, gives the constant curvature kappa = tau r / (E I) with
tau = k q / (1 + k L_e (r^2 / (E I) + 1 / (E A))) in both models (the path shortens by
L_e (r kappa + tau / (E A)); without extension, kappa -> q / (r L_e) as k -> infinity).

The static solver (``softrnn.statics``) integrates the continuum model: see ``softrnn.statics.kernels``.
"""

import math
import re
from dataclasses import dataclass

import numpy as np

from ..errors import SoftrnnInputError, bad, is_finite_number, is_int, nonnegative
from .discrete import segment_strains
from .loads import smoothstep

ROUTINGS = ("straight", "helical")
_NAME = re.compile(r"^[a-z][a-z0-9_]{0,49}$")


@dataclass(frozen=True)
class Scalar:
    """A scalar tension profile t (K,) [s] -> (K,) [N] (or displacement profile [m]) from a vector time function of
    ``softrnn.rod.loads`` (``Constant``, ``Sinusoid``, ``Sampled``, ``Window``, a path ...): its
    ``component`` (0, 1 or 2), times a smoothstep blend from 0 over ``ramp`` [s] (a gentle start
    from the unloaded rod; 0: none)."""

    function: object
    component: int = 0
    ramp: float = 0.0

    def __post_init__(self):
        if not callable(self.function):
            raise bad("Scalar.function", self.function, "a time function t (K,) -> (K, 3)")
        if not is_int(self.component) or not 0 <= self.component <= 2:
            raise bad("Scalar.component", self.component, "0, 1 or 2")
        nonnegative("Scalar.ramp", self.ramp, "s")

    def __call__(self, t):
        t = np.asarray(t, dtype=float)
        value = np.asarray(self.function(t), dtype=float)[:, self.component]
        return value * smoothstep(t / self.ramp) if self.ramp > 0 else value


@dataclass(frozen=True, kw_only=True)
class Tendon:
    """A tendon routed along the rod and pulled with a tension, or pulled in by a displacement
    through a series stiffness (a position-controlled servo).

    Parameters
    ----------
    name : str
        lower-case letters, digits and ``_``, starting with a letter (the actuation channel
        ``tendon_<name>`` of a dataset)
    offset : (2,)
        (ox, oy): offset from the centreline at the base along d1, d2 [m]; at most the section
        radius from it
    tension : float or callable
        a constant tension >= 0 [N], or a profile t (K,) [s] -> (K,) [N] (e.g.
        ``Scalar(Sinusoid(...))``); values below zero are clipped to 0 when the profile is evaluated
        (a slack tendon cannot push). Default 0 N; not with ``displacement``
    routing : str
        "straight" (constant offset) or "helical" (the offset turns about d3)
    pitch : float
        helical routing only: the signed arc length of one turn [m] (positive: right-handed about
        d3)
    end_node : int
        the node where the tendon terminates (negative counts from the end; default: the last node)
    end_s : float
        the termination as an arc length [m] instead (the nearest node of a dynamic rod; exact in
        the static solver)
    displacement : float or callable
        instead of ``tension``: the length pulled in at the servo [m] (positive: pulled in;
        negative: paid out), a constant or a profile t (K,) [s] -> (K,) [m]; the tension is then k
        max(0, q - (l_0 - l)) (module docstring)
    stiffness : float
        with ``displacement`` (required): the series stiffness k of servo and cable [N/m], finite
        and > 0
    """

    name: str
    offset: tuple
    tension: object = None
    routing: str = "straight"
    pitch: float | None = None
    end_node: int | None = None
    end_s: float | None = None
    displacement: object = None
    stiffness: float | None = None

    def __post_init__(self):
        if not isinstance(self.name, str) or not _NAME.match(self.name):
            raise bad("tendon.name", self.name, "lower-case letters, digits or '_', starting with a letter "
                                                "(at most 50 characters), e.g. 'left'")
        try:
            items = [float(x) for x in self.offset] if all(is_finite_number(x) for x in self.offset) else []
        except TypeError:
            items = []
        if len(items) != 2:
            raise bad(f"tendon {self.name!r} offset", self.offset, "two finite numbers (ox, oy) in m: the "
                                                                   "offset from the centreline along d1, d2")
        object.__setattr__(self, "offset", tuple(items))
        if self.routing not in ROUTINGS:
            raise bad(f"tendon {self.name!r} routing", self.routing, "'straight' or 'helical'")
        if self.routing == "helical":
            if not is_finite_number(self.pitch) or self.pitch == 0:
                raise bad(f"tendon {self.name!r} pitch", self.pitch,
                          "a finite, nonzero length of one turn in m for helical routing")
        elif self.pitch is not None:
            raise bad(f"tendon {self.name!r} pitch", self.pitch, "no pitch for straight routing (or routing='helical')")
        if self.end_node is not None and self.end_s is not None:
            raise bad(f"tendon {self.name!r} end", (self.end_node, self.end_s), "end_node or end_s, not both")
        if self.end_node is not None and not is_int(self.end_node):
            raise bad(f"tendon {self.name!r} end_node", self.end_node, "an integer node index")
        if self.end_s is not None and (not is_finite_number(self.end_s) or self.end_s <= 0):
            raise bad(f"tendon {self.name!r} end_s", self.end_s, "a positive arc length in m")
        if self.displacement is not None:
            self._check_displacement()
            return
        if self.stiffness is not None:
            raise bad(f"tendon {self.name!r} stiffness", self.stiffness,
                      "no stiffness for a tendon pulled with a tension (or give displacement instead of tension)")
        if self.tension is None:
            object.__setattr__(self, "tension", 0.0)
        if callable(self.tension):
            return
        if not is_finite_number(self.tension) or self.tension < 0:
            raise bad(f"tendon {self.name!r} tension", self.tension,
                      "a tension >= 0 in N (a tendon cannot push), or a tension profile t -> (K,)")
        object.__setattr__(self, "tension", float(self.tension))

    def _check_displacement(self) -> None:
        """A displacement-controlled tendon: no tension, a displacement in m, a stiffness > 0 in N/m."""
        if self.tension is not None:
            raise bad(f"tendon {self.name!r} tension", self.tension,
                      "no tension for a tendon driven by a displacement (give tension or displacement, not both)")
        if not callable(self.displacement):
            if not is_finite_number(self.displacement):
                raise bad(f"tendon {self.name!r} displacement", self.displacement,
                          "a finite length pulled in at the servo in m, or a displacement profile t -> (K,)")
            object.__setattr__(self, "displacement", float(self.displacement))
        if not is_finite_number(self.stiffness) or self.stiffness <= 0:
            raise bad(f"tendon {self.name!r} stiffness", self.stiffness,
                      "a finite series stiffness > 0 in N/m (servo plus cable) for a tendon driven by a displacement")
        object.__setattr__(self, "stiffness", float(self.stiffness))

    @property
    def displacement_controlled(self) -> bool:
        """True when the tendon is driven by a ``displacement`` (its tension follows the rod)."""
        return self.displacement is not None

    @property
    def displacement_channel(self) -> str:
        """The actuation channel of its displacement, ``tendon_<name>_displacement`` [m]."""
        return f"tendon_{self.name}_displacement"

    @property
    def twist_rate(self) -> float:
        """d phi / ds = 2 pi / pitch [rad/m] (0 for straight routing)."""
        return 0.0 if self.pitch is None else 2.0 * math.pi / float(self.pitch)

    @property
    def channel(self) -> str:
        """The actuation channel name ``tendon_<name>``."""
        return f"tendon_{self.name}"

    def offsets_at(self, s) -> np.ndarray:
        """Body-frame offsets rho(s) (K, 3) [m] at the stress-free arc lengths s (K,) [m]."""
        phi = self.twist_rate * np.asarray(s, dtype=float)
        c, sn = np.cos(phi), np.sin(phi)
        ox, oy = self.offset
        return np.stack([c * ox - sn * oy, sn * ox + c * oy, np.zeros_like(phi)], axis=-1)

    def tensions(self, t) -> np.ndarray:
        """Tension (K,) [N] at times t (K,) [s], clipped at 0 (a slack tendon); a profile that
        returns another shape or a value that is not finite is an error. A tendon driven by a
        displacement has no tension of its own (it follows the rod's configuration): an error."""
        t = np.asarray(t, dtype=float)
        if self.displacement is not None:
            raise SoftrnnInputError(f"tendon {self.name!r} is driven by a displacement: its tension follows the "
                                    "rod's configuration; read it from Trajectory.tendon_tensions or "
                                    "StaticSolution.tendon_tensions")
        return np.maximum(self._profile(self.tension, t, "tension", "N"), 0.0)

    def displacements(self, t) -> np.ndarray:
        """Displacement (K,) [m] at times t (K,) [s] of a tendon driven by one (not clipped: a
        negative value pays the tendon out); a profile that returns another shape or a value that
        is not finite is an error."""
        t = np.asarray(t, dtype=float)
        if self.displacement is None:
            raise bad(f"tendon {self.name!r} displacement", None, "a tendon driven by a displacement (this one is "
                                                                  "pulled with a tension)")
        return self._profile(self.displacement, t, "displacement", "m")

    def _profile(self, profile, t: np.ndarray, what: str, unit: str) -> np.ndarray:
        """The constant or profile ``profile`` (the tension or the displacement, named ``what``, in
        ``unit``) at times t (K,) [s]: (K,); another shape or a value that is not finite is an error."""
        if not callable(profile):
            return np.full(t.shape, profile)
        value = np.asarray(profile(t), dtype=float)
        if value.shape != t.shape:
            raise bad(f"tendon {self.name!r} {what}", f"a profile returning shape {value.shape}",
                      f"a profile t (K,) -> (K,) in {unit} (got {t.shape} times); wrap a vector time function "
                      "in softrnn.rod.tendons.Scalar")
        if not np.all(np.isfinite(value)):
            raise SoftrnnInputError(f"tendon {self.name!r}: the {what} profile is not finite at "
                                    f"t = {float(t[~np.isfinite(value)][0]):.6g} s; give finite {what}s in {unit}")
        return value

    def end_index(self, n_nodes: int, seg_length: float) -> int:
        """The termination node (1 .. n - 1) of a rod of ``n_nodes`` nodes of spacing ``seg_length``
        [m]; SoftrnnInputError naming the node or arc length when it is out of range."""
        n = n_nodes
        if self.end_s is not None:
            L = (n - 1) * seg_length
            if not self.end_s <= L * (1 + 1e-9):
                raise bad(f"tendon {self.name!r} end_s", self.end_s, f"an arc length in (0, {L:g}] m (the rod length)")
            a = int(round(self.end_s / seg_length))
        elif self.end_node is None:
            a = n - 1
        else:
            if not -n <= self.end_node < n:
                raise bad(f"tendon {self.name!r} end_node", self.end_node,
                          f"a node index in [-{n}, {n - 1}] for a rod of {n} nodes (negative counts from the end)")
            a = int(self.end_node) % n
        if a < 1:
            raise bad(f"tendon {self.name!r} end", self.end_node if self.end_s is None else self.end_s,
                      f"a termination beyond the base node 0 (node >= 1, arc length >= {seg_length:g} m)")
        return a


def check_offset(tendon: Tendon, radii: np.ndarray, end: int) -> None:
    """Refuse a tendon whose offset lies outside the cross-section of a node it passes (radii (n,)
    [m] per node, ``end`` its termination node)."""
    size = math.hypot(*tendon.offset)
    limit = float(np.min(radii[:end + 1]))
    if size > limit * (1 + 1e-12):
        raise bad(f"tendon {tendon.name!r} offset", tendon.offset,
                  f"an offset of at most the section radius {limit:g} m from the centreline "
                  f"(|offset| = {size:g} m lies outside the rod)")


def routing_arrays(tendons, n_nodes: int, seg_length: float) -> tuple[np.ndarray, np.ndarray]:
    """The kernel's routing arrays of ``tendons`` (m of them) on a rod of ``n_nodes`` nodes:
    route (m, n - 1, 6), per segment the body-frame offset rho [m] and its rate d rho / ds [-] at
    the middle's stress-free arc length (zero beyond the termination), and end (m,) int64 the
    termination nodes."""
    m, n = len(tendons), n_nodes
    route = np.zeros((m, n - 1, 6))
    end = np.zeros(m, dtype=np.int64)
    s = seg_length * (np.arange(n - 1) + 0.5)
    for j, td in enumerate(tendons):
        e = end[j] = td.end_index(n, seg_length)
        rho = td.offsets_at(s[:e])
        route[j, :e, :3] = rho
        route[j, :e, 3:] = td.twist_rate * np.cross([0.0, 0.0, 1.0], rho)
    return route, end


def tension_matrix(tendons, t) -> np.ndarray:
    """Tensions (K, m) [N] of the m ``tendons`` at times t (K,) [s] (clipped at 0); a tendon driven
    by a displacement is an error (its tension follows the rod: ``Trajectory.tendon_tensions``)."""
    t = np.asarray(t, dtype=float)
    out = np.zeros((t.size, len(tendons)))
    for j, td in enumerate(tendons):
        out[:, j] = td.tensions(t)
    return out


def prescribed_tensions(tendons, t) -> np.ndarray:
    """Tensions (K, m) [N] of the tendons pulled with a tension at times t (K,) [s] (clipped at 0),
    0 in the columns of the tendons driven by a displacement (the kernel computes theirs)."""
    t = np.asarray(t, dtype=float)
    out = np.zeros((t.size, len(tendons)))
    for j, td in enumerate(tendons):
        if not td.displacement_controlled:
            out[:, j] = td.tensions(t)
    return out


def displacement_matrix(tendons, t) -> np.ndarray:
    """Displacements (K, m) [m] of the tendons driven by one at times t (K,) [s]; 0 in the columns
    of the tendons pulled with a tension."""
    t = np.asarray(t, dtype=float)
    out = np.zeros((t.size, len(tendons)))
    for j, td in enumerate(tendons):
        if td.displacement_controlled:
            out[:, j] = td.displacements(t)
    return out


def spring_arrays(tendons, rotations, positions, seg_length) -> tuple[np.ndarray, np.ndarray]:
    """The kernel's spring arrays of ``tendons`` on a rod whose stress-free reference has the
    rotations (n, 3, 3) and positions (n, 3) [m]: stiffness (m,) [N/m] (0 for a tendon pulled with
    a tension) and rest (m,) [m], the tendons' discrete lengths l_0 in the reference
    (``tendon_lengths``)."""
    stiffness = np.array([td.stiffness if td.displacement_controlled else 0.0 for td in tendons], dtype=float)
    route, end = routing_arrays(tendons, len(positions), seg_length)
    rest = tendon_lengths(rotations, positions, seg_length, route, end) if len(tendons) else np.zeros(0)
    return stiffness, rest


def spring_tensions(lengths, rest, stiffness, displacement) -> np.ndarray:
    """tau = k max(0, q - (l_0 - l)) [N] from the tendon lengths l, rest lengths l_0 [m], series
    stiffnesses k [N/m] and displacements q [m] (broadcast arrays); 0 where k is 0."""
    stretch = np.asarray(displacement, dtype=float) - (np.asarray(rest, dtype=float) - np.asarray(lengths, dtype=float))
    return np.asarray(stiffness, dtype=float) * np.maximum(stretch, 0.0)


def actuation_units(tendons) -> dict[str, str]:
    """The tendons' actuation channels in column order: {``tendon_<name>``: "N"} for every tendon,
    then {``tendon_<name>_displacement``: "m"} for each tendon driven by a displacement."""
    units = {td.channel: "N" for td in tendons}
    units.update({td.displacement_channel: "m" for td in tendons if td.displacement_controlled})
    return units


def tendon_actuation(tendons, times, tensions=None) -> tuple[np.ndarray, dict[str, str]]:
    """The tendons as actuation inputs of a dataset: values (T, c) at the sample times (T,) [s] and
    the channels (``actuation_units``) in column order: the tensions [N] (what the simulator
    applied: clipped at 0), then the displacements [m] of the tendons driven by one. The tensions
    of such tendons follow the rod: give ``tensions`` (T, m) [N], a run's
    ``Trajectory.tendon_tensions`` (without it only a tension-driven set, or no times, works)."""
    tendons = tuple(tendons)
    times = np.asarray(times, dtype=float)
    if tensions is None:
        tensions = tension_matrix(tendons, times) if times.size else np.zeros((0, len(tendons)))
    moved = [td for td in tendons if td.displacement_controlled]
    values = np.asarray(tensions, dtype=float).reshape(times.size, len(tendons))
    if moved:
        values = np.concatenate([values, displacement_matrix(moved, times)], axis=1)
    return values, actuation_units(tendons)


def tendon_sink(append, tendons):
    """A ``Simulator.run`` sink that passes every chunk on as ``append(chunk, actuation=values)``
    with the tendons' actuation (k, c) at the chunk's times (``tendon_actuation``: tensions [N],
    then the displacements [m] of the tendons driven by one, whose tensions come from the chunk's
    ``tendon_tensions``): e.g. a ``softrnn.io.DatasetWriter``'s append, made with
    ``actuation_units`` from ``tendon_actuation``. Without tendons, ``append`` itself."""
    tendons = tuple(tendons)
    if not tendons:
        return append
    if not any(td.displacement_controlled for td in tendons):
        def sink(chunk):
            append(chunk, actuation=tension_matrix(tendons, chunk.time))
        return sink

    def sink_moved(chunk):
        append(chunk, actuation=tendon_actuation(tendons, chunk.time, chunk.tendon_tensions)[0])
    return sink_moved


def _tangents(K, G, route, end):
    """Per tendon j: Gamma + K x rho + rho' (e_j, 3) over its routed segments."""
    return [G[:e] + np.cross(K[:e], route[j, :e, :3]) + route[j, :e, 3:] for j, e in enumerate(end)]


def tendon_potential(rotations, positions, seg_length, route, end, tension) -> float:
    """V = sum_j tau_j l sum_{a < e_j} |Gamma_a + K_a x rho_a + rho'_a| [J]: the work potential of
    the tendons with tensions (m,) [N] on the rod's configuration (rotations (n, 3, 3), positions
    (n, 3) [m]; ``route``, ``end`` from ``routing_arrays``)."""
    K, G = segment_strains(rotations, positions, seg_length)
    return float(sum(max(float(tension[j]), 0.0) * seg_length * np.linalg.norm(t, axis=1).sum()
                     for j, t in enumerate(_tangents(K, G, route, end))))


def tendon_lengths(rotations, positions, seg_length, route, end) -> np.ndarray:
    """The discrete tendon lengths l_j = l sum_{a < e_j} |Gamma_a + K_a x rho_a + rho'_a| (m,) [m]
    on one configuration (rotations (n, 3, 3), positions (n, 3) [m]; ``route``, ``end`` from
    ``routing_arrays``): the tendon potential is sum_j tau_j l_j."""
    K, G = segment_strains(rotations, positions, seg_length)
    return np.array([seg_length * np.linalg.norm(t, axis=1).sum() for t in _tangents(K, G, route, end)])


def tendon_energy(setup, trajectory) -> tuple[np.ndarray, np.ndarray]:
    """The tendons' share of a run's energy balance: (potential (S,) [J], work (S,) [J]).

    ``potential``: at each saved sample, sum_j tau_j(t) l_j(t) over the tendons pulled with a
    tension (the work potential; tensions clipped at 0, lengths ``tendon_lengths``) plus
    sum_j tau_j^2 / (2 k_j) over those driven by a displacement (the energy of their series spring,
    tau_j from the sample's configuration): with constant tensions and displacements and no
    dissipation, ``trajectory.energy.sum(axis=1) + potential`` is conserved. ``work`` =
    -int sum_j tau_j dl_j, the work the tendons did on the rod since the first sample (trapezoidal
    rule over the samples, so to the accuracy of the saved interval): with varying tensions or
    displacements and no dissipation, ``trajectory.energy.sum(axis=1) - work`` is conserved.
    ``Trajectory.energy`` (kinetic, elastic, gravitational) leaves both out. The trajectory must
    save every node (``RunConfig.save_nodes`` None)."""
    n = setup.rod.n_nodes
    if len(trajectory.nodes) != n or np.any(np.asarray(trajectory.nodes) != np.arange(n)):
        raise bad("trajectory", f"{len(trajectory.nodes)} saved nodes",
                  f"a run that saves all {n} nodes (RunConfig save_nodes = None)")
    S = len(trajectory.time)
    tendons = tuple(setup.tendons)
    if not tendons:
        return np.zeros(S), np.zeros(S)
    l = setup.rod.segment_length
    route, end = routing_arrays(tendons, n, l)
    R = trajectory.rotations()
    lengths = np.stack([tendon_lengths(R[k], trajectory.positions[k], l, route, end) for k in range(S)])
    tau = prescribed_tensions(tendons, trajectory.time)
    potential = (tau * lengths).sum(axis=1)
    moved = np.array([td.displacement_controlled for td in tendons])
    if moved.any():
        stiffness, rest = spring_arrays(tendons, setup.reference.rotations, setup.reference.positions, l)
        spring = spring_tensions(lengths, rest, stiffness, displacement_matrix(tendons, trajectory.time))
        tau[:, moved] = spring[:, moved]
        potential = (tau * lengths)[:, ~moved].sum(axis=1) + (0.5 * tau[:, moved] ** 2 / stiffness[moved]).sum(axis=1)
    work = np.zeros(S)
    work[1:] = -np.cumsum((0.5 * (tau[1:] + tau[:-1]) * np.diff(lengths, axis=0)).sum(axis=1))
    return potential, work


def tendon_resultants(K, G, route, end, tension) -> tuple[np.ndarray, np.ndarray]:
    """The tendons' terms of the segments' force and moment resultants (n - 1, 3) [N], [N m] (frame
    of each segment's first node) for strains K (n - 1, 3) [1/m], Gamma (n - 1, 3) [-]: tau t and
    tau rho x t, t the unit vector of Gamma + K x rho + rho' (NumPy reference of the kernel)."""
    N = np.zeros_like(K)
    M = np.zeros_like(K)
    for j, t in enumerate(_tangents(K, G, route, end)):
        tau = max(float(tension[j]), 0.0)
        if tau == 0.0:
            continue
        e = end[j]
        t = tau * t / np.linalg.norm(t, axis=1, keepdims=True)
        N[:e] += t
        M[:e] += np.cross(route[j, :e, :3], t)
    return N, M
