"""A robot's dynamic physics driven by its recorded tendon tensions, and its calibration.

The robot is described by a scenario (``softrnn.scenarios``: a shipped name such as
``tendon-spatial`` or a TOML file): its rod, tendons, boundary, damping and gravity. A recording
whose inputs are the tendon tensions [N], one column per tendon in the scenario's tendon order,
drives those tendons; the dynamic rod simulator (``softrnn.rod``) runs the session from the
scenario's initial state at rest and gives the tip (the scenario's last node, or ``node``) at the
recorded times.

* **Actuator lag.** Each recorded tension u(t) (between rows held linearly or as a step, ``hold``)
  passes through a first-order lag tau dy/dt = u - y, y(0) = u(0), solved exactly on each interval.
* **Settling.** ``settle`` [s] of simulated time before the session, the first row's tensions held,
  for a session that does not start from the unloaded rod at rest.
* **A coarser rod.** A scenario's rod of more than ``max_nodes`` nodes is run with ``max_nodes``
  (same length, material and tendons; ``coarse``) where nothing but its ends is named by a node
  index: the calibration fits the coarse rod's parameters, and the coarse rod predicts (a 21-node
  rod runs about 3x faster than a 41-node one).
* **Calibration** (``calibrate_dynamics``): multipliers of Young's modulus, the density and the
  translational and rotational damping, and the lag tau [s], all fitted in ln(value) within bounds
  (``DYNAMIC_PARAMETERS``) by ``softrnn.fitting.fit`` on the tip over ``window`` seconds in all,
  the first ``window / sessions`` of each session (residuals in fractions of the rod's length).
  Every trial runs with the same solver step, the stable one of the stiffest, lightest corner of
  the bounds, so the finite differences see no jump of the step.
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass, field, replace

import numpy as np

from ..errors import SoftrnnInputError, bad, nonnegative
from ..fitting import FitOptions, FitResult, Parameter, fit
from ..rod import RunConfig, Simulator
from ..scenarios import Scenario, load_scenario
from .recording import Recording

TENSION_UNITS = ("n",)
"""Units (lower case) of inputs read as tendon tensions [N]."""
HOLDS = ("linear", "zoh")
"""How a recorded tension is held between rows: linearly interpolated, or a zero-order hold."""
DYNAMIC_PARAMETERS = (("youngs_modulus", 1.0, 0.5, 2.0), ("density", 1.0, 0.5, 2.0),
                      ("damping_translational", 1.0, 0.1, 10.0), ("damping_rotational", 1.0, 0.1, 10.0),
                      ("actuator_lag_s", 0.02, 1e-3, 1.0))
"""The calibrated parameters: (name, start, lower, upper); the first four multiply the scenario's
values, the last is the lag tau [s]."""


@dataclass(frozen=True)
class DynamicOptions:
    """How the dynamic physics is run and calibrated.

    Attributes
    ----------
    window : float
        seconds the calibration fits in all, split equally among the sessions, each part from its
        session's start (0: the whole sessions)
    hold : str
        how a tension is held between rows, one of ``HOLDS``
    node : int
        the tracked node of the scenario's rod (negative: from the tip; default the tip)
    settle : float
        seconds simulated before the session with the first row's tensions held [s]
    max_evaluations : int
        the calibration's budget of optimiser evaluations (``FitOptions.max_evaluations``)
    fit : tuple of str
        the calibrated parameters, names of ``DYNAMIC_PARAMETERS``
    max_nodes : int
        run a rod of more nodes with this many (``coarse``; 0: the scenario's own)
    """

    window: float = 60.0
    hold: str = "linear"
    node: int = -1
    settle: float = 0.0
    max_evaluations: int = 12
    fit: tuple = tuple(p[0] for p in DYNAMIC_PARAMETERS)
    max_nodes: int = 21

    def __post_init__(self):
        if isinstance(self.max_nodes, bool) or not isinstance(self.max_nodes, int) or self.max_nodes == 1 \
                or self.max_nodes < 0:
            raise bad("max_nodes", self.max_nodes, "an integer >= 2, or 0 for the scenario's own rod")
        nonnegative("window", self.window, "s")
        nonnegative("settle", self.settle, "s")
        if self.hold not in HOLDS:
            raise bad("hold", self.hold, f"one of {', '.join(HOLDS)}")
        if isinstance(self.node, bool) or not isinstance(self.node, int):
            raise bad("node", self.node, "an integer node index (negative: from the tip)")
        object.__setattr__(self, "fit", tuple(self.fit))
        known = [p[0] for p in DYNAMIC_PARAMETERS]
        if not self.fit or any(f not in known for f in self.fit) or len(set(self.fit)) != len(self.fit):
            raise bad("fit", ",".join(map(str, self.fit)), f"one or more of {', '.join(known)}, each once")
        FitOptions(max_evaluations=self.max_evaluations)


def lagged(time_s: np.ndarray, u: np.ndarray, tau: float, hold: str = "linear") -> np.ndarray:
    """The lag's output y (T, m) at the row times ``time_s`` (T,) [s] of the inputs ``u`` (T, m)
    through tau dy/dt = u - y, y(0) = u(0), solved exactly with u held ``hold`` between rows."""
    y = np.empty_like(u, dtype=float)
    y[0] = u[0]
    if tau <= 0:
        y[:] = u
        return y
    h = np.diff(time_s)
    a = np.exp(-h / tau)
    slope = np.diff(u, axis=0) / h[:, None] if hold == "linear" else np.zeros((len(h), u.shape[1]))
    for k in range(len(h)):
        # u(t) = u_k + s (t - t_k): y(t) = u(t) - s tau + (y_k - u_k + s tau) exp(-(t - t_k) / tau)
        s = slope[k] * tau
        y[k + 1] = u[k] + slope[k] * h[k] - s + (y[k] - u[k] + s) * a[k]
    return y


@dataclass(frozen=True, eq=False)
class TensionProfile:
    """One tendon's tension t (K,) [s] of the simulation -> (K,) [N]: the recorded tension of
    ``column`` through the lag, the session's row ``time`` (T,) [s] from 0, ``settle`` [s] later."""

    time: np.ndarray
    u: np.ndarray
    y: np.ndarray
    tau: float
    hold: str
    column: int
    settle: float = 0.0

    def __call__(self, t) -> np.ndarray:
        s = np.asarray(t, dtype=float) - self.settle
        last = len(self.time) - 1
        k = np.clip(np.searchsorted(self.time, s, side="right") - 1, 0, last)
        k1 = np.minimum(k + 1, last)
        d = np.clip(s - self.time[k], 0.0, None)
        u0, y0 = self.u[k, self.column], self.y[k, self.column]
        slope = np.zeros_like(u0)
        if self.hold == "linear":
            h = self.time[k1] - self.time[k]
            slope = np.divide(self.u[k1, self.column] - u0, h, out=slope, where=h > 0)
            d = np.where(h > 0, np.minimum(d, h), d)           # beyond the last row: held
        if self.tau <= 0:
            return u0 + slope * d
        st = slope * self.tau
        return u0 + slope * d - st + (y0 - u0 + st) * np.exp(-d / self.tau)


def _scaled(scenario: Scenario, values: dict):
    """The scenario's ``Setup`` with the multipliers of ``values`` applied (missing: 1)."""
    setup = scenario.setup
    rod = setup.rod
    e, rho = values.get("youngs_modulus", 1.0), values.get("density", 1.0)
    rod = replace(rod, youngs_modulus=rod.youngs_modulus * e, density=rod.density * rho,
                  shear_modulus=None if rod.shear_modulus is None else rod.shear_modulus * e)
    d = setup.damping
    damping = replace(d, translational=d.translational * values.get("damping_translational", 1.0),
                      rotational=d.rotational * values.get("damping_rotational", 1.0))
    return replace(setup, rod=rod, damping=damping)


def coarse(scenario: Scenario, nodes: int, node: int = -1) -> Scenario:
    """``scenario`` with its rod rebuilt with ``nodes`` nodes where it has more and no node index
    other than its ends is named (boundary, loads, tendon ends, the tracked ``node``); else itself."""
    setup = scenario.setup
    n = setup.rod.n_nodes
    ends = {0, n - 1}
    seg = setup.rod.segment_length
    if not nodes or n <= nodes or setup.loads or setup.contact is not None \
            or any(setup.node_index(bc.node) not in ends for bc in setup.boundary) \
            or any(td.end_index(n, seg) != n - 1 for td in setup.tendons) or setup.node_index(node) != n - 1:
        return scenario
    try:
        return scenario.with_values({"rod.n_nodes": nodes, "run.nodes_of_interest": [-1]})
    except SoftrnnInputError:
        return scenario


@dataclass(frozen=True, eq=False)
class DynamicRobot:
    """A robot's dynamic description: the ``scenario`` (rod, tendons, boundary, damping, gravity;
    its rod made ``coarse`` by ``from_scenario``, which loads one by name or path) run by the
    recorded tensions with ``options``; ``nodes_described`` is the scenario's own node count."""

    scenario: Scenario
    options: DynamicOptions = DynamicOptions()
    nodes_described: int | None = None
    _steps: dict = field(default_factory=dict, repr=False)

    @classmethod
    def from_scenario(cls, name_or_path, options: DynamicOptions = DynamicOptions()) -> DynamicRobot:
        """The robot of a shipped scenario's name or a scenario file's path; one with no tendons,
        or magnetic, is refused naming ``scenario``."""
        sc = name_or_path if isinstance(name_or_path, Scenario) else load_scenario(name_or_path)
        if not sc.setup.tendons or getattr(sc, "magnetic", None) is not None:
            raise bad("scenario", sc.name, "a tendon robot's scenario with [[tendons]] (e.g. tendon-spatial)")
        sc.setup.node_index(options.node, "node")
        return cls(coarse(sc, options.max_nodes, options.node), options, nodes_described=sc.setup.rod.n_nodes)

    @property
    def length(self) -> float:
        """The rod's length [m]."""
        return float(self.scenario.setup.rod.length)

    @property
    def tendons(self) -> tuple:
        """The scenario's tendon names, in order (the recording's input columns)."""
        return tuple(td.name for td in self.scenario.setup.tendons)

    def check(self, session: Recording) -> None:
        """Refuse a session whose inputs are not the scenario's tendon tensions in N (one line naming
        ``scenario``)."""
        m = len(self.tendons)
        if session.n_inputs != m:
            raise bad("scenario", self.scenario.name, f"a robot with as many tendons as the recording {session.path} "
                                                      f"has input columns ({session.n_inputs}), but the scenario has "
                                                      f"{m} ({', '.join(self.tendons)})")
        wrong = [u or "none" for u in session.units if u.lower() not in TENSION_UNITS]
        if wrong:
            raise bad("scenario", self.scenario.name, f"inputs that are tendon tensions in N (e.g. act_tendon_a[N]),"
                                                      f" but the units of {session.path}'s inputs are "
                                                      f"{', '.join(sorted(set(wrong)))}")

    def substeps(self, dt: float, names) -> int:
        """Solver steps per saved interval ``dt`` [s] for every trial of a fit of ``names``: the
        most over the corners of the modulus and density bounds (the stiffest, lightest rod)."""
        key = (round(dt, 12), tuple(names))
        if key not in self._steps:
            bounds = {p[0]: (p[2], p[3]) for p in DYNAMIC_PARAMETERS if p[0] in names and p[0] in
                      ("youngs_modulus", "density")}
            corners = [{}]
            for name, (lo, hi) in bounds.items():
                corners = [{**c, name: v} for c in corners for v in (1.0, lo, hi)]
            config = self.scenario.config
            run = RunConfig(dt=dt, n_samples=2, safety=config.safety, integrator=config.integrator)
            self._steps[key] = max(Simulator(_scaled(self.scenario, c)).resolve_substeps(run) for c in corners)
        return self._steps[key]

    def tip(self, values: dict, session: Recording, until: float | None = None, substeps: int | None = None):
        """The simulated tip (T', 3) [m] at the session's row times (those within ``until`` [s]
        of its start; None: all), the robot run from rest at its first row with ``values`` ({name of
        ``DYNAMIC_PARAMETERS``: value}, missing: the start) and ``substeps`` solver steps per row
        interval (None: the fewest stable). A session whose inputs were shifted by ``lag`` rows
        (``shift_inputs``) is run on its inputs at their own times, ``lag`` median intervals before
        the tip's."""
        self.check(session)
        o = self.options
        t = session.time - session.time[0]
        dt = float(np.median(np.diff(t)))
        rows = t.size if until is None else max(int(np.searchsorted(t, until, side="right")), 2)
        u = np.maximum(session.inputs[:rows], 0.0)
        tau = values.get("actuator_lag_s", 0.0)
        y = lagged(t[:rows], u, tau, o.hold)
        tendons = tuple(replace(td, tension=TensionProfile(t[:rows], u, y, tau, o.hold, j, o.settle),
                                displacement=None, stiffness=None)
                        for j, td in enumerate(self.scenario.setup.tendons))
        setup = replace(_scaled(self.scenario, values), tendons=tendons)
        at = t[:rows] + session.lag * dt + o.settle           # the tip's times in the simulation [s]
        n = int(math.ceil(at[-1] / dt - 1e-9)) + 1
        config = self.scenario.config
        run = RunConfig(dt=dt, n_samples=n, substeps=substeps, save_nodes=(setup.node_index(o.node, "node"),),
                        safety=config.safety, integrator=config.integrator)
        traj = Simulator(setup).run(run)
        path = np.asarray(traj.positions[:, 0], dtype=float)
        return np.column_stack([np.interp(at, traj.time, path[:, a]) for a in range(3)])


@dataclass(frozen=True, eq=False)
class _Windows:
    """The calibration's model (``softrnn.fitting.fit``): the windows' tips over the length."""

    robot: DynamicRobot
    sessions: tuple
    names: tuple
    until: float | None
    substeps: tuple

    def __call__(self, values) -> np.ndarray:
        v = dict(zip(self.names, values))
        return np.concatenate([self.robot.tip(v, s, self.until, n).ravel()
                               for s, n in zip(self.sessions, self.substeps)]) / self.robot.length


@dataclass(frozen=True, eq=False)
class DynamicCalibration:
    """A finished dynamic calibration.

    Attributes
    ----------
    values : dict
        {name: value} of every ``DYNAMIC_PARAMETERS`` entry (the fitted ones and the starts of the rest)
    result : FitResult
        the fit (in fractions of the rod's length)
    window_s : float
        the seconds of each session fitted (0: whole sessions)
    rows : int
        the rows fitted
    rmse_start_mm, rmse_fitted_mm : float
        Euclidean tip RMSE over the fitted rows before and after [mm]
    seconds : float
        the wall time [s]
    """

    values: dict
    result: FitResult
    window_s: float
    rows: int
    rmse_start_mm: float
    rmse_fitted_mm: float
    seconds: float

    def to_dict(self) -> dict:
        """JSON-ready: the parameters (start, fitted, bounds, standard error), the residual before
        and after, the fit's account."""
        r = self.result
        fitted = {n: (s, f, e) for n, s, f, e in zip(r.names, r.start, r.fitted, r.std_error)}
        params = {}
        for name, start, lower, upper in DYNAMIC_PARAMETERS:
            s, f, e = fitted.get(name, (start, start, 0.0))
            params[name] = {"start": float(s), "fitted": round(float(f), 6), "std_error": round(float(e), 6),
                            "bounds": [lower, upper], "fitted_here": name in fitted}
        return {"parameters": params, "window_s": self.window_s, "rows": self.rows,
                "tip_rmse_start_mm": round(self.rmse_start_mm, 4), "tip_rmse_fitted_mm": round(self.rmse_fitted_mm, 4),
                "not_identifiable": list(r.not_identifiable), "evaluations": r.evaluations, "trials": r.trials,
                "failed_trials": r.failed_trials, "message": r.message, "seconds": round(self.seconds, 1)}


def _rmse_mm(prediction: np.ndarray, measured: np.ndarray, length: float) -> float:
    d = (prediction - measured).reshape(-1, 3) * length
    return float(np.sqrt(np.mean(np.sum(d ** 2, axis=1)))) * 1e3


def calibrate_dynamics(robot: DynamicRobot, sessions, progress=None) -> DynamicCalibration:
    """Fit ``robot.options.fit`` of ``DYNAMIC_PARAMETERS`` to the tips of ``sessions`` (a list of
    ``Recording``) over the first ``robot.options.window / len(sessions)`` seconds of each (module
    docstring).
    ``progress(trials, budget, info)`` after every batch of simulations."""
    t0 = time.perf_counter()
    sessions = tuple(sessions)
    if not sessions:
        raise bad("sessions", [], "at least one recording")
    for s in sessions:
        robot.check(s)
    o = robot.options
    until = o.window / len(sessions) if o.window > 0 else None
    names = tuple(p[0] for p in DYNAMIC_PARAMETERS if p[0] in o.fit)
    parameters = [Parameter(n, start, lo, hi) for n, start, lo, hi in DYNAMIC_PARAMETERS if n in names]
    steps = tuple(robot.substeps(float(np.median(np.diff(s.time))), names) for s in sessions)
    model = _Windows(robot, sessions, names, until, steps)
    measured = []
    for s in sessions:
        t = s.time - s.time[0]
        rows = t.size if until is None else max(int(np.searchsorted(t, until, side="right")), 2)
        measured.append(s.tip[:rows].ravel())
    measured = np.concatenate(measured) / robot.length
    try:
        result = fit(model, measured, parameters, options=FitOptions(max_evaluations=o.max_evaluations),
                     progress=progress)
    except SoftrnnInputError as err:
        raise SoftrnnInputError(f"the dynamic calibration of {robot.scenario.name}: {err}") from None
    values = {n: start for n, start, *_ in DYNAMIC_PARAMETERS} | result.values()
    L = robot.length
    return DynamicCalibration(values=values, result=result, window_s=float(o.window), rows=measured.size // 3,
                              rmse_start_mm=_rmse_mm(result.prediction_start, measured, L),
                              rmse_fitted_mm=_rmse_mm(result.prediction_fitted, measured, L),
                              seconds=time.perf_counter() - t0)


__all__ = ["DYNAMIC_PARAMETERS", "HOLDS", "TENSION_UNITS", "DynamicCalibration", "DynamicOptions", "DynamicRobot",
           "TensionProfile", "calibrate_dynamics", "lagged"]
