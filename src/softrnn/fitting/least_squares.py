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
  n + 1 simulations of a point and its differences are independent and go to the evaluator in
  one batch (in this process, ``InProcess``, or on Dask, ``softrnn.calibration.parallel.Evaluator``),
  speculatively, before the optimiser asks for the Jacobian, when it has more than one worker.
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

import time

import numpy as np
from scipy.optimize import least_squares

from ..errors import SoftrnnInputError, bad
from ..progress import Progress
from .parameters import FitOptions, FitResult, Parameter, stop_reason
from .trials import InProcess, _Trials

PENALTY = 1e3
"""Residual of a failed trial, as a multiple of the start's root-mean-square residual."""

CORRELATION_LIMIT = 0.99
"""Parameter pairs correlated beyond this (in absolute value) are reported as not identifiable."""


def solve(residual, x0, bounds, max_evaluations: int, **options):
    """``scipy.optimize.least_squares`` (trust region reflective) of ``residual(x)`` -> (m,) from
    ``x0`` (n,) within ``bounds`` ((n,) lower, (n,) upper; +-inf where free) in at most
    ``max_evaluations``; ``options`` go to it as they are (``jac``, ``loss``, ``f_scale``,
    ``x_scale``, tolerances). The one place softrnn calls the optimiser; returns its result."""
    return least_squares(residual, x0, bounds=bounds, method="trf", max_nfev=max_evaluations, **options)


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
    """Fit ``parameters`` (``Parameter`` list: start values and bounds) so that the picklable
    ``model(values)`` -> (m_all,) prediction, for a tuple of the parameters' values in their order,
    matches ``measured`` (m,) (NaN where there is none, left out); method in the module docstring.

    ``weights`` (m,) or scalar multiplies each residual (e.g. 1 / its noise level; None: 1);
    ``evaluator`` runs the simulations (None: ``InProcess``); ``options`` says how to fit (None:
    ``FitOptions()``); ``progress(trials, budget, info)`` after every batch of simulations;
    ``cache_dir`` and ``fingerprint`` keep every trial to resume. Returns the ``FitResult``.
    """

    options = FitOptions() if options is None else options
    parameters, names, y, use, w = _checked(measured, parameters, weights)
    evaluator = InProcess() if evaluator is None else evaluator
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
        res = solve(problem.fun, x0, (lower, upper), options.max_evaluations, jac=problem.jac, x_scale=1.0,
                    xtol=options.xtol, ftol=options.ftol, gtol=options.gtol)
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
