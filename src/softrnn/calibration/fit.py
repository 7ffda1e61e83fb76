"""Bounded nonlinear least squares over a simulator's parameters, with parallel finite differences.

The simulator is a picklable callable ``model(values) -> prediction``: ``values`` a tuple of the
parameters' values in ``Parameter`` order, ``prediction`` a 1-D float array of m values comparable
with the measurement (raising ``SimulationError`` where the trial value makes it unstable). ``fit``
minimises ``sum((w * (prediction - measured))**2)`` over the finite entries of ``measured`` with
``scipy.optimize.least_squares`` (trust region reflective, bounds).

* **Parameter space.** Each parameter is fitted as x = ln(value / start) where its lower bound is
  positive (a relative step is equally meaningful for a modulus of 2.5 MPa and a damping of 0.1),
  else as x = (value - start) / (upper - lower); both put the start at x = 0.
* **Jacobian.** Forward differences of step ``diff_step`` in x (backward at an upper bound). The
  n + 1 simulations of a point and its differences are independent and go to the ``Evaluator`` in
  one batch (in this process, or on Dask), speculatively, before the optimiser asks for the
  Jacobian, when it has more than one worker.
* **Failed trials.** A trial the simulator cannot run (``SimulationError``, or a non-finite
  prediction) gets a residual of ``PENALTY`` times the starting point's root-mean-square residual
  (so the optimiser rejects the step) and is counted; a difference that fails is taken in the other
  direction. A start that fails is an error.
* **Uncertainty.** Standard errors from the Jacobian J at the optimum: cov = s^2 (J^T J)^-1 with
  s^2 = sum(r^2) / (m - n), mapped back to the values (delta method). They assume independent
  measurement errors; a model error correlated over time makes them optimistic. Pairs correlated
  beyond ``CORRELATION_LIMIT`` and parameters the data do not move (a zero column of J) are
  reported as not identifiable.
* **Resuming.** With ``cache_dir``, every trial's prediction is kept in a file named by a hash of
  ``fingerprint`` and the trial's x; the optimiser is deterministic, so a run that is interrupted
  and started again replays the finished trials from the files and goes on where it stopped.
"""

from __future__ import annotations

import hashlib
import io
import math
import time
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
from scipy.optimize import least_squares

from ..errors import SimulationError, SoftrnnInputError, bad, is_finite_number
from ..files import atomic_write_bytes, atomic_write_text
from ..progress import Progress
from .parallel import Evaluator

PENALTY = 1e3
"""Residual of a failed trial, as a multiple of the start's root-mean-square residual."""

CORRELATION_LIMIT = 0.99
"""Parameter pairs correlated beyond this (in absolute value) are reported as not identifiable."""


@dataclass(frozen=True)
class Parameter:
    """A fitted parameter: its ``name`` (e.g. a dotted scenario key), ``start`` value and bounds
    ``lower`` < ``upper`` (the start within them)."""

    name: str
    start: float
    lower: float
    upper: float

    def __post_init__(self):
        for what in ("start", "lower", "upper"):
            if not is_finite_number(getattr(self, what)):
                raise bad(f"{self.name}.{what}", getattr(self, what), "a finite number")
            object.__setattr__(self, what, float(getattr(self, what)))
        if not self.lower < self.upper:
            raise bad(f"{self.name}.bounds", [self.lower, self.upper], "[lower, upper] with lower < upper")
        if not self.lower <= self.start <= self.upper:
            raise bad(f"{self.name}.start", self.start,
                      f"a start within its bounds [{self.lower:g}, {self.upper:g}] (widen the bounds or move "
                      f"the start)")
        if self.lower > 0 and self.start <= 0:
            raise bad(f"{self.name}.start", self.start, "a positive start (the bounds are positive)")

    @property
    def log(self) -> bool:
        """Whether it is fitted in ln(value) (positive bounds) rather than in value."""
        return self.lower > 0

    def to_x(self, value: float) -> float:
        """The optimiser's coordinate of ``value`` (0 at the start)."""
        if self.log:
            return math.log(value / self.start)
        return (value - self.start) / (self.upper - self.lower)

    def from_x(self, x: float) -> float:
        """The value at the optimiser's coordinate ``x``."""
        if self.log:
            return self.start * math.exp(x)
        return self.start + x * (self.upper - self.lower)

    def value_scale(self, x: float) -> float:
        """d value / d x at ``x`` (maps a standard error in x to one in the value)."""
        return self.from_x(x) if self.log else self.upper - self.lower


