"""What a fit works on and gives: the fitted ``Parameter`` (its start, bounds and the optimiser's
coordinate), how to fit (``FitOptions``), why the optimiser stopped (``stop_reason``) and the
finished fit (``FitResult``)."""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from ..errors import bad, is_finite_number


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
