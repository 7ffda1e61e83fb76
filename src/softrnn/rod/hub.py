"""Insertion and rotation at the hub: a device pushed along and twisted about its insertion axis
(docs/guide/simulator.md#insertion-and-rotation-at-the-hub).

A ``Hub`` clamps one node (usually node 0) at its ``entry`` point [m] with its frame ``rotation0``
and moves it by two inputs:

* the insertion d [m] along the unit ``axis`` and the rotation theta [rad] about it, each
  prescribed as a time function (a number, a ``(times, values)`` table, ``Commanded`` or any
  callable t (K,) [s] -> (K,)): the clamp follows position entry + d(t) axis and rotation
  Rot(axis, theta(t)) rotation0 (``Hub.__call__``, the ``Clamp.motion`` of ``Hub.clamp``);
* or driven: an axial ``force`` [N] pushes the node along the axis and a ``torque`` [N m] twists it
  about the axis against the rod's reaction, the hub a body of ``mass`` [kg] and axial ``inertia``
  [kg m^2] added to the node's; the guide still holds the node's position across the axis and its
  tilt (kernel node kinds ``HUB_PUSHED``, ``HUB_TWISTED``, ``HUB_DRIVEN`` of ``rod.kernel_records``).
  A driven hub needs the axis along the node's d3 (the rod enters along its tangent) and the
  explicit integrator.

Commanded inputs (``Commanded``, ``Hub.commanded``) are set between runs (``Hub.command``) so a
closed loop or an environment can step the rod: the motion stays continuous (a rate command
continues from where the hub is).

A data set stores the hub as actuation channels (``HUB_CHANNELS``; ``HubRecorder``): insertion [m]
and rotation [rad], prescribed or measured, and with a driven hub its force [N] and torque [N m].
"""

import math
from dataclasses import dataclass

import numpy as np

from ..errors import bad, is_finite_number, nonnegative, positive, vec3
from .boundary import Clamp
from .kernel_records import CLAMPED, HUB_DRIVEN, HUB_PUSHED, HUB_TWISTED
from .loads import NodalLoad, Sampled
from .so3 import frame_from_tangent, quaternion_to_matrix
from .tendons import actuation_units, tendon_actuation, tendon_sink

HUB_CHANNELS = {"hub_insertion": "m", "hub_rotation": "rad", "hub_force": "N", "hub_torque": "N m"}
"""The hub's actuation channels of a data set and their units, in column order (a prescribed hub
stores the first two; a driven one its force and / or torque too)."""


@dataclass(frozen=True, eq=False)
class HubTable:
    """A scalar table: ``values`` (m,) at increasing finite ``times`` (m,) [s], linear between them
    (``interpolation`` 'linear') or held from each time to the next ('hold'), and held at the first
    value before the first time and at the last after the last (a hub stays where its table
    leaves it). t (K,) -> (K,)."""

    times: np.ndarray
    values: np.ndarray
    interpolation: str = "linear"

    def __post_init__(self):
        values = np.asarray(self.values, dtype=float)
        if values.ndim != 1:
            raise bad("HubTable.values", _short(self.values), "a 1-D list of values, one per time")
        table = Sampled(self.times, values[:, None] * np.array([1.0, 0.0, 0.0]), self.interpolation)  # checks them
        object.__setattr__(self, "times", table.times)
        object.__setattr__(self, "values", values)
        object.__setattr__(self, "_table", table)

    def __call__(self, t):
        t = np.clip(np.asarray(t, dtype=float), self.times[0], self.times[-1])
        return self._table(t)[:, 0]


def _short(value):
    """``value`` for a message: as (nested) lists, or its shape when it is long."""
    try:
        a = np.asarray(value, dtype=float)
    except (TypeError, ValueError):
        return value
    return a.tolist() if a.size <= 16 else f"an array of shape {a.shape}"


