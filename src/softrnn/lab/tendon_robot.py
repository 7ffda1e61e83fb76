"""A tendon-driven continuum robot driven by tendon displacements (position-controlled servos):
its quasi-static physics, and the calibration of that physics to a recording.

Model. The backbone has S segments of lengths L_s, each bent with constant curvature (the
piecewise-constant-curvature model, exact for a weightless rod loaded only by its tendons at
the segment ends). Segment s carries ``tendons_per_segment`` tendons, terminated at its end, at
the routing radius r and body-frame angles theta_i (offset rho_i = r (cos theta_i, sin theta_i)).
A tendon of segment e runs through segments 1..e. Its tension tau_i >= 0 bends every segment it
runs through: the bending vector of segment s (curvature times the unit direction toward which it
bends, in the segment's frame) is

    b_s = (1 / EI_s) sum_{i runs through s} tau_i rho_i

and the tendon's path shortens by delta_i = sum_{s <= e(i)} L_s b_s . rho_i. A servo pulls the
tendon in by q_i (the recorded displacement, positive = pulled) through a series spring of
stiffness k (servo, cable, spool) and with a slack c_i to take up first (the tendon's offset):

    tau_i = k max(0, q_i - c_i - delta_i)

A slack tendon carries nothing (the max), which is what lets one servo release while another
pulls. With tau' = tau / k [m], these conditions are the linear complementarity problem
tau' >= 0, w = (I + A) tau' - (q - c) >= 0, tau' . w = 0, with A_ij = sum_{s <= min(e_i, e_j)}
(k L_s / EI_s) rho_i . rho_j symmetric positive semi-definite, so I + A is positive definite and
the solution is unique; it is solved exactly by an active-set method (``_tensions``). The tip is then
the end of the chain of constant-curvature arcs (no twist between segments), plus a marker offset
d along the last tangent, seen from the motion-capture frame through a rigid base pose.

Gravity and friction along the routing (options, ``CalibrationOptions``; solved row by row in order
by ``softrnn.lab.tendon_kernels``, whose docstring has the equations): the backbone's weight bends
every segment by the moment of everything distal to it, from the current shape (a fixed point
with the tensions); a tendon's tension falls along its path as exp(-mu phi), phi the wrap angle
from the base, while it is pulled in, and rises so while it is released (the direction from the
change of its command since the previous row: path dependence, hysteresis). With neither, the rows
are independent and the model is the closed one above.

The tendons' play (an option): friction that sticks, so that after a reversal of a servo the
displacement that reaches the robot stays put until the servo has moved back by twice the play w (the
play operator of ``tendon_kernels.play``, one width for every tendon); q above is then that
displacement. w = 0 is the model without play.

The tendons' creep (an option): under load the tendons lengthen slowly (the cables' and their
anchorages' creep), so every tendon's slack grows with time by the same s(t), at a rate gamma times
the mean tension over the series stiffness (``tendon_kernels``' docstring); q above is then q - s.
The robot's turn with its creep (an option, with creep): the robot turns about its own axis as the
tendons creep, by an angle chi s (the creep slack s above): the torsional creep of the backbone and of
the tendons' anchorages and mount under the same load, which a tendon's lengthening alone does not
show. The tip is turned about the base's axis through the base before the base pose places it.
Creep makes the model depend on the rows' times and on the whole history since the calibration's
first row: ``Calibration`` keeps where the creep stood at each of its rows (``CreepTimeline``), so
that a session recorded within them starts from the slack it had then, and any other from the slack
the calibration's last row left (the robot as its training left it).

What poses alone can identify: only ratios, never a force or a stiffness by itself (no force is
recorded): EI_s / k per segment (bending stiffness over the series stiffness), w / k (the weight per
length over the series stiffness, so w / EI_s = (w / k)(k / EI_s)) with gravity's direction in the
base frame, the friction coefficient mu (and the play w), and the creep rate gamma. What the model
still misses, the calibration report shows as its error, and a learned residual
(``softrnn.lab.families``) takes.

Calibration (``calibrate``): nonlinear least squares (the calibration core's ``multistart``,
``softrnn.fitting``, with a soft-L1 loss against outlying rows) of the tip over every row of the
training sessions, from several starts (the tendons' angular order and the angle between segments
are not known in advance: both orders x twists over a full turn, screened briefly), the best
refined. Parameters: the tendon angles and offsets, the routing radius, EI_s / k per segment, the
marker offset and the base pose; with gravity (w / k)
g_hat (3 values: the weight and its direction), with friction mu, with play w and with creep gamma,
refined from the plain model's calibration (the weight from zero, mu from 0.01, w from 2 % of the
routing radius, gamma from ``_CREEP_START``). Rows without a measured tip (NaN) are run through the
model but not fitted: their commands still load the tendons (creep) and set the friction's state.
With gravity or friction (and neither creep, play nor a turn, which tie the rows together) the
least squares' derivatives come from implicit differentiation of each row's fixed point
(``_TipResidual.jacobian``: a single pass per parameter at the rows' solution), not from differences
of the whole solve: as accurate, and a refinement 3-11 times faster.
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass, field, replace

import numpy as np
from numba import njit
from scipy.spatial.transform import Rotation

from ..errors import SoftrnnInputError, bad, integer, is_finite_number, positive
from ..fitting import StartOptions, multistart
from ..fitting.starts import here
from .tendon_kernels import _lcp, chain_tip, play, session_passes, session_solve, session_tips

LENGTH_UNITS = {"m": 1.0, "mm": 1e-3, "cm": 1e-2}
"""Input units read as tendon displacements, with their factor to m."""


@dataclass(frozen=True)
class TendonRobot:
    """The robot's known geometry.

    Parameters
    ----------
    segment_lengths : tuple of float
        L_s [m] of each segment, base to tip
    tendons_per_segment : int
        tendons of each segment (>= 2); the inputs are the tendon displacements in segment order
    routing_radius : float
        the tendons' distance from the backbone [m] (a start value: the calibration fits it)
    """

    segment_lengths: tuple
    tendons_per_segment: int = 3
    routing_radius: float = 4.5e-3

    def __post_init__(self):
        lengths = tuple(self.segment_lengths) if hasattr(self.segment_lengths, "__iter__") else ()
        if not lengths or not all(is_finite_number(x) and x > 0 for x in lengths):
            raise bad("segment_lengths", self.segment_lengths, "one or more positive lengths in m, base to tip")
        object.__setattr__(self, "segment_lengths", tuple(float(x) for x in lengths))
        integer("tendons_per_segment", self.tendons_per_segment, low=2)
        positive("routing_radius", self.routing_radius, "m")

    @property
    def n_segments(self) -> int:
        """S, the segments."""
        return len(self.segment_lengths)

    @property
    def n_tendons(self) -> int:
        """The tendons (and inputs): S times the tendons per segment."""
        return self.n_segments * self.tendons_per_segment

    @property
    def length(self) -> float:
        """The backbone's length [m]."""
        return float(sum(self.segment_lengths))

    @property
    def segment_of(self) -> np.ndarray:
        """(n_tendons,) the segment (0-based) each tendon terminates at."""
        return np.repeat(np.arange(self.n_segments), self.tendons_per_segment)