@dataclass(frozen=True, kw_only=True)
class FitOptions:
    """How to fit.

    Attributes
    ----------
    max_evaluations : int
        Largest number of points the optimiser evaluates (``least_squares``' ``max_nfev``; each
        costs one simulation, and a Jacobian n more).
    diff_step : float
        Finite-difference step in the fitted coordinate x (a relative step for ln-fitted values).
    xtol, ftol, gtol : float
        ``least_squares``' tolerances on the step, the cost's decrease and the gradient. Besides,
        the fit stops as soon as a point's cost is within ``ftol`` (relative) of the best so far,
        whether it improves on it or not: the optimum is then known as well as the finite
        differences allow, and ``least_squares`` would only shrink its trust region further.
    """

    max_evaluations: int = 40
    diff_step: float = 1e-4
    xtol: float = 1e-6
    ftol: float = 1e-8
    gtol: float = 1e-10

    def __post_init__(self):
        if isinstance(self.max_evaluations, bool) or not isinstance(self.max_evaluations, int) \
                or self.max_evaluations < 2:
            raise bad("max_evaluations", self.max_evaluations, "an integer >= 2")
        for name in ("diff_step", "xtol", "ftol", "gtol"):
            v = getattr(self, name)
            if not is_finite_number(v) or not 0 < v < 1:
                raise bad(name, v, "a number in (0, 1)")


def stop_reason(status: int, evaluations: int, options: FitOptions) -> str:
    """Why ``least_squares`` stopped, in plain words, from its ``status`` code (-1 to 4), the number
    of ``evaluations`` and the ``options`` whose tolerance or budget ended the fit; this replaces
    SciPy's own termination message."""
    after = f"after {evaluations} evaluation{'' if evaluations == 1 else 's'}"
    reasons = {
        -1: f"the optimiser rejected its inputs {after}",
        0: f"the evaluation budget (max_evaluations = {options.max_evaluations}) ran out {after} "
           "before any tolerance was met",
        1: f"the gradient fell below gtol = {options.gtol:g} {after}",
        2: f"the cost decreased by less than ftol = {options.ftol:g} (relative) {after}",
        3: f"the step became smaller than xtol = {options.xtol:g} (relative) {after}",
        4: f"the cost's decrease and the step fell below ftol = {options.ftol:g} and xtol = {options.xtol:g} "
           f"{after}",
    }
    return reasons.get(status, f"the optimiser stopped with status {status} {after}")


@dataclass(frozen=True, eq=False)
class FitResult:
    """A finished fit (n parameters, m measured values used).

    Attributes
    ----------
    names : tuple of str
        parameter names
    start, fitted, std_error : (n,)
        values in the parameters' units
    correlation : (n, n)
        correlation of the estimates
    not_identifiable : list of str
        lines saying which are not identifiable
    rms_start, rms_fitted : float
        root-mean-square weighted residual at the start and at the optimum
    prediction_start, prediction_fitted : (m_all,)
        the model's predictions (the full vector)
    trials : int
        simulations run (cached ones included)
    failed_trials : int
        those the simulator could not run
    cached_trials : int
        those read from ``cache_dir``
    evaluations : int
        points the optimiser evaluated
    seconds : float
        wall time [s]
    success, message : bool, str
        ``least_squares``' verdict, in words (``stop_reason``)
    measurements : int
        m, the measured values used (the residual's length)
    history : list
        (trials so far, RMS residual, {name: value}) of every point the optimiser evaluated
    """

    names: tuple
    start: np.ndarray
    fitted: np.ndarray
    std_error: np.ndarray
    correlation: np.ndarray
    not_identifiable: list
    rms_start: float
    rms_fitted: float
    prediction_start: np.ndarray
    prediction_fitted: np.ndarray
    trials: int
    failed_trials: int
    cached_trials: int
    evaluations: int
    seconds: float
    success: bool
    message: str
    measurements: int = 0
    history: list = field(default_factory=list)

    def values(self) -> dict:
        """{name: fitted value}."""
        return {n: float(v) for n, v in zip(self.names, self.fitted)}

    def to_dict(self) -> dict:
        """JSON-ready summary (no prediction arrays)."""
        return {
            "parameters": {n: {"start": float(s), "fitted": float(f), "std_error": float(e)}
                           for n, s, f, e in zip(self.names, self.start, self.fitted, self.std_error)},
            "correlation": [[float(c) for c in row] for row in self.correlation],
            "not_identifiable": list(self.not_identifiable),
            "rms_residual_start": self.rms_start, "rms_residual_fitted": self.rms_fitted,
            "measurements": self.measurements, "trials": self.trials, "failed_trials": self.failed_trials,
            "cached_trials": self.cached_trials, "evaluations": self.evaluations, "seconds": self.seconds,
            "success": self.success, "message": self.message,
            "history": [{"trial": t, "rms_residual": r, "values": v} for t, r, v in self.history],
        }


