"""Steering the magnetic manipulator at a vessel bifurcation (docs/guide/navigation.md).

The manipulator's rod (``ManipulatorSpec``: the PMC-770 rod with its two magnets, clamped at its
base) lies in a ``softrnn.rod.Bifurcation`` with contact; the coils apply a field across the trunk,
toward one branch, and the magnets' torque bends the tip into that branch's mouth. ``navigate``
runs one case, ``tip_branch`` tells where the tip ended; ``softrnn magnetic navigate`` stores a run
as a dataset that ``softrnn show`` and ``softrnn animate`` read (with its obstacles and currents);
the shipped scenario ``magnetic-bifurcation`` describes the same demonstration (``ramp_schedule``
makes the currents of both).

The demonstration's values (assumptions, with reasons):

* Rod: the default manipulator (50 mm of PMC-770 rubber, 3 mm thick, magnets at 25 and 49 mm),
  clamped at x = -25 mm on the trunk's axis, pointing along +x; gravity -z. With a fixed base
  (``navigation_spec()``) the tip reaches only the branches' mouths (5 mm past the junction).
* Insertion (``DEMO_ADVANCE``, ``navigation_spec(advance=...)``): the base advances 12 mm along the
  trunk (to x = -13 mm; the trunk extends to -35 mm behind it), starting at 0.3 s, when the field
  is at 60 % and the tip already leans toward the branch, over 0.7 s (smoothstep: 17 mm/s on
  average, 32 mm/s at its fastest): the steered tip then ends 17 mm along the branch, at 70 % of
  its 25 mm. Without a field the tip is pushed into the carina's crease and the advance jams there.
* Vessel (``demo_bifurcation``): a phantom, 7 mm inner diameter throughout (a large artery's
  size, e.g. the common carotid's 6-7 mm, scaled to the 3 mm rod so that it has 2 mm of room to
  bend): a straight trunk from x = -35 mm (behind the clamp) to the junction at x = 20 mm, and two
  25 mm branches at +-20 degrees in the horizontal plane, left toward +y. The straight rod then
  ends 5 mm past the junction, short of the carina's crease (5.8 mm for a rod on the axis).
* Contact: friction 0.1 (a lubricated phantom), penalty stiffness for 1000 m/s^2 (the magnetic
  loads press the rod on the wall with many times its weight; at this stiffness it sinks under
  0.5 % of its radius), critical damping.
* Field: 15 mT across the trunk toward the branch (``steering_field``), the minimum-norm coil
  currents for it at the workspace centre (``currents_for_field``, 5 A of the coils' 8 A); ramped
  from zero over ``ramp`` s after the rod settled (sagged onto the trunk's floor), then held.
"""

import math

import numpy as np

from ..errors import bad, positive
from ..rod.contact import Bifurcation, Contact
from .manipulator import (
    BaseAdvance,
    CurrentSchedule,
    ManipulatorRun,
    ManipulatorSpec,
    ManipulatorTrajectory,
    currents_for_field,
    simulate_manipulator,
)

BRANCHES = ("left", "right", "none")
"""The steering choices: toward the left or the right branch, or no field (the control)."""

DEMO_FIELD = 0.015
"""Field [T] across the trunk that steers the demonstration (5 A in the coils of ``bigmag_like``)."""

JUNCTION_X = 0.020
"""x [m] of the demonstration's junction (the rod's tip is at x = 25 mm)."""

DEMO_ADVANCE = BaseAdvance(distance=0.012, start=0.3, ramp=0.7)
"""The demonstration's insertion: 12 mm along the trunk from 0.3 s to 1.0 s (run it to 1.2 s,
e.g. ``navigate(branch, spec=navigation_spec(advance=DEMO_ADVANCE), hold=0.7)``)."""


def demo_bifurcation(*, radius: float = 0.0035, angle: float = 20.0, junction: float = JUNCTION_X,
                     branch_length: float = 0.025) -> Bifurcation:
    """The demonstration's vessel: a straight trunk along x from x = -35 mm to the junction at
    (junction, 0, 0) [m], and two straight branches of ``branch_length`` [m] at +-``angle`` [deg]
    in the xy-plane (left toward +y), all of inner radius ``radius`` [m]."""
    a = math.radians(positive("angle", angle, "degrees"))
    positive("branch_length", branch_length, "m")

    def arm(side):
        return [[junction + t * branch_length * math.cos(a), side * t * branch_length * math.sin(a), 0.0]
                for t in (0.5, 1.0)]
    return Bifurcation([[-0.035, 0.0, 0.0], [junction, 0.0, 0.0]], arm(1), arm(-1), radius)


def navigation_spec(bifurcation: Bifurcation | None = None, *, friction: float = 0.1,
                    reference_acceleration: float = 1000.0, advance: BaseAdvance | None = None) -> ManipulatorSpec:
    """The default manipulator inside ``bifurcation`` (None: ``demo_bifurcation()``) with contact of
    ``friction`` [-] and the default penalty stiffness at ``reference_acceleration`` [m/s^2]; its base
    fixed, or inserted by ``advance`` (e.g. ``DEMO_ADVANCE``)."""
    bifurcation = demo_bifurcation() if bifurcation is None else bifurcation
    if not isinstance(bifurcation, Bifurcation):
        raise bad("bifurcation", type(bifurcation).__name__, "a softrnn.rod.Bifurcation, or None for the demo's")
    contact = Contact(obstacles=bifurcation, friction=friction, reference_acceleration=reference_acceleration)
    return ManipulatorSpec(contact=contact, advance=advance)