@dataclass(frozen=True)
class TendonParameters:
    """Calibrated parameters (SI units).

    Attributes
    ----------
    angles : (n,) [rad]
        tendon angles in the base frame
    offsets : (n,) [m]
        slack to take up before a tendon pulls (c_i)
    routing_radius : float [m]
        the tendons' distance from the backbone
    compliance : (S,) [m^-3]
        k / EI_s per segment (series stiffness over bending stiffness)
    marker : float [m]
        marker offset beyond the last segment, along its tangent
    rotation : (3,) [rad]
        base orientation in the motion-capture frame (rotation vector)
    base : (3,) [m]
        base position in the motion-capture frame
    gravity : (3,) or None
        (w / k) g_hat: the backbone's weight per length over the series stiffness (dimensionless)
        times the unit direction of gravity in the base frame; None: no gravity in the model
    friction : float or None
        mu, the friction coefficient along the routing (capstan); None: no friction in the model
    play : float or None
        w [m], every tendon's play: after a reversal of its servo the displacement that reaches the
        robot stays put until the servo has moved 2 w (``tendon_kernels.play``); None: no play
    creep : float or None
        gamma [1/s], the creep rate: every tendon's slack grows at gamma times the mean tension over the
        series stiffness (``tendon_kernels``); None: no creep
    twist : float or None
        chi [rad/m], the robot's turn about its axis per metre of creep slack (with creep); None: no turn
    """

    angles: np.ndarray
    offsets: np.ndarray
    routing_radius: float
    compliance: np.ndarray
    marker: float
    rotation: np.ndarray
    base: np.ndarray
    gravity: np.ndarray | None = None
    friction: float | None = None
    play: float | None = None
    creep: float | None = None
    twist: float | None = None

    @property
    def plain(self) -> bool:
        """True without gravity, friction and creep (the closed model of the module's docstring, after the
        play): the rows are independent."""
        return self.gravity is None and self.friction is None and self.creep is None and self.twist is None

    def routing(self) -> np.ndarray:
        """(n, 2) [m] each tendon's position in the cross-section, r (cos theta_i, sin theta_i)."""
        return self.routing_radius * np.stack([np.cos(self.angles), np.sin(self.angles)], axis=1)

    def gravity_vector(self) -> np.ndarray:
        """(3,) (w / k) g_hat in the base frame, zeros without gravity in the model."""
        return np.zeros(3) if self.gravity is None else np.asarray(self.gravity, dtype=float)

    def in_tracker(self, points: np.ndarray) -> np.ndarray:
        """points (K, 3) [m] in the base frame placed in the motion-capture frame by the base pose."""
        return points @ _rotations(self.rotation).T + self.base

    def to_dict(self, robot: TendonRobot) -> dict:
        """JSON-ready, in mm and degrees, with the stiffness ratio k r^2 L_s / EI_s per segment."""
        ratio = [float(self.compliance[s] * self.routing_radius ** 2 * L)
                 for s, L in enumerate(robot.segment_lengths)]
        wrapped = np.angle(np.exp(1j * self.angles))          # in (-pi, pi]
        extra = {}
        if self.gravity is not None:
            weight = float(np.linalg.norm(self.gravity))
            g_hat = self.gravity / weight if weight > 0 else np.zeros(3)
            extra.update(weight_over_series_stiffness=float(f"{weight:.6g}"),
                         gravity_direction_base=g_hat.round(6).tolist(),
                         gravity_direction_tracker=(_rotations(self.rotation) @ g_hat).round(6).tolist())
        if self.friction is not None:
            extra["routing_friction"] = round(float(self.friction), 6)
        if self.play is not None:
            extra["tendon_play_mm"] = round(float(self.play) * 1e3, 6)
        if self.creep is not None:
            extra["creep_rate_per_s"] = float(f"{self.creep:.6g}")
        if self.twist is not None:
            extra["creep_turn_deg_per_mm"] = round(math.degrees(self.twist) * 1e-3, 6)
        return {"tendon_angles_deg": np.degrees(wrapped).round(3).tolist(),
                "tendon_offsets_mm": (self.offsets * 1e3).round(4).tolist(),
                "routing_radius_mm": round(self.routing_radius * 1e3, 4),
                "bending_over_series_stiffness_m3": [float(f"{1.0 / c:.6g}") for c in self.compliance],
                "stiffness_ratio_k_r2_L_over_EI": [float(f"{x:.6g}") for x in ratio],
                "marker_offset_mm": round(self.marker * 1e3, 4),
                "base_rotation_deg": np.degrees(self.rotation).round(4).tolist(),
                "base_position_mm": (self.base * 1e3).round(4).tolist(), **extra}

    @classmethod
    def from_dict(cls, d: dict) -> TendonParameters:
        """The parameters from ``to_dict``'s output."""
        return cls(angles=np.radians(d["tendon_angles_deg"]), offsets=np.asarray(d["tendon_offsets_mm"]) * 1e-3,
                   routing_radius=d["routing_radius_mm"] * 1e-3,
                   compliance=1.0 / np.asarray(d["bending_over_series_stiffness_m3"], dtype=float),
                   marker=d["marker_offset_mm"] * 1e-3, rotation=np.radians(d["base_rotation_deg"]),
                   base=np.asarray(d["base_position_mm"]) * 1e-3,
                   gravity=(d["weight_over_series_stiffness"] * np.asarray(d["gravity_direction_base"], dtype=float)
                            if "weight_over_series_stiffness" in d else None),
                   friction=d.get("routing_friction"),
                   play=d["tendon_play_mm"] * 1e-3 if "tendon_play_mm" in d else None,
                   creep=d.get("creep_rate_per_s"),
                   twist=math.radians(d["creep_turn_deg_per_mm"]) * 1e3 if "creep_turn_deg_per_mm" in d else None)