# --------------------------------------------------------------------------------------------- trials
def run_trial(model, values: tuple) -> tuple:
    """(prediction or None, message): ``model(values)``, with a failure caught (runs on a worker)."""
    try:
        pred = np.asarray(model(tuple(float(v) for v in values)), dtype=np.float64).ravel()
    except (SimulationError, FloatingPointError, ZeroDivisionError) as err:
        return None, str(err).splitlines()[0] if str(err) else type(err).__name__
    except SoftrnnInputError as err:          # e.g. a trial value the model's own checks refuse
        return None, str(err)
    if not np.all(np.isfinite(pred)):
        return None, "the prediction is not finite"
    return pred, ""


class _Trials:
    """The predictions of every x tried, from memory, the cache folder or a batch of simulations."""

    def __init__(self, model, parameters, evaluator, cache_dir, fingerprint: str, progress, budget: int):
        self.model, self.parameters, self.evaluator = model, parameters, evaluator
        self.cache_dir = None if cache_dir is None else Path(cache_dir)
        self.fingerprint = fingerprint
        self.progress, self.budget = progress, budget
        self.names = tuple(p.name for p in parameters)
        self.memory: dict = {}            # the most recent trials (a bounded number, oldest dropped first)
        self.kept: dict = {}              # trials kept for the whole fit (the start)
        self.held: dict = {}              # the best point's trials (replaced when a better one comes)
        self.limit = 4 * (len(parameters) + 1)
        self.trials = self.failed = self.cached = 0
        self.last_message = ""

    def keep(self, x) -> None:
        """Hold the trial of ``x`` for the whole fit (the memory forgets old trials)."""
        key = np.asarray(x, np.float64).tobytes()
        self.kept[key] = self.memory[key]

    def hold(self, points) -> None:
        """Hold the trials of ``points`` (those in memory) until the next call."""
        keys = (np.asarray(x, np.float64).tobytes() for x in points)
        self.held = {k: self.memory[k] for k in keys if k in self.memory}

    def values(self, x: np.ndarray) -> tuple:
        return tuple(p.from_x(float(v)) for p, v in zip(self.parameters, x))

    def _file(self, key: bytes) -> Path:
        digest = hashlib.sha256(self.fingerprint.encode() + key).hexdigest()[:24]
        return self.cache_dir / f"trial-{digest}.npy"

    def _from_cache(self, key: bytes):
        if self.cache_dir is None:
            return False, None
        path = self._file(key)
        failed = path.with_suffix(".failed")
        if failed.exists():
            return True, (None, failed.read_text(encoding="utf-8"))
        if path.exists():
            try:
                return True, (np.load(path), "")
            except (OSError, ValueError):
                path.unlink(missing_ok=True)
        return False, None

    def _to_cache(self, key: bytes, pred, message: str) -> None:
        if self.cache_dir is None:
            return

        self.cache_dir.mkdir(parents=True, exist_ok=True)
        path = self._file(key)
        if pred is None:
            atomic_write_text(path.with_suffix(".failed"), message)
        else:
            buf = io.BytesIO()
            np.save(buf, pred)
            atomic_write_bytes(path, buf.getvalue())

    def get(self, points: list) -> list:
        """The (prediction or None, message) of every x in ``points`` (new ones simulated as one batch)."""
        todo = []
        for x in points:
            key = np.asarray(x, np.float64).tobytes()
            if key in self.memory or key in self.kept or key in self.held or any(key == k for k, _ in todo):
                continue
            hit, entry = self._from_cache(key)
            if hit:
                self.memory[key] = entry
                self.trials += 1
                self.cached += 1
                self.failed += entry[0] is None
            else:
                todo.append((key, x))
        if todo:
            results = self.evaluator.map(run_trial, self.model, [self.values(x) for _, x in todo])
            for (key, _), (pred, message) in zip(todo, results):
                self.memory[key] = (pred, message)
                self._to_cache(key, pred, message)
                self.trials += 1
                if pred is None:
                    self.failed += 1
                    self.last_message = message
        if self.progress is not None:
            self.progress(min(self.trials, self.budget), self.budget, {"trials": self.trials, "failed": self.failed})
        found = [self.kept.get(k) or self.held.get(k) or self.memory[k]
                 for k in (np.asarray(x, np.float64).tobytes() for x in points)]
        while len(self.memory) > max(self.limit, len(points)):
            self.memory.pop(next(iter(self.memory)))
        return found