class Commanded:
    """A scalar input set between runs (a hub's insertion [m] or rotation [rad], or its force [N] or
    torque [N m]): piecewise linear in time, ``value`` until the first command. t (K,) -> (K,).

    ``rate(t_now, rate)`` continues from the value at t_now with ``rate`` per second;
    ``set(t_now, value)`` holds ``value`` from t_now on (a step: for forces and torques);
    ``ramp_to(t_now, target, duration)`` moves to ``target`` in ``duration`` [s] and holds it. A
    command replaces whatever an earlier one planned after t_now; commands come in time order;
    ``reset`` forgets them all. ``bounds`` (low, high), e.g. an insertion's travel: the value stops
    at either end (a rate continues from where it stopped; ``set`` and ``ramp_to`` targets must lie
    within); None: unbounded.
    """

    def __init__(self, value: float = 0.0, bounds: tuple | None = None):
        if not is_finite_number(value):
            raise bad("Commanded.value", value, "a finite start value")
        if bounds is not None:
            try:
                low, high = (float(b) for b in bounds)
            except (TypeError, ValueError):
                raise bad("Commanded.bounds", bounds, "(low, high): the least and the largest value") from None
            if math.isnan(low) or math.isnan(high) or not low <= float(value) <= high:
                raise bad("Commanded.bounds", bounds, f"(low, high) with low <= the start value {value:g} <= high")
            bounds = (low, high)
        self.bounds = bounds
        self._initial = float(value)
        self.reset()

    def reset(self) -> None:
        """Forget every command: the start value again, at all times."""
        self._start = [-math.inf]      # segment k holds from _start[k]: _value[k] + _rate[k] (t - _start[k])
        self._value = [self._initial]
        self._rate = [0.0]
        self._last = -math.inf
        self._arrays = None

    def __call__(self, t):
        t = np.asarray(t, dtype=float)
        if self._arrays is None:                     # rebuilt after a command
            self._arrays = tuple(np.array(a) for a in (self._start, self._value, self._rate))
        k = np.searchsorted(self._arrays[0], t, side="right") - 1
        start, value, rate = (a[k] for a in self._arrays)
        out = np.where(rate != 0.0, value + rate * (t - np.where(np.isfinite(start), start, 0.0)), value)
        return out if self.bounds is None else np.clip(out, *self.bounds)

    def at(self, t_now: float) -> float:
        """The value at t_now [s]."""
        return float(self(np.array([float(t_now)]))[0])

    def _cut(self, t_now) -> float:
        """Check ``t_now`` (finite, not before the last command) and drop what was planned after it."""
        if not is_finite_number(t_now) or t_now < self._last:
            raise bad("t_now", t_now, f"a finite time >= {self._last:g} s, the last command's (commands come in "
                                      "time order)")
        while len(self._start) > 1 and self._start[-1] > t_now:
            for seq in (self._start, self._value, self._rate):
                seq.pop()
            self._arrays = None
        self._last = float(t_now)
        return float(t_now)

    def rate(self, t_now: float, rate: float) -> None:
        """From ``t_now`` [s] on, change by ``rate`` per second from the value there."""
        if not is_finite_number(rate):
            raise bad("rate", rate, "a finite rate per second")
        value = self.at(self._cut(t_now))
        self._append(t_now, value, float(rate))

    def _within(self, name: str, value) -> None:
        """Refuse a value that is not finite or lies outside ``bounds``."""
        if not is_finite_number(value):
            raise bad(name, value, f"a finite {name} value")
        if self.bounds is not None and not self.bounds[0] <= value <= self.bounds[1]:
            raise bad(name, value, f"a value within the bounds [{self.bounds[0]:g}, {self.bounds[1]:g}]")

    def set(self, t_now: float, value: float) -> None:
        """Hold ``value`` from ``t_now`` [s] on."""
        self._within("value", value)
        self._append(self._cut(t_now), float(value), 0.0)

    def ramp_to(self, t_now: float, target: float, duration: float) -> None:
        """Move linearly from the value at ``t_now`` [s] to ``target`` over ``duration`` [s] > 0, then hold."""
        self._within("target", target)
        if not is_finite_number(duration) or duration <= 0:
            raise bad("duration", duration, "a positive time in s")
        value = self.at(self._cut(t_now))
        self._append(t_now, value, (float(target) - value) / float(duration))
        self._append(float(t_now) + float(duration), float(target), 0.0)

    def _append(self, start: float, value: float, rate: float) -> None:
        self._arrays = None
        if start == self._start[-1]:
            self._value[-1], self._rate[-1] = value, rate
            return
        self._start.append(float(start))
        self._value.append(value)
        self._rate.append(rate)