# ------------------------------------------------------------------------------------------ physics
@njit(cache=True)
def _tensions(M, b, out):
    """The LCP tau >= 0, M tau - b >= 0, tau (M tau - b) = 0 for each row of b (K, n), M (n, n)
    positive definite, into out (K, n) [m]: each row solved exactly by ``tendon_kernels``' active-set
    solve (which tendons are taut, corrected one at a time; projected Gauss-Seidel where that does not
    settle), warm-started from the row before's tensions."""
    K, n = b.shape
    tau = np.zeros(n)
    active = np.empty(n, dtype=np.bool_)
    A = np.empty((n, n + 1))
    idx = np.empty(n, dtype=np.int64)
    for k in range(K):
        _lcp(M, b[k], tau, active, A, idx)
        for i in range(n):
            out[k, i] = tau[i]


@njit(cache=True)
def _arcs(tau, rho, seg, L, compliance, marker, x):
    """The tip (K, 3) [m] in the base frame into ``x``: the chain of constant-curvature arcs
    (``tendon_kernels.chain_tip``) of the segments, each bent by compliance_s sum over the tendons
    that reach it (``seg`` (n,) >= s) of tau_i rho_i (tau (K, n) [m], rho (n, 2) [m], L (S,) [m]),
    plus ``marker`` [m] along the last tangent."""
    K, n = tau.shape
    S = L.size
    b = np.empty((S, 2))
    frames = np.empty((2, 3, 3))
    points = np.empty((2, 3))
    for k in range(K):
        for s in range(S):
            bx, by = 0.0, 0.0
            for i in range(n):
                if seg[i] >= s:
                    bx += tau[k, i] * rho[i, 0]
                    by += tau[k, i] * rho[i, 1]
            b[s, 0] = compliance[s] * bx
            b[s, 1] = compliance[s] * by                           # bending (2,) [1/m]
        chain_tip(b, L, marker, frames, points, x[k])


def _rotations(axis_angle: np.ndarray) -> np.ndarray:
    return Rotation.from_rotvec(axis_angle).as_matrix()


def tip_positions(robot: TendonRobot, params: TendonParameters, q: np.ndarray,
                  resets: np.ndarray | None = None, times: np.ndarray | None = None,
                  slack: float = 0.0) -> tuple[np.ndarray, np.ndarray]:
    """The tip (K, 3) [m] in the motion-capture frame and the tensions over the series
    stiffness tau / k (K, n) [m] (at the base) for tendon displacements q (K, n) [m]. With gravity,
    friction or creep (``params``), the rows are solved in order (``solve_rows``): ``resets`` (K,) bool
    marks the rows where a session starts (default: the first row only); with creep, ``times`` (K,) [s]
    are the rows' times and ``slack`` [m] the creep slack at the first row."""
    if not params.plain:
        tip, tau, _, _, _ = solve_rows(robot, params, q, resets, times, slack)
        return tip, tau
    q = reached(params, q, resets)
    seg = robot.segment_of
    L = np.asarray(robot.segment_lengths)
    rho = params.routing()
    cum = np.cumsum(L * params.compliance)
    A = cum[np.minimum(seg[:, None], seg[None, :])] * (rho @ rho.T)
    M = np.eye(robot.n_tendons) + A
    tau = np.empty_like(q)
    _tensions(M, np.ascontiguousarray(q - params.offsets), tau)
    x = np.empty((q.shape[0], 3))
    _arcs(tau, rho, seg, L, np.asarray(params.compliance, dtype=float), float(params.marker), x)
    return params.in_tracker(x), tau


def _reset_rows(resets: np.ndarray | None, K: int) -> np.ndarray:
    """(K,) bool: the rows where a session starts (``resets``; None: none marked, the kernels start the first)."""
    return np.zeros(K, dtype=np.bool_) if resets is None else np.asarray(resets, dtype=np.bool_)


def reached(params: TendonParameters, q: np.ndarray, resets: np.ndarray | None = None) -> np.ndarray:
    """The displacements (K, n) [m] that reach the robot for the commands q (K, n) [m]: q through every
    tendon's play ``params.play`` (``tendon_kernels.play``, restarted where ``resets`` (K,) bool is
    True; default: the first row only), q itself without play."""
    q = np.ascontiguousarray(q, dtype=float)
    if params.play is None:
        return q
    out = np.empty_like(q)
    reset = _reset_rows(resets, len(q))
    play(q, reset, np.full(q.shape[1], float(params.play)), out)
    return out