class _Converged(Exception):
    """Raised inside the optimiser's residual call to stop it (``FitOptions`` says when)."""


def _fd_points(x: np.ndarray, h: float, upper: np.ndarray) -> list:
    """The n forward-difference points of x (backward where x + h passes the upper bound)."""
    pts = []
    for i in range(x.size):
        p = x.copy()
        p[i] = x[i] + h if x[i] + h <= upper[i] else x[i] - h
        pts.append(p)
    return pts


def _checked(measured, parameters, weights) -> tuple:
    """(parameters list, names, y (m,), use (m,) bool, w (m,)) checked."""
    parameters = list(parameters)
    if not parameters or not all(isinstance(p, Parameter) for p in parameters):
        raise bad("parameters", parameters, "a non-empty list of Parameter entries")
    names = tuple(p.name for p in parameters)
    if len(set(names)) != len(names):
        raise bad("parameters", list(names), "each parameter once")
    y = np.asarray(measured, dtype=np.float64).ravel()
    use = np.isfinite(y)
    if use.sum() <= len(parameters):
        raise bad("measured", f"{int(use.sum())} finite values", f"more measurements than the {len(parameters)} "
                                                                  f"fitted parameters")
    w = np.broadcast_to(np.asarray(1.0 if weights is None else weights, np.float64), y.shape)
    if not np.all(np.isfinite(w[use])) or np.any(w[use] < 0):
        raise bad("weights", "non-finite or negative values", "finite weights >= 0")
    return parameters, names, y, use, w


class _Problem:
    """The residual and its finite-difference Jacobian for ``least_squares``, in the fitted
    coordinates x; remembers the best point and stops the optimiser (``_Converged``) once the cost
    no longer changes."""

    def __init__(self, trials: _Trials, y, use, w, upper, lower, options: FitOptions, speculate: bool):
        self.trials, self.y, self.use, self.w = trials, y, use, w
        self.upper, self.lower, self.options, self.speculate = upper, lower, options, speculate
        self.h = options.diff_step
        self.penalty = None
        self.best_cost, self.best_x = None, None
        self.evaluations = 0
        self.history = []

    def residual_of(self, pred) -> np.ndarray:
        if pred is None:
            return np.full(int(self.use.sum()), self.penalty)
        return (self.w * (pred - self.y))[self.use]

    def batch(self, x) -> list:
        """x, and its finite-difference points when the evaluator runs several simulations at once."""
        return [x] + (_fd_points(x, self.h, self.upper) if self.speculate else [])

    def fun(self, x) -> np.ndarray:
        batch = self.batch(x)
        pred, _ = self.trials.get(batch)[0]
        r = self.residual_of(pred)
        self.evaluations += 1
        cost = float(r @ r)
        self.history.append((self.trials.trials, float(np.sqrt(np.mean(r ** 2))),
                             dict(zip(self.trials.names, self.trials.values(x)))))
        previous = self.best_cost
        if previous is None or cost < previous:
            self.best_cost, self.best_x = cost, np.array(x, dtype=np.float64)
            self.trials.hold(batch)
        if previous is not None and abs(cost - previous) <= self.options.ftol * previous:
            raise _Converged()
        return r

    def jac(self, x) -> np.ndarray:
        pts = _fd_points(x, self.h, self.upper)
        base = self.residual_of(self.trials.get([x])[0][0])
        J = np.zeros((base.size, x.size))
        for i, (p, (pred, _)) in enumerate(zip(pts, self.trials.get(pts))):
            if pred is None:                       # try the other side once
                q = x.copy()
                q[i] = 2 * x[i] - p[i]
                if self.lower[i] <= q[i] <= self.upper[i]:
                    p = q
                    pred = self.trials.get([q])[0][0]
            if pred is not None:
                J[:, i] = (self.residual_of(pred) - base) / (p[i] - x[i])
        return J