def scalar_function(name: str, value, unit: str):
    """A hub input as a time function t (K,) [s] -> (K,): None stays None (no input), a number is a
    constant, a ``(times, values)`` pair a ``HubTable``, a callable is checked at t = 0 (finite,
    one value per time); anything else is a one-line error naming ``name``."""
    if value is None:
        return None
    if is_finite_number(value):
        return HubTable([0.0], [float(value)])
    if isinstance(value, (tuple, list)) and len(value) == 2 and not callable(value[0]):
        times, values = value
        try:
            return HubTable(times, values)
        except (TypeError, ValueError) as err:
            raise bad(name, _short(value), f"a table (times [s], values [{unit}]) of finite values at strictly "
                                           f"increasing times ({err})") from None
    if not callable(value):
        raise bad(name, value, f"a number in {unit}, a (times, values) table or a time function t (K,) -> (K,)")
    probe = np.asarray(value(np.zeros(1)), dtype=float)
    if probe.shape != (1,) or not np.all(np.isfinite(probe)):
        raise bad(name, value, f"a time function t (K,) [s] -> (K,) of finite values in {unit} (at t = 0 it gave "
                               f"shape {probe.shape})")
    return value


def axis_rotation(axis: np.ndarray, theta: np.ndarray) -> np.ndarray:
    """Rotations (K, 3, 3) by the angles theta (K,) [rad] about the unit ``axis`` (3,) (Rodrigues)."""
    K = np.array([[0.0, -axis[2], axis[1]], [axis[2], 0.0, -axis[0]], [-axis[1], axis[0], 0.0]])
    s, c = np.sin(theta)[:, None, None], np.cos(theta)[:, None, None]
    return np.eye(3) + s * K + (1.0 - c) * (K @ K)


@dataclass(frozen=True, eq=False)
class _Along:
    """A world vector along ``axis`` (3,) scaled by a scalar time function: t (K,) -> (K, 3)."""

    function: object
    axis: np.ndarray

    def __call__(self, t):
        return np.asarray(self.function(t), dtype=float)[:, None] * self.axis