def solve_rows(robot: TendonRobot, params: TendonParameters, q: np.ndarray, resets: np.ndarray | None = None,
               times: np.ndarray | None = None, slack: float = 0.0) -> tuple:
    """The fuller physics (gravity, friction and creep, ``softrnn.lab.tendon_kernels``; after the play,
    ``reached``) row by row in order.

    Returns the tip (K, 3) [m] in the motion-capture frame, tau / k (K, n) [m] at the base, the
    segments' bending vectors (K, S, 2) [1/m], the fixed-point passes (K,) of each row (negated where
    the row did not settle, ``tendon_kernels``) and the creep slack (K,) [m] each row saw (zeros without
    creep); ``resets`` (K,) bool marks the rows where a session starts (default: the first row only);
    with creep, ``times`` (K,) [s] are the rows' times (``row_intervals``) and ``slack`` [m] the creep
    slack at the first row.
    """
    q = reached(params, q, resets)
    K, n = q.shape
    reset = _reset_rows(resets, K)
    if params.creep is None:
        rate, dt, slack = 0.0, np.zeros(K), 0.0
    elif times is None:
        raise bad("times", None, "the rows' times [s]: the tendons' creep runs in time")
    else:
        rate, dt = float(params.creep), row_intervals(times, reset)
    tips, tau = np.empty((K, 3)), np.empty((K, n))
    bend, passes, seen = np.empty((K, robot.n_segments, 2)), np.empty(K, dtype=np.int64), np.empty(K)
    session_solve(q, reset, robot.segment_of, np.asarray(robot.segment_lengths), np.asarray(params.compliance, float),
                  params.routing(), np.asarray(params.offsets, float), float(params.friction or 0.0),
                  params.gravity_vector(), float(params.marker),
                  rate, dt, float(slack), tips, tau, bend, passes, seen)
    if params.twist is not None:
        tips = _turned(tips, params.twist * seen)
    return params.in_tracker(tips), tau, bend, passes, seen


def _turned(points: np.ndarray, angle: np.ndarray) -> np.ndarray:
    """points (K, 3) [m] in the base frame turned about its axis (z) by ``angle`` (K,) [rad], row by row."""
    c, s = np.cos(angle), np.sin(angle)
    return np.stack([c * points[:, 0] - s * points[:, 1], s * points[:, 0] + c * points[:, 1], points[:, 2]], axis=1)


def row_intervals(times: np.ndarray, reset: np.ndarray) -> np.ndarray:
    """(K,) [s] how long each row's load acts before the next row: the time to the next row of the same
    session, 0 at a session's last row (``reset`` (K,) bool, True at each session's first row; no
    creep across the gap between two sessions)."""
    times = np.asarray(times, dtype=float)
    dt = np.zeros(times.size)
    dt[:-1] = np.diff(times)
    dt[:-1][np.asarray(reset, dtype=bool)[1:]] = 0.0
    return np.maximum(dt, 0.0)


def session_resets(lengths) -> np.ndarray:
    """(sum of lengths,) bool: True at the first row of each of the stacked sessions of ``lengths`` rows."""
    reset = np.zeros(int(sum(lengths)), dtype=bool)
    reset[np.cumsum([0, *lengths[:-1]]).astype(int)] = True
    return reset


# -------------------------------------------------------------------------------------- calibration
PHYSICS_OPTIONS = ("gravity", "friction", "play", "creep", "twist")
"""The parts ``CalibrationOptions`` adds to the plain model, each a bool, in the order of a variant's name."""


@dataclass(frozen=True)
class CalibrationOptions(StartOptions):
    """How ``calibrate`` searches (``softrnn.fitting.StartOptions``): the starts are the angular
    layouts (both orders of the tendons, x ``twists`` twists between segments spread over a full
    turn), each screened with ``screen_evaluations``, the best ``screen_keep`` fitted on with
    ``quick_evaluations``, the best ``refine`` of those refined with ``evaluations``; ``loss_scale`` [m], where the
    soft-L1 loss turns from quadratic to linear (rows farther off than this count less).
    ``gravity`` and ``friction`` add the backbone's weight (its direction fitted) and friction
    along the routing (mu in 0..``friction_max``) to the model, ``play`` every tendon's play (one width w
    for all, 0..pi x the routing radius), ``creep`` the tendons' creep (its rate gamma in 0..``_CREEP_MAX``;
    the rows' times needed), ``twist`` with creep the robot's turn about its axis as it creeps (chi in
    +-``_TWIST_MAX``): the plain model is calibrated first, then everything is refined from there
    with them (``variant_evaluations``). All off (the default): the plain model alone."""

    screen_evaluations: int = 20
    screen_keep: int = 6
    twists: int = 18
    loss_scale: float = 10e-3
    gravity: bool = False
    friction: bool = False
    play: bool = False
    creep: bool = False
    twist: bool = False
    friction_max: float = 0.5
    variant_evaluations: int = 150

    def __post_init__(self):
        super().__post_init__()
        positive("loss_scale", self.loss_scale, "m")
        for name in PHYSICS_OPTIONS:
            if not isinstance(getattr(self, name), bool):
                raise bad(name, getattr(self, name), "True or False")
        if self.twist and not self.creep:
            raise bad("twist", self.twist, "twist=True with creep=True: the robot turns as its tendons creep")
        if not is_finite_number(self.friction_max) or not 0.0 < self.friction_max <= 2.0:
            raise bad("friction_max", self.friction_max, "a friction coefficient in (0, 2]")
        integer("variant_evaluations", self.variant_evaluations)
        integer("twists", self.twists)

    @property
    def variant(self) -> str:
        """``plain``, or those of ``gravity``, ``friction``, ``play``, ``creep`` and ``twist`` on, joined by ``+``."""
        return "+".join(n for n in PHYSICS_OPTIONS if getattr(self, n)) or "plain"