def _uncertainty(J: np.ndarray, r: np.ndarray, names: tuple, scale: np.ndarray) -> tuple:
    """(standard errors (n,) of the values, correlation (n, n), identifiability warnings) from the
    Jacobian J (m, n) in x and the residual r (m,) at the optimum; ``scale`` (n,) = d value / d x."""
    m, n = J.shape
    s2 = float(r @ r) / max(m - n, 1)
    inverse = np.linalg.pinv(J.T @ J)
    se_x = np.sqrt(np.clip(np.diag(inverse), 0.0, None))
    with np.errstate(invalid="ignore", divide="ignore"):
        corr = inverse / np.outer(se_x, se_x)                 # independent of s2: defined for an exact fit too
    corr = np.where(np.isfinite(corr), corr, 0.0)
    np.fill_diagonal(corr, 1.0)
    issues = [f"{names[i]}: the data do not depend on it (zero sensitivity)" for i in range(n) if not np.any(J[:, i])]
    for i in range(n):
        for j in range(i + 1, n):
            if abs(corr[i, j]) > CORRELATION_LIMIT:
                issues.append(f"{names[i]} and {names[j]}: correlated {corr[i, j]:+.4f} (beyond "
                              f"{CORRELATION_LIMIT}); the data fix a combination of them, not each one")
    return se_x * np.sqrt(s2) * scale, corr, issues


def fit(model, measured, parameters, *, weights=None, evaluator=None, options: FitOptions | None = None,
        progress: Progress | None = None, cache_dir=None, fingerprint: str = "") -> FitResult:
    """Fit ``parameters`` (``Parameter`` list) so that ``model(values)`` matches ``measured``.

    Parameters
    ----------
    model : callable
        picklable ``model(values)`` -> (m_all,) prediction for a tuple of the parameters' values in
        ``parameters`` order (see the module docstring)
    measured : (m,)
        measurements, NaN where there is none (left out)
    parameters : list of Parameter
        the fitted parameters, their start values and bounds
    weights : (m,) or scalar or None
        multiplies each residual (e.g. 1 / its noise level); None: 1
    evaluator : Evaluator or None
        runs the simulations (None: this process)
    options : FitOptions or None
        how to fit (None: ``FitOptions()``)
    progress : Progress or None
        ``progress(trials, budget, info)`` after every batch of simulations
    cache_dir, fingerprint : path, str
        keep every trial in ``cache_dir`` to resume (see the module docstring)

    Returns
    -------
    FitResult
        the finished fit
    """

    options = FitOptions() if options is None else options
    parameters, names, y, use, w = _checked(measured, parameters, weights)
    evaluator = Evaluator() if evaluator is None else evaluator
    n = len(parameters)
    lower = np.array([p.to_x(p.lower) for p in parameters])
    upper = np.array([p.to_x(p.upper) for p in parameters])
    x0 = np.zeros(n)
    trials = _Trials(model, parameters, evaluator, cache_dir, fingerprint, progress, options.max_evaluations * (n + 1))
    problem = _Problem(trials, y, use, w, upper, lower, options, speculate=evaluator.workers > 1)
    t0 = time.perf_counter()
    (pred0, message0), *_ = trials.get(problem.batch(x0))
    if pred0 is None:
        raise SoftrnnInputError(f"the simulation fails at the start values {dict(zip(names, trials.values(x0)))}: "
                                f"{message0}; start from values the simulator can run")
    if pred0.shape != y.shape:
        raise bad("measured", f"{y.size} values", f"as many values as the model predicts ({pred0.size})")
    trials.keep(x0)
    rms0 = float(np.sqrt(np.mean(problem.residual_of(pred0) ** 2)))
    problem.penalty = PENALTY * max(rms0, 1e-300)
    try:
        res = least_squares(problem.fun, x0, jac=problem.jac, bounds=(lower, upper), method="trf", x_scale=1.0,
                            max_nfev=options.max_evaluations, xtol=options.xtol, ftol=options.ftol,
                            gtol=options.gtol)
        xf, success = np.asarray(res.x, np.float64), bool(res.success)
        message = stop_reason(int(res.status), problem.evaluations, options)
    except _Converged:
        xf, success = problem.best_x, True
        message = f"the cost changed by less than ftol = {options.ftol:g} (relative) from the best point"
    pred_f = trials.get([xf])[0][0]
    rf = problem.residual_of(pred_f)
    scale = np.array([p.value_scale(v) for p, v in zip(parameters, xf)])
    se, corr, issues = _uncertainty(problem.jac(xf), rf, names, scale)
    return FitResult(names=names, start=np.array([p.start for p in parameters]), fitted=np.array(trials.values(xf)),
                     std_error=se, correlation=corr, not_identifiable=issues, rms_start=rms0,
                     rms_fitted=float(np.sqrt(np.mean(rf ** 2))), prediction_start=pred0,
                     prediction_fitted=pred_f if pred_f is not None else np.full_like(y, np.nan),
                     trials=trials.trials, failed_trials=trials.failed, cached_trials=trials.cached,
                     evaluations=problem.evaluations, seconds=time.perf_counter() - t0, success=success,
                     message=message, measurements=int(rf.size), history=problem.history)