@dataclass(frozen=True, eq=False)
class Hub:
    """The hub of an inserted device: it holds one node at ``entry`` and inserts it along ``axis``
    and rotates it about it (module docstring).

    Attributes
    ----------
    entry : (3,) [m]
        the held node's position at zero insertion
    axis : (3,)
        the insertion direction, normalised (a nonzero vector)
    rotation0 : (3, 3) or None
        the held node's frame at zero rotation (columns d1, d2, d3; None: d3 along the axis, d1 the
        part of world z, or x, normal to it)
    insertion, rotation : time function or None
        the prescribed insertion d(t) [m] and rotation theta(t) [rad] (``scalar_function``: a
        number, a (times, values) table, ``Commanded`` or a callable t (K,) -> (K,)); None: 0, or
        driven by ``force`` / ``torque``
    force, torque : time function or None
        instead: the axial force [N] pushing the node along the axis and the torque [N m] about it
    mass : float
        the hub's mass [kg] moved with a pushed node (>= 0; with ``force`` only)
    inertia : float
        the hub's moment of inertia about the axis [kg m^2] turned with a twisted node (>= 0; with
        ``torque`` only)
    """

    entry: tuple
    axis: tuple
    rotation0: np.ndarray | None = None
    insertion: object = None
    rotation: object = None
    force: object = None
    torque: object = None
    mass: float = 0.0
    inertia: float = 0.0

    def __post_init__(self):
        object.__setattr__(self, "entry", vec3("Hub.entry", self.entry, "in m"))
        axis = np.array(vec3("Hub.axis", self.axis, "(the insertion direction, of nonzero length)", nonzero=True))
        axis = axis / np.linalg.norm(axis)
        axis.setflags(write=False)
        object.__setattr__(self, "axis", axis)
        object.__setattr__(self, "rotation0", self._frame())
        for given, other in (("insertion", "force"), ("rotation", "torque")):
            if getattr(self, given) is not None and getattr(self, other) is not None:
                raise bad(f"Hub.{given}", getattr(self, given), f"None when the {given} is driven by a {other} "
                                                                f"(give {given} or {other}, not both)")
        for name, unit in (("insertion", "m"), ("rotation", "rad"), ("force", "N"), ("torque", "N m")):
            object.__setattr__(self, name, scalar_function(f"Hub.{name}", getattr(self, name), unit))
        for name, driver, unit in (("mass", "force", "kg"), ("inertia", "torque", "kg m^2")):
            value = nonnegative(f"Hub.{name}", getattr(self, name), unit)
            if value > 0 and getattr(self, driver) is None:
                raise bad(f"Hub.{name}", value, f"0 without a {driver} (only a driven hub moves its own {name})")
            object.__setattr__(self, name, value)
        if self.driven and np.abs(self.rotation0[:, 2] - self.axis).max() > 1e-9:
            raise bad("Hub.rotation0", f"a frame with d3 = {np.round(self.rotation0[:, 2], 6).tolist()}",
                      f"a frame whose d3 is the axis {np.round(self.axis, 6).tolist()} (a driven hub pushes and "
                      "twists the rod along its tangent)")

    def _frame(self) -> np.ndarray:
        """The checked ``rotation0`` (3, 3), read-only (the default frame when None)."""
        if self.rotation0 is None:
            hint = (0.0, 0.0, 1.0) if abs(self.axis[2]) < 0.9 else (1.0, 0.0, 0.0)
            R = frame_from_tangent(self.axis, np.array(hint))
        else:
            R = np.array(self.rotation0, dtype=float)
            if R.shape != (3, 3) or not np.all(np.isfinite(R)) or not np.allclose(R.T @ R, np.eye(3), atol=1e-8) \
                    or np.linalg.det(R) < 0:
                raise bad("Hub.rotation0", f"an array of shape {R.shape}", "a 3x3 rotation matrix (columns d1, d2, d3)")
        R.setflags(write=False)
        return R

    @classmethod
    def commanded(cls, entry, axis, rotation0=None, *, pushed: bool = False, twisted: bool = False,
                  mass: float = 0.0, inertia: float = 0.0, travel: float | None = None) -> "Hub":
        """A hub whose inputs are set between runs (``command``): insertion and rotation rates, or with
        ``pushed`` / ``twisted`` its force [N] / torque [N m] (``Commanded``, all 0 at the start);
        ``travel`` [m] > 0: the commanded insertion stays in [0, travel] (it stops at either end)."""
        bounds = None
        if travel is not None:
            if pushed:
                raise bad("travel", travel, "None for a hub pushed by a force (the travel bounds a commanded "
                                            "insertion)")
            bounds = (0.0, positive("travel", travel, "m"))
        inputs = {("force" if pushed else "insertion"): Commanded(bounds=bounds),
                  ("torque" if twisted else "rotation"): Commanded()}
        return cls(entry=entry, axis=axis, rotation0=rotation0, mass=mass, inertia=inertia, **inputs)

    def reset_commands(self) -> None:
        """Forget the commands of its ``Commanded`` inputs (each back at its start value), e.g. at the
        start of an episode."""
        for function in (self.insertion, self.rotation, self.force, self.torque):
            if isinstance(function, Commanded):
                function.reset()

    @property
    def pushed(self) -> bool:
        """Whether a force drives the insertion."""
        return self.force is not None

    @property
    def twisted(self) -> bool:
        """Whether a torque drives the rotation."""
        return self.torque is not None

    @property
    def driven(self) -> bool:
        """Whether a force or a torque drives the hub (its node is then a dynamic one)."""
        return self.pushed or self.twisted

    @property
    def kind(self) -> int:
        """The held node's kernel kind: CLAMPED, HUB_PUSHED, HUB_TWISTED or HUB_DRIVEN."""
        return {(False, False): CLAMPED, (True, False): HUB_PUSHED, (False, True): HUB_TWISTED,
                (True, True): HUB_DRIVEN}[(self.pushed, self.twisted)]

    def __call__(self, t):
        """The clamp motion: positions (K, 3) [m] and rotations (K, 3, 3) at times t (K,) [s] (a driven
        input at 0)."""
        t = np.atleast_1d(np.asarray(t, dtype=float))
        d = np.zeros(t.size) if self.insertion is None else np.asarray(self.insertion(t), dtype=float)
        pos = np.asarray(self.entry) + d[:, None] * self.axis
        if self.rotation is None:
            return pos, np.broadcast_to(self.rotation0, (t.size, 3, 3)).copy()
        return pos, axis_rotation(self.axis, np.asarray(self.rotation(t), dtype=float)) @ self.rotation0

    def clamp(self, node: int = 0) -> Clamp:
        """The boundary condition: node ``node`` held by this hub (``Clamp`` with this hub as motion)."""
        return Clamp(node, motion=self)

    def loads(self, node: int) -> tuple:
        """The driving force and torque as world-frame ``NodalLoad`` entries on ``node`` (none when
        prescribed)."""
        out = []
        if self.pushed:
            out.append(NodalLoad(node, force=_Along(self.force, self.axis)))
        if self.twisted:
            out.append(NodalLoad(node, torque=_Along(self.torque, self.axis)))
        return tuple(out)

    def command(self, t_now: float, *, insertion_rate=None, rotation_rate=None, force=None, torque=None) -> None:
        """Set the commanded inputs from ``t_now`` [s] on (the simulator's current time): insertion
        rate [m/s] and rotation rate [rad/s] (continuing from where the hub is), or a driven hub's
        force [N] and torque [N m]; None leaves an input as it is. Each must be ``Commanded``."""
        for name, value, target, how in (("insertion_rate", insertion_rate, "insertion", "rate"),
                                         ("rotation_rate", rotation_rate, "rotation", "rate"),
                                         ("force", force, "force", "set"), ("torque", torque, "torque", "set")):
            if value is None:
                continue
            function = getattr(self, target)
            if not isinstance(function, Commanded):
                raise bad(name, value, f"None: this hub's {target} is not commanded (build it with Hub.commanded)")
            getattr(function, how)(t_now, value)

    def at(self, t_now: float) -> tuple[float, float]:
        """The prescribed (or commanded) insertion [m] and rotation [rad] at t_now [s]; nan for an
        input driven by a force or a torque (``measure`` it on the node)."""
        t = np.array([float(t_now)])

        def value(function, driven: bool) -> float:
            if driven:
                return math.nan
            return 0.0 if function is None else float(np.asarray(function(t), dtype=float)[0])
        return value(self.insertion, self.pushed), value(self.rotation, self.twisted)

    def measure(self, position, rotation) -> tuple[float, float]:
        """The insertion [m] and rotation [rad] in (-pi, pi] of the held node at ``position`` (3,) [m]
        with the frame ``rotation`` (3, 3) (e.g. ``Simulator.state``'s row of the node)."""
        d = float((np.asarray(position, dtype=float) - self.entry) @ self.axis)
        return d, float(self.twist_angle(np.asarray(rotation, dtype=float)[None])[0])

    @property
    def channels(self) -> dict:
        """Its actuation channels {name: unit} in column order (``HUB_CHANNELS``)."""
        names = ["hub_insertion", "hub_rotation"] + ["hub_force"] * self.pushed + ["hub_torque"] * self.twisted
        return {name: HUB_CHANNELS[name] for name in names}

    def twist_angle(self, rotations: np.ndarray) -> np.ndarray:
        """The rotation about the axis (K,) [rad] in (-pi, pi] of held-node frames (K, 3, 3)."""
        Q = np.asarray(rotations, dtype=float) @ self.rotation0.T
        sin = 0.5 * ((Q[:, 2, 1] - Q[:, 1, 2]) * self.axis[0] + (Q[:, 0, 2] - Q[:, 2, 0]) * self.axis[1]
                     + (Q[:, 1, 0] - Q[:, 0, 1]) * self.axis[2])
        return np.arctan2(sin, 0.5 * (np.trace(Q, axis1=1, axis2=2) - 1.0))