@dataclass(frozen=True, eq=False)
class CreepTimeline:
    """Where the tendons' creep stood along a calibration's rows, so that a prediction starts from the
    slack its session had.

    Attributes
    ----------
    times : (K,) [s]
        the calibration's rows' times, in its rows' order
    q : (K, n) [m]
        their tendon displacements
    slack : (K,) [m]
        the creep slack each of those rows saw
    end : float [m]
        the slack the last row left: the robot as its training left it
    """

    times: np.ndarray
    q: np.ndarray
    slack: np.ndarray
    end: float

    def at(self, times: np.ndarray, q: np.ndarray) -> float:
        """The slack [m] at the first row of a session of rows at ``times`` (T,) [s] with displacements
        ``q`` (T, n) [m]: that of the calibration's run of rows with the same times and displacements (a
        session, or a stretch of one, that the calibration ran through); else, where the calibration's
        rows share one clock (their times in order) and the session lies before the first of them or
        between two (no row of the calibration within its span), that of the first row after it: creep
        only grows, and the robot had crept no further then; else ``end``: a session recorded after the
        calibration's rows, or on a clock of its own (its span holds rows of the calibration that are
        not its own: times that start again from zero in each session, say), runs on the robot as the
        training left it."""
        times, q = np.asarray(times, dtype=float), np.asarray(q, dtype=float)
        for j in np.flatnonzero(self.times == times[0]):
            m = min(times.size, self.times.size - j)
            if np.array_equal(self.times[j:j + m], times[:m]) and np.array_equal(self.q[j:j + m], q[:m]):
                return float(self.slack[j])
        own = self.times
        if own.size and np.all(np.diff(own) >= 0.0) and times[0] <= own[-1]:
            after = int(np.searchsorted(own, times[0]))
            if own[after] > times[-1]:
                return float(self.slack[after])
        return self.end

    def to_dict(self) -> dict:
        """JSON-ready: the slack at the first and the last row [mm]."""
        return {"creep_slack_first_row_mm": round(float(self.slack[0]) * 1e3, 4) if self.slack.size else 0.0,
                "creep_slack_end_mm": round(self.end * 1e3, 4)}


@dataclass(frozen=True)
class Calibration:
    """A calibrated tendon robot: ``robot``, ``params``, the tip RMSE on the fitted rows [m]
    (Euclidean), what the search tried (``starts``: one dict per start) and, with creep, where it
    stood along the fitted rows (``timeline``, ``CreepTimeline``; None without creep)."""

    robot: TendonRobot
    params: TendonParameters
    rmse_m: float
    starts: tuple
    seconds: float
    timeline: CreepTimeline | None = None

    def predict(self, q: np.ndarray, resets: np.ndarray | None = None, times: np.ndarray | None = None) -> np.ndarray:
        """The tip (K, 3) [m] for tendon displacements q (K, n) [m], the rows of one session in order
        (friction reads each tendon's previous row; ``resets`` (K,) bool marks where another starts);
        with creep, ``times`` (K,) [s] are the rows' times and the session starts from the slack the
        calibration's timeline gives its first row (``CreepTimeline.at``)."""
        slack = 0.0 if self.timeline is None or times is None else self.timeline.at(times, q)
        return tip_positions(self.robot, self.params, q, resets, times, slack)[0]

    def to_dict(self) -> dict:
        """JSON-ready: the model, the segments, the parameters, the fit and the starts tried."""
        extra = "".join(t for t, on in ((", gravity", self.params.gravity is not None),
                                        (", friction along the routing (capstan)", self.params.friction is not None),
                                        (", tendon play", self.params.play is not None),
                                        (", tendon creep", self.params.creep is not None),
                                        (", the robot's turn with its creep", self.params.twist is not None))
                        if on)
        return {"model": "piecewise-constant-curvature tendon robot, displacement-driven with series stiffness "
                         f"and slack{extra} (softrnn.lab.tendon_robot)",
                "segment_lengths_m": list(self.robot.segment_lengths),
                "tendons_per_segment": self.robot.tendons_per_segment,
                "parameters": self.params.to_dict(self.robot),
                "fit_tip_rmse_mm": round(self.rmse_m * 1e3, 4), "starts": list(self.starts),
                "seconds": round(self.seconds, 2)} | ({} if self.timeline is None else self.timeline.to_dict())


_GRAVITY_UNIT = 1e-4
"""The internal unit of w / k in the least squares."""
_CREEP_UNIT = 1e-3
"""The internal unit of the creep rate [1/s] in the least squares (per 1000 s)."""
_CREEP_START = 0.1
_CREEP_MAX = 20.0
"""The creep rate's start and upper bound [``_CREEP_UNIT``]: at the bound, a tendon pulled to 1 mm past its
slack lengthens by 20 mm in 1000 s, far beyond any cable's creep."""
_TWIST_UNIT = math.radians(1.0) * 1e3
"""The internal unit of the turn with creep [rad/m] in the least squares (degrees per mm of creep slack)."""
_TWIST_MAX = 90.0
"""The turn's bound [``_TWIST_UNIT``]: a quarter turn per mm of creep slack."""


def pack(p: TendonParameters) -> np.ndarray:
    """The parameters as the calibration's vector (what its least squares fits; ``_bounds``): in mm and rad,
    the compliance's log (well scaled), then gravity, friction, play, creep and the turn where ``p`` has
    them. Equal parameters pack to equal vectors, so its bytes key a calibration."""
    extra = ([] if p.gravity is None else list(np.asarray(p.gravity) / _GRAVITY_UNIT)) + \
        ([] if p.friction is None else [p.friction]) + ([] if p.play is None else [p.play * 1e3]) + \
        ([] if p.creep is None else [p.creep / _CREEP_UNIT]) + ([] if p.twist is None else [p.twist / _TWIST_UNIT])
    # a compliance that underflowed to 0 (a segment the rows leave free, fitted rigid) packs as the smallest one
    log_compliance = np.log(np.maximum(np.asarray(p.compliance, dtype=float) * 1e-9, np.finfo(float).tiny))
    return np.concatenate([p.angles, p.offsets * 1e3, [p.routing_radius * 1e3], log_compliance,
                           [p.marker * 1e3], p.rotation, p.base * 1e3, extra])