def steering_field(bifurcation: Bifurcation, branch: str, magnitude: float = DEMO_FIELD) -> np.ndarray:
    """The field (3,) [T] that steers into ``branch`` ('left', 'right'; 'none': zero): ``magnitude``
    [T] along the direction from the junction to the branch's first point, less its component
    along the trunk's last segment (across the trunk, toward the branch)."""
    if branch not in BRANCHES:
        raise bad("branch", branch, "one of " + ", ".join(BRANCHES))
    positive("field", magnitude, "T")
    if branch == "none":
        return np.zeros(3)
    trunk = bifurcation.trunk
    axis = (trunk[-1] - trunk[-2]) / np.linalg.norm(trunk[-1] - trunk[-2])
    out = getattr(bifurcation, branch)[0] - trunk[-1]
    across = out - (out @ axis) * axis
    size = float(np.linalg.norm(across))
    if not size > 0:
        raise bad("branch", branch, "a branch that leaves the trunk at an angle (this one continues it)")
    return magnitude * across / size


def navigate(branch: str, *, spec: ManipulatorSpec | None = None, field: float = DEMO_FIELD,
             ramp: float = 0.5, hold: float = 0.5, dt: float = 0.01, settle: float = 0.3,
             progress=None) -> ManipulatorTrajectory:
    """Steer the manipulator's tip into ``branch`` of its bifurcation ('left', 'right', or 'none': no
    field, the control); the run samples every ``dt`` [s] from t = 0 to ramp + hold (``progress``: as
    for ``simulate_manipulator``).

    Parameters
    ----------
    spec : ManipulatorSpec or None
        a manipulator whose ``contact`` holds a ``Bifurcation`` (None: ``navigation_spec()``); with
        ``spec.advance`` the base is inserted meanwhile (ramp + hold should cover its end)
    field : float
        field magnitude [T] (``steering_field``), by the minimum-norm currents at the workspace centre
    ramp, hold, dt, settle : float
        the currents' linear rise and hold [s]; saved interval [s]; settling at zero current before t = 0 [s]

    Returns
    -------
    ManipulatorTrajectory
        the run, with the contact loads
    """
    spec = navigation_spec() if spec is None else spec
    bif = _bifurcation_of(spec)
    for name, value in (("ramp", ramp), ("hold", hold)):
        positive(name, value, "s")
    B = steering_field(bif, branch, field)
    currents = currents_for_field(spec.coils, (0.0, 0.0, 0.0), B)
    n_samples = int(round((ramp + hold) / positive("dt", dt, "s"))) + 1
    schedule = ramp_schedule(currents, ramp, ramp + hold)
    run = ManipulatorRun(dt=dt, n_samples=n_samples, settle=settle)
    return simulate_manipulator(spec, schedule, run, progress=progress)


def ramp_schedule(currents, ramp: float, end: float, start: float = 0.0) -> CurrentSchedule:
    """Currents that are zero until ``start`` [s], rise linearly to ``currents`` (n_c,) [A] over
    ``ramp`` [s] and then hold, as a ``CurrentSchedule`` that covers the run to ``end`` [s].

    Parameters
    ----------
    currents : array-like (n_c,)
        the held coil currents [A]
    ramp : float
        rise time [s], > 0
    end : float
        the run's last time [s] (the schedule holds the currents to it)
    start : float
        time [s] >= 0 at which the rise begins

    Returns
    -------
    CurrentSchedule
        times 0, start (when > 0), start + ramp and end (when later), with the currents there
    """
    held = np.asarray(currents, dtype=float)
    positive("ramp", ramp, "s")
    if isinstance(start, bool) or not isinstance(start, (int, float)) or not math.isfinite(start) or start < 0:
        raise bad("start", start, "a time >= 0 in s")
    times, values = [0.0], [np.zeros_like(held)]
    if start > 0:
        times.append(float(start))
        values.append(np.zeros_like(held))
    times.append(start + ramp)
    values.append(held)
    if end > start + ramp:
        times.append(float(end))
        values.append(held)
    return CurrentSchedule(np.array(times), np.stack(values))


def _bifurcation_of(spec: ManipulatorSpec) -> Bifurcation:
    """The one ``Bifurcation`` among the obstacles of ``spec.contact``."""
    found = [] if spec.contact is None else [o for o in spec.contact.obstacles if isinstance(o, Bifurcation)]
    if len(found) != 1:
        raise bad("spec.contact", f"{len(found)} bifurcations", "a ManipulatorSpec whose contact holds one "
                                                                "Bifurcation (see navigation_spec)")
    return found[0]


def tip_branch(bifurcation: Bifurcation, tip, radius: float = 0.0) -> str:
    """Where a tip at ``tip`` (3,) [m] with rod radius ``radius`` [m] is: 'left' or 'right' (inside
    that branch's tube only), 'trunk' (inside both: the trunk or the junction), or 'wall' (inside
    neither: on a wall, e.g. the carina's crease)."""
    left, right = bifurcation.inside(np.asarray(tip, dtype=float).reshape(1, 3), radius)[0]
    return {(True, False): "left", (False, True): "right", (True, True): "trunk"}.get((bool(left), bool(right)),
                                                                                      "wall")