# --------------------------------------------------------------------------- the hub in a setup
def hub_of(setup) -> tuple[int, Hub] | None:
    """The node index and ``Hub`` of a ``Setup``'s clamp held by a hub, or None; a setup holds at
    most one hub (its channels are named after it)."""
    found = [(setup.node_index(bc.node), bc.motion) for bc in setup.boundary
             if isinstance(bc, Clamp) and isinstance(bc.motion, Hub)]
    if len(found) > 1:
        raise bad("boundary", f"{len(found)} clamps held by a Hub", "at most one hub per setup")
    return found[0] if found else None


def driven_hub(setup) -> tuple[int, Hub] | None:
    """``hub_of(setup)`` when the hub is driven by a force or a torque, else None."""
    found = hub_of(setup)
    return found if found is not None and found[1].driven else None


def with_hub(rod, setup):
    """The lumped rod (``LumpedRod``) of ``setup`` with a driven hub's node kind, and the hub's mass
    added to its node's and its inertia to the node's about d3; ``rod`` itself without one."""
    found = driven_hub(setup)
    if found is None:
        return rod
    a, hub = found
    kind, mass, inertia = rod.kind.copy(), rod.mass.copy(), rod.inertia.copy()
    kind[a] = hub.kind
    mass[a] += hub.mass
    inertia[a, 2] += hub.inertia
    for array in (kind, mass, inertia):
        array.setflags(write=False)
    return rod._replace(kind=kind, mass=mass, inertia=inertia)


def hub_loads(setup) -> tuple:
    """((node index, ``NodalLoad``), ...) of a driven hub's force and torque (none without one)."""
    found = driven_hub(setup)
    return () if found is None else tuple((found[0], load) for load in found[1].loads(found[0]))