def _unpack(x: np.ndarray, robot: TendonRobot, gravity: bool = False, friction: bool = False,
            play: bool = False, creep: bool = False, twist: bool = False) -> TendonParameters:
    n, S = robot.n_tendons, robot.n_segments
    end = 2 * n + 8 + S
    turn = end + 3 * gravity + friction + play + creep
    return TendonParameters(angles=x[:n], offsets=x[n:2 * n] * 1e-3, routing_radius=x[2 * n] * 1e-3,
                            compliance=np.exp(x[2 * n + 1:2 * n + 1 + S]) * 1e9, marker=x[2 * n + 1 + S] * 1e-3,
                            rotation=x[2 * n + 2 + S:2 * n + 5 + S], base=x[2 * n + 5 + S:end] * 1e-3,
                            gravity=x[end:end + 3] * _GRAVITY_UNIT if gravity else None,
                            friction=float(x[end + 3 * gravity]) if friction else None,
                            play=float(x[end + 3 * gravity + friction]) * 1e-3 if play else None,
                            creep=float(x[end + 3 * gravity + friction + play]) * _CREEP_UNIT if creep else None,
                            twist=float(x[turn]) * _TWIST_UNIT if twist else None)


def _variant_start(start: TendonParameters, options: CalibrationOptions, robot: TendonRobot) -> TendonParameters:
    """``start`` with the gravity, friction, play, creep and turn of ``options`` (none yet: no weight, mu 0.01,
    a play of ``_PLAY_START`` x the routing radius, a creep rate of ``_CREEP_START``, no turn), or without."""
    gravity = (np.zeros(3) if start.gravity is None else start.gravity) if options.gravity else None
    friction = (0.01 if start.friction is None else min(start.friction, 0.99 * options.friction_max)) \
        if options.friction else None
    play = (_PLAY_START * robot.routing_radius if start.play is None else min(start.play, _play_max(robot))) \
        if options.play else None
    creep = (_CREEP_START * _CREEP_UNIT if start.creep is None else min(start.creep, _CREEP_MAX * _CREEP_UNIT)) \
        if options.creep else None
    twist = (0.0 if start.twist is None else float(np.clip(start.twist, -_TWIST_MAX * _TWIST_UNIT,
                                                           _TWIST_MAX * _TWIST_UNIT))) if options.twist else None
    return replace(start, gravity=gravity, friction=friction, play=play, creep=creep, twist=twist)


_PLAY_START = 0.02
"""The play's start [routing radii] (a small play: the least squares see its effect from both sides)."""


def _play_max(robot: TendonRobot) -> float:
    """The largest play [m]: pi x the routing radius (a pull that bends a segment by half a turn)."""
    return math.pi * robot.routing_radius


def _base_guess(robot: TendonRobot, q: np.ndarray, tip: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Start values of the base pose: the backbone axis is the coordinate whose spread is most
    one-sided (bending only ever shortens the tip's reach along it), pointing to its long end;
    the base lies one robot length behind the tip of the least-actuated row."""
    centred = tip - np.median(tip, axis=0)
    skew = np.mean(centred ** 3, axis=0) / np.maximum(np.mean(centred ** 2, axis=0), 1e-30) ** 1.5
    axis = int(np.argmax(np.abs(skew)))
    direction = np.zeros(3)
    direction[axis] = -np.sign(skew[axis]) or 1.0
    rest = tip[int(np.argmin(np.sum(np.maximum(q, 0.0) ** 2, axis=1)))]
    z = np.array([0.0, 0.0, 1.0])
    cross = np.cross(z, direction)
    if np.linalg.norm(cross) < 1e-12:
        rotation = np.zeros(3) if direction[2] > 0 else np.array([math.pi, 0.0, 0.0])
    else:
        rotation = cross / np.linalg.norm(cross) * math.acos(np.clip(direction @ z, -1, 1))
    return rotation, rest - direction * robot.length


def _starts(robot: TendonRobot, twists: int) -> list[tuple[int, float]]:
    """(order sign, segment twist [deg]): both tendon orders x ``twists`` twists in [-180, 180) deg
    (the tendons are told apart by their hardware order, so any twist in a full turn is a different
    layout); one twist (0) for a robot of one segment."""
    grid = np.arange(twists if robot.n_segments > 1 else 1) * 360.0 / twists
    return [(sign, float(twist)) for twist in np.where(grid >= 180.0, grid - 360.0, grid) for sign in (1, -1)]


ROUTING_RANGE = (0.2, 5.0)
"""The routing radii the calibration fits, as multiples of the robot's (its start value, ``TendonRobot``)."""


def _bounds(robot: TendonRobot, options: CalibrationOptions) -> tuple[np.ndarray, np.ndarray]:
    """(lower, upper) of the packed parameters (``pack``) for ``options``' variant."""
    n, S = robot.n_tendons, robot.n_segments
    inf = np.inf
    lower = np.concatenate([np.full(n, -inf), np.full(n, -inf), [ROUTING_RANGE[0] * robot.routing_radius * 1e3],
                            np.full(S, -inf), [0.0], np.full(3, -inf), np.full(3, -inf),
                            np.full(3 * options.gravity, -inf), np.zeros(int(options.friction)),
                            np.zeros(int(options.play)), np.zeros(int(options.creep)),
                            np.full(int(options.twist), -_TWIST_MAX)])
    upper = np.concatenate([np.full(n, inf), np.full(n, inf), [ROUTING_RANGE[1] * robot.routing_radius * 1e3],
                            np.full(S, inf), [0.5 * robot.length * 1e3], np.full(3, inf), np.full(3, inf),
                            np.full(3 * options.gravity, inf), np.full(int(options.friction), options.friction_max),
                            np.full(int(options.play), _play_max(robot) * 1e3),
                            np.full(int(options.creep), _CREEP_MAX), np.full(int(options.twist), _TWIST_MAX)])
    return lower, upper


def calibrate(robot: TendonRobot, q: np.ndarray, tip: np.ndarray, options: CalibrationOptions = CalibrationOptions(),
              progress=None, start: TendonParameters | None = None, resets: np.ndarray | None = None, spread=here,
              pieces: int = 1, times: np.ndarray | None = None) -> Calibration:
    """Fit the robot's parameters to tendon displacements q (K, n) [m] and tips (K, 3) [m]
    (every row of the training sessions, in order; ``resets`` (K,) bool marks where each session
    starts, ``session_resets``; a row whose tip is NaN is run but not fitted). ``progress(done, total)``
    after each start. With ``start`` (e.g. a calibration on part of the rows), only the refinement runs,
    from there. With gravity, friction, play or creep (``options``) and no ``start``, the plain model is
    calibrated first (its search on the closed model, faster) and everything refined from there. With
    creep, ``times`` (K,) [s] are the rows' times. ``spread`` and ``pieces``: where the search's fits run
    (``softrnn.fitting.multistart``; e.g. a pool's workers); the result is the same to the bit."""
    q = np.asarray(q, dtype=float)
    tip = np.asarray(tip, dtype=float)
    if q.ndim != 2 or q.shape[1] != robot.n_tendons:
        raise SoftrnnInputError(f"the recording has {q.shape[-1]} inputs but the robot {robot.n_segments} segments "
                                f"x {robot.tendons_per_segment} tendons = {robot.n_tendons}; give --segments and "
                                "--tendons-per-segment that match the input columns (segment order)")
    if options.creep and (times is None or np.shape(times) != (q.shape[0],)):
        raise bad("times", None if times is None else np.shape(times), f"the {q.shape[0]} rows' times [s]: the "
                                                                       "tendons' creep runs in time")
    t0 = time.perf_counter()
    earlier = ()
    if options.variant != "plain" and start is None:
        plain = _search(robot, q, tip, replace(options, **dict.fromkeys(PHYSICS_OPTIONS, False)), progress, None,
                        resets, spread=spread, pieces=pieces)
        start, earlier = plain.params, plain.starts
    if start is not None:
        start = _variant_start(start, options, robot)
    if options.variant != "plain":
        options = replace(options, evaluations=options.variant_evaluations)
    found = _search(robot, q, tip, options, progress, start, resets, label="the plain model's"
                    if earlier else "given", spread=spread, pieces=pieces, times=times)
    timeline = None
    if found.params.creep is not None:
        seen = solve_rows(robot, found.params, q, resets, times)[4]
        # the last row's load acts for no time (no row follows it): the training leaves the slack it saw
        timeline = CreepTimeline(times=np.asarray(times, dtype=float).copy(), q=q.copy(), slack=seen,
                                 end=float(seen[-1]))
    return replace(found, starts=earlier + found.starts, seconds=time.perf_counter() - t0, timeline=timeline)


@dataclass(frozen=True, eq=False)
class _TipResidual:
    """The calibration's residual: the model's tips minus the measured ones (K * 3,) [mm] at packed
    parameters x; ``flags``: ((option, bool), ...) of ``PHYSICS_OPTIONS``. A class, so that it pickles
    (``multistart``'s ``spread``)."""

    robot: TendonRobot
    q: np.ndarray
    tip: np.ndarray
    resets: np.ndarray | None
    flags: tuple
    times: np.ndarray | None = None
    fitted: np.ndarray | None = None
    """(K,) bool: the rows whose tips are fitted (None: all); the others are run (creep, friction) only."""
    upper: np.ndarray | None = None
    """(p,) the packed parameters' upper bounds: ``jacobian``'s differences step back from them."""
    last: dict = field(default_factory=dict, repr=False)
    """With ``implicit``: the rows' solution (tau / k, bending vectors) at the x of the last call, which the
    optimiser then asks the derivatives at (``jacobian``)."""

    def _params(self, x: np.ndarray) -> TendonParameters:
        # a trial step's compliance beyond any float (the solver rejects it) or below the smallest (0: rigid)
        with np.errstate(over="ignore", under="ignore"):
            return _unpack(x, self.robot, **dict(self.flags))

    def __call__(self, x: np.ndarray) -> np.ndarray:
        if not self.implicit:
            return self._residual(tip_positions(self.robot, self._params(x), self.q, self.resets, self.times)[0])
        tips, tau, bend, _, _ = solve_rows(self.robot, self._params(x), self.q, self.resets, self.times)
        self.last.clear()
        self.last[x.tobytes()] = (tau, bend)
        return self._residual(tips)

    def _residual(self, tips: np.ndarray) -> np.ndarray:
        """(K * 3,) [mm] the fitted rows' tips (K, 3) [m] minus the measured ones."""
        if self.fitted is not None:
            tips = tips[self.fitted]
        return ((tips - self.tip) * 1e3).ravel()

    @property
    def implicit(self) -> bool:
        """Whether ``jacobian`` applies: each row a fixed point solved by passes (gravity or friction) and
        the rows independent of each other's tips (no creep, play or turn)."""
        flags = dict(self.flags)
        return bool(flags.get("gravity") or flags.get("friction")) and not any(
            flags.get(name) for name in ("creep", "play", "twist"))

    def jacobian(self, x: np.ndarray) -> np.ndarray:
        """(K * 3, p) the residual's derivatives at x by implicit differentiation of each row's fixed point
        b = G(b; x) (``implicit``): db/dx = (I - dG/db)^-1 dG/dx, both from single passes
        (``tendon_kernels.session_passes``) at the rows' solution, differenced with ``least_squares``' own
        2-point steps (sqrt(eps) max(1, |x_j|) with x_j's sign, backward where it would pass ``upper``), and
        the tip moved along (h e_j, h db/dx_j). A difference of the whole solve converges each perturbed row
        from the previous row again (several passes, each to the passes' tolerance, which a step of
        sqrt(eps) barely exceeds); this costs one pass per parameter and per bending component."""
        robot, p0 = self.robot, self._params(x)
        if x.tobytes() not in self.last:
            self(x)
        tau, bend = self.last[x.tobytes()]
        reset = _reset_rows(self.resets, self.q.shape[0])
        K, S = bend.shape[0], robot.n_segments

        def passes(params, b):
            b = np.ascontiguousarray(b.reshape(K, S, 2))
            out = np.empty_like(b)
            session_passes(np.ascontiguousarray(self.q), reset, robot.segment_of, np.asarray(robot.segment_lengths),
                           np.asarray(params.compliance, float), params.routing(), np.asarray(params.offsets, float),
                           float(params.friction or 0.0), params.gravity_vector(), b, tau, out)
            return out.reshape(K, 2 * S)

        def tips(params, b):
            out = np.empty((K, 3))
            session_tips(np.ascontiguousarray(b.reshape(K, S, 2)), np.asarray(robot.segment_lengths),
                         float(params.marker), out)
            return params.in_tracker(out)

        g0, flat = passes(p0, bend), bend.reshape(K, 2 * S)
        G_b = np.empty((K, 2 * S, 2 * S))
        for c in range(2 * S):
            h = _FD_STEP * max(1.0, float(np.abs(flat[:, c]).max()))
            moved = flat.copy()
            moved[:, c] += h
            G_b[:, :, c] = (passes(p0, moved) - g0) / h
        upper = np.full(x.size, np.inf) if self.upper is None else self.upper
        points = []                                                     # (x_j, its step, its parameters)
        for j in range(x.size):
            h = _FD_STEP * (1.0 if x[j] >= 0 else -1.0) * max(1.0, abs(x[j]))
            xj = x.copy()
            xj[j] = x[j] + (h if x[j] + h <= upper[j] else -h)
            points.append((xj, xj[j] - x[j], self._params(xj)))
        G_x = np.stack([(passes(pj, flat) - g0) / step for _, step, pj in points], axis=2)
        try:
            db = np.linalg.solve(np.eye(2 * S) - G_b, G_x)              # (K, 2S, p)
        except np.linalg.LinAlgError:   # a row at a fork of its fixed point (a buckling trial): whole solves
            f0 = self(x)
            return np.stack([(self(xj) - f0) / step for xj, step, _ in points], axis=1)
        t0 = self._residual(tips(p0, flat))
        return np.stack([(self._residual(tips(pj, flat + step * db[:, :, j])) - t0) / step
                         for j, (_, step, pj) in enumerate(points)], axis=1)


_FD_STEP = float(np.finfo(float).eps) ** 0.5
"""The differences' relative step (``_TipResidual.jacobian``): ``least_squares``' own."""


def _rmse_mm(fun: np.ndarray) -> float:
    """The tip RMSE [mm] of a residual (K * 3,) [mm]."""
    return float(np.sqrt(np.mean(np.sum(fun.reshape(-1, 3) ** 2, axis=1))))


def _search(robot: TendonRobot, q: np.ndarray, tip: np.ndarray, options: CalibrationOptions, progress,
            start: TendonParameters | None, resets, label: str = "given", spread=here,
            pieces: int = 1, times: np.ndarray | None = None) -> Calibration:
    """``calibrate``'s multi-start search (``start`` None) or refinement from ``start``; ``spread`` and
    ``pieces`` as ``multistart``'s."""
    measured = np.all(np.isfinite(tip), axis=1)
    if not measured.any():
        raise bad("tip", "no finite row", "at least one row with a measured tip to fit")
    fitted = None if measured.all() else measured
    rotation, base = _base_guess(robot, q[measured], tip[measured])
    n, S = robot.n_tendons, robot.n_segments
    scale = options.loss_scale * 1e3
    flags = {name: getattr(options, name) for name in PHYSICS_OPTIONS}
    bounds = _bounds(robot, options)
    residual = _TipResidual(robot, q, tip[measured], resets, tuple(flags.items()), times, fitted, bounds[1])
    starts = []
    for sign, twist in _starts(robot, options.twists) if start is None else []:
        angles = np.radians(sign * np.tile(np.arange(robot.tendons_per_segment) * 360.0 / robot.tendons_per_segment,
                                           S) + np.repeat(np.arange(S) * twist, robot.tendons_per_segment))
        # compliance start: the tendons as stiff as the backbone's bending over one segment
        guess = TendonParameters(angles=angles, offsets=np.zeros(n), routing_radius=robot.routing_radius,
                                 compliance=np.full(S, 1.0 / (robot.routing_radius ** 2 * robot.length / S)),
                                 marker=0.0, rotation=rotation, base=base)
        starts.append(({"tendon_order": "counter-clockwise" if sign > 0 else "clockwise",
                        "segment_twist_deg": twist}, pack(guess)))
    resume = None if start is None else ({"tendon_order": label, "segment_twist_deg": None}, pack(start))
    t0 = time.perf_counter()
    jac = {"jac": residual.jacobian} if residual.implicit else {}     # rows solved by passes: implicit derivatives
    found = multistart(residual, starts, bounds, options=options, score=_rmse_mm, key="rmse_mm",
                       resume=resume, progress=progress, spread=spread, pieces=pieces, loss="soft_l1", f_scale=scale,
                       x_scale="jac", **jac)
    starts_out = tuple({key: (round(v, 4) if isinstance(v, float) else v) for key, v in e.items() if key != "x"}
                       for e in found.tried)
    return Calibration(robot=robot, params=_unpack(found.x, robot, **flags), rmse_m=found.score * 1e-3,
                       starts=starts_out, seconds=time.perf_counter() - t0)