def hub_half_kick(rod, velocities: np.ndarray, angular_velocities: np.ndarray, rotations: np.ndarray,
                  forces: np.ndarray, torques: np.ndarray, h: float) -> None:
    """The half kick (``rod.state.half_kick``) of the driven hub nodes of ``rod``: along d3 of their
    rotations (n, 3, 3) from the forces (n, 3) [N] (world) and about it from the body torques (n, 3)
    [N m]; velocities (n, 3) [m/s] and angular_velocities (n, 3) [rad/s] set in place; h [s]."""
    for a in np.flatnonzero(rod.kind >= HUB_PUSHED):
        e = rotations[a, :, 2]
        if rod.kind[a] in (HUB_PUSHED, HUB_DRIVEN):
            velocities[a] = -0.5 * h * float(forces[a] @ e) / rod.mass[a] * e
        if rod.kind[a] in (HUB_TWISTED, HUB_DRIVEN):
            angular_velocities[a] = (0.0, 0.0, -0.5 * h * torques[a, 2] / rod.inertia[a, 2])


class HubRecorder:
    """The hub's actuation channels (``Hub.channels``) of a run's chunks: the prescribed insertion
    [m] and rotation [rad] from their time functions, a driven one measured on the held node (saved
    at ``column`` of the chunks: d = (r - entry) . axis, theta continued across chunks from
    ``Hub.twist_angle``), and the force [N] and torque [N m]. Call it on each chunk in order."""

    def __init__(self, hub: Hub, column: int | None = None):
        if hub.driven and column is None:
            raise bad("column", column, "the saved column of the hub's node (a driven hub is measured on it)")
        self.hub, self.column = hub, column
        self._theta = None

    def __call__(self, chunk) -> np.ndarray:
        """Values (k, c) at the chunk's k samples."""
        hub, t = self.hub, np.asarray(chunk.time, dtype=float)
        if hub.insertion is not None:
            d = np.asarray(hub.insertion(t), dtype=float)
        else:
            d = (np.asarray(chunk.positions[:, self.column], dtype=float) - hub.entry) @ hub.axis
        if hub.rotation is not None:
            theta = np.asarray(hub.rotation(t), dtype=float)
        else:
            theta = self._unwrapped(hub.twist_angle(quaternion_to_matrix(chunk.quaternions[:, self.column])))
        cols = [d, theta] + [np.asarray(f(t), dtype=float) for f in (hub.force, hub.torque) if f is not None]
        return np.stack(cols, axis=1)

    def _unwrapped(self, theta: np.ndarray) -> np.ndarray:
        """``theta`` (k,) [rad] continued from the last chunk's last value: each change taken in
        (-pi, pi], so turns add up (a hub turns less than half a turn between samples)."""
        if theta.size == 0:
            return theta
        last = theta[0] if self._theta is None else self._theta
        out = last + np.cumsum(np.angle(np.exp(1j * np.diff(np.concatenate([[last], theta])))))
        self._theta = float(out[-1])
        return out


def run_channels(setup) -> dict:
    """The actuation channels {name: unit} of a run of ``setup`` in column order: the tendons'
    (``rod.tendons.actuation_units``), then the hub's (``Hub.channels``)."""
    from_tendons = actuation_units(setup.tendons)
    found = hub_of(setup)
    return from_tendons if found is None else {**from_tendons, **found[1].channels}


def run_sink(append, setup, nodes):
    """A ``Simulator.run`` sink passing every chunk on as ``append(chunk, actuation=values)`` with
    ``run_channels(setup)`` (the tendons' values, ``rod.tendons.tendon_actuation``, then the hub's,
    ``HubRecorder``; ``nodes`` (s,): the saved nodes); ``rod.tendons.tendon_sink`` without a hub."""
    found = hub_of(setup)
    if found is None:
        return tendon_sink(append, setup.tendons)
    a, hub = found
    nodes = [int(b) for b in nodes]
    if hub.driven and a not in nodes:
        raise bad("save_nodes", nodes, f"the hub's node {a} among the saved nodes (a driven hub is measured on it)")
    recorder = HubRecorder(hub, nodes.index(a) if a in nodes else None)

    def sink(chunk):
        tendons = tendon_actuation(setup.tendons, chunk.time, chunk.tendon_tensions)[0]
        append(chunk, actuation=np.concatenate([tendons, recorder(chunk)], axis=1))
    return sink
