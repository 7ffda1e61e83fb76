"""A scenario file fitted to a recorded dataset (``softrnn calibrate``): chosen values of the scenario,
named by dotted keys as in its ``[randomize]`` table, are fitted so that the simulated trajectories
of the recorded nodes match the data over a span of time.

* **Parameters.** Bounds and start of each key come from the scenario's ``[calibrate]`` table (the
  start defaults to the file's value), else from the key's ``uniform`` or ``loguniform`` range in
  ``[randomize]``. A key whose lower bound is positive is fitted in ln(value) (``Parameter``).
* **Model.** ``ScenarioModel``: the scenario built with the trial values (``Scenario.with_values``),
  simulated from its initial state at t = 0 to the end of the span at the data's ``dt`` with a fixed
  number of solver steps per sample (the scenario's own step, else the largest stable count over
  the corners of the bounds box, so the step never jumps between trials and spoils the finite
  differences); its prediction is the recorded nodes' positions over the span divided by the rod's
  length L, so residuals are fractions of L.
* **Data.** Positions (T, N, 3) on a time grid k dt from 0, of a rod with the scenario's node count
  (``check_dataset``); float32 in files, compared in float64.
* **Span.** ``train`` (the first 60 % of the samples, the paper's chronological split), ``all``, or
  ``T0:T1`` in seconds (``resolve_span``).
"""

from __future__ import annotations

import hashlib
import itertools
import math
from dataclasses import dataclass
from functools import lru_cache

import numpy as np

from .. import __version__
from ..errors import SoftrnnInputError, bad, one_line
from ..fitting import FitOptions, FitResult, Parameter, fit
from ..rod.simulation import RunConfig, Simulator
from ..scenarios.calibrate import _lookup, edited_text
from ..scenarios.reading import ScenarioError, _is_number, _show
from ..scenarios.scenario import Scenario, parse_scenario

TRAIN_FRACTION = 0.6
"""The default span: the first 60 % of the samples (the paper's chronological train/test split)."""

TIME_TOLERANCE = 1e-3
"""Largest offset of a sample time from its grid point k dt, as a fraction of dt."""

MAX_CORNER_DIMENSIONS = 6
"""Up to this many fitted keys, the substeps are checked at all 2^n corners of the bounds box;
beyond, at each bound alone (the other keys at their starts)."""

HEADER = "# Calibrated by softrnn"
"""How the comment line that ``fitted_text`` puts at the top of a fitted scenario starts."""


# --------------------------------------------------------------------------------------- parameters
def _check_key(scenario: Scenario, key: str) -> None:
    """Refuse a ``--fit`` key that names no number of the scenario (one line naming --fit and the fix)."""
    kind, found = _lookup(scenario.data, key)
    if kind == "none":
        raise bad("--fit", key, f"a dotted key naming a number of the scenario, as in [randomize] (e.g. "
                                f"rod.youngs_modulus, damping.translational, loads.0.stiffness), but {found}")
    if kind == "absent":
        try:
            scenario.with_values({key: 1.0})
        except ScenarioError as err:
            if f"unknown key '{key}'" in str(err):       # the message without the trial's dummy value
                reason = str(err)[len(err.source) + 2:].rsplit(" (with ", 1)[0]
                raise bad("--fit", key, f"a dotted key naming a number of the scenario, but: {reason}") from None
        entry = scenario.calibrate.get(key)
        if entry is None or entry[2] is None:
            raise bad("--fit", key, f"a key the scenario sets, but the file leaves it at its default; write it "
                                    f"in the file, or give its start in [calibrate]: \"{key}\" = "
                                    f"{{ bounds = [lo, hi], start = value }}")
        return
    if not _is_number(found):
        hint = f"; name one component, e.g. {key}.0" if isinstance(found, list) else ""
        raise bad("--fit", key, f"a key whose value is a number, but {key} = {_show(found)}{hint}")


def parameter_of(scenario: Scenario, key: str) -> Parameter:
    """The ``Parameter`` of a dotted ``key`` of ``scenario``: bounds and start from ``[calibrate]``
    (start: the file's value unless given), else the key's ``uniform`` or ``loguniform`` range in
    ``[randomize]`` with the file's value as start. Raises a one-line ``SoftrnnInputError`` naming
    ``--fit`` for an unknown or non-numeric key, a key without bounds, or bounds that exclude the start."""
    _check_key(scenario, key)
    kind, found = _lookup(scenario.data, key)
    if key in scenario.calibrate:
        lower, upper, start = scenario.calibrate[key]
        start = float(found) if start is None else start
        where = "[calibrate]"
    elif key in scenario.randomize and scenario.randomize[key][0] in ("uniform", "loguniform"):
        lower, upper = scenario.randomize[key][1]
        start, where = float(found), f"its {scenario.randomize[key][0]} range in [randomize]"
        if not lower < upper:
            raise bad("--fit", key, f"bounds with lower < upper, but {where} is [{lower:g}, {upper:g}]; give "
                                    f"bounds in [calibrate]: \"{key}\" = {{ bounds = [lo, hi] }}")
    else:
        raise bad("--fit", key, f"bounds for this key: add \"{key}\" = {{ bounds = [lo, hi] }} to the scenario's "
                                f"[calibrate] table (a uniform or loguniform range in [randomize] also serves)")
    if not lower <= start <= upper:
        raise bad("--fit", key, f"bounds that hold the start {start:g}, but {where} gives [{lower:g}, {upper:g}]; "
                                f"widen the bounds in [calibrate] or give another start")
    return Parameter(key, start, lower, upper)


def parameters_of(scenario: Scenario, keys) -> list[Parameter]:
    """``parameter_of`` for every key of ``keys`` (a list, or a comma-separated string), each once."""
    if isinstance(keys, str):
        keys = [k.strip() for k in keys.split(",")]
    keys = list(keys)
    if not keys or any(not isinstance(k, str) or not k for k in keys):
        raise bad("--fit", ",".join(map(str, keys)), "KEY[,KEY...]: dotted keys of the scenario, e.g. "
                                                     "rod.youngs_modulus,damping.translational")
    if len(set(keys)) != len(keys):
        raise bad("--fit", ",".join(keys), "each key once")
    return [parameter_of(scenario, k) for k in keys]


def _corners(parameters: list[Parameter]) -> list[tuple]:
    """The starts, and the corners of the bounds box (2^n of them up to ``MAX_CORNER_DIMENSIONS``
    keys; beyond, each bound alone with the other keys at their starts)."""
    start = tuple(p.start for p in parameters)
    if len(parameters) <= MAX_CORNER_DIMENSIONS:
        return [start] + list(itertools.product(*[(p.lower, p.upper) for p in parameters]))
    points = [start]
    for i, p in enumerate(parameters):
        for bound in (p.lower, p.upper):
            points.append(start[:i] + (bound,) + start[i + 1:])
    return points


def fixed_substeps(scenario: Scenario, parameters: list[Parameter], dt: float) -> int:
    """Solver steps per sample of ``dt`` [s] for every trial: where the scenario sets ``run.substeps``,
    as many as keep its solver step ``run.dt / run.substeps`` (the same count at the same ``dt``),
    else the largest stable count over the start and the corners of the bounds box."""
    if scenario.config.substeps is not None:
        step = scenario.config.dt / scenario.config.substeps
        return max(1, math.ceil(dt / step * (1 - 1e-9)))
    names = [p.name for p in parameters]
    config = RunConfig(dt=dt, n_samples=2, safety=scenario.config.safety, integrator=scenario.config.integrator)
    most = 1
    for point in _corners(parameters):
        values = dict(zip(names, point))
        try:
            trial = scenario.with_values(values)
        except ScenarioError as err:
            raise SoftrnnInputError(f"--fit: the scenario does not build at the corner {_show(values)} of the "
                                    f"bounds ({one_line(err)}); narrow the bounds") from None
        most = max(most, Simulator(trial.setup).resolve_substeps(config))
    return most


# --------------------------------------------------------------------------------------------- data
@dataclass(frozen=True)
class Span:
    """The samples ``first`` .. ``stop - 1`` the residuals cover, and how they were asked for
    (``label``: ``train``, ``all`` or ``T0:T1``)."""

    first: int
    stop: int
    label: str

    def to_dict(self, time: np.ndarray) -> dict:
        """JSON-ready: label, sample range [first, stop) and its times [s]."""
        return {"label": self.label, "samples": [self.first, self.stop], "start_s": float(time[self.first]),
                "stop_s": float(time[self.stop - 1])}


def resolve_span(span: str, time: np.ndarray, dt: float) -> Span:
    """The ``Span`` of ``span`` (``train``, ``all`` or ``T0:T1`` in seconds, both ends included; an
    empty end: the data's) over sample ``time`` (T,) [s] spaced ``dt``; at least 2 samples."""
    T = int(time.shape[0])
    end = float(time[-1])
    expected = (f"train (the first {100 * TRAIN_FRACTION:.0f} % of the samples), all, or T0:T1 in seconds "
                f"with 0 <= T0 < T1 <= {end:g} (the data's end)")
    if not isinstance(span, str):
        raise bad("--span", span, expected)
    if span == "train":
        first, stop = 0, int(math.floor(TRAIN_FRACTION * T))
    elif span == "all":
        first, stop = 0, T
    else:
        parts = span.split(":")
        try:
            if len(parts) != 2:
                raise ValueError
            t0 = float(parts[0]) if parts[0].strip() else 0.0
            t1 = float(parts[1]) if parts[1].strip() else end
        except ValueError:
            raise bad("--span", span, expected) from None
        tol = TIME_TOLERANCE * dt
        if not (math.isfinite(t0) and math.isfinite(t1) and 0 <= t0 < t1 <= end + tol):
            raise bad("--span", span, expected)
        first = int(np.searchsorted(time, t0 - tol, side="left"))
        stop = int(np.searchsorted(time, t1 + tol, side="right"))
    if stop - first < 2:
        raise bad("--span", span, f"a span of at least 2 samples (it holds {max(stop - first, 0)} of the data's {T})")
    return Span(first, stop, span)


def check_dataset(scenario: Scenario, dataset, data: str, fitted=()) -> None:
    """Refuse data that do not match ``scenario`` (a one-line ``SoftrnnInputError`` naming DATA):
    another node count (the dataset's rod, or nodes beyond the scenario's rod), another rod length
    (unless ``rod.length`` is ``fitted``), or sample times off the grid k dt from t = 0."""
    n = scenario.setup.rod.n_nodes
    rod = dataset.attrs.get("rod")
    rod = rod if isinstance(rod, dict) else {}
    if isinstance(rod.get("n_nodes"), int) and rod["n_nodes"] != n:
        raise bad("DATA", data, f"data of the scenario's rod, but the dataset's rod has {rod['n_nodes']} nodes and "
                                f"the scenario's {n} (rod.n_nodes); use a scenario of the rod that was recorded")
    if dataset.nodes.size == 0:
        raise bad("DATA", data, "a recording of at least one node")
    if int(dataset.nodes.min()) < 0 or int(dataset.nodes.max()) >= n:
        raise bad("DATA", data, f"nodes of the scenario's {n}-node rod, but the dataset records nodes "
                                f"{int(dataset.nodes.min())}..{int(dataset.nodes.max())}")
    length = scenario.setup.rod.length
    if _is_number(rod.get("length")) and "rod.length" not in fitted and abs(rod["length"] / length - 1) > 1e-6:
        raise bad("DATA", data, f"data of the scenario's rod, but the dataset's rod is {rod['length']:g} m long and "
                                f"the scenario's {length:g} m (rod.length)")
    time, dt = dataset.time, dataset.dt
    if time.size < 3 or not dt > 0:
        raise bad("DATA", data, f"a recording of at least 3 samples (it has {time.size})")
    off = np.abs(time - dt * np.arange(time.size))
    bad_k = np.flatnonzero(off > TIME_TOLERANCE * dt)
    if bad_k.size:
        k = int(bad_k[0])
        raise bad("DATA", data, f"samples every dt = {dt:g} s from t = 0 (the scenario's initial state), but sample "
                                f"{k} is at t = {time[k]:.9g} s, not {k * dt:.9g} s; resample the recording onto "
                                f"that grid")


def _nodes(dataset, nodes) -> tuple[list[int], np.ndarray]:
    """(rod node indices, their columns in the dataset) of ``nodes`` (None: every recorded node)."""
    if nodes is None:
        return [int(a) for a in dataset.nodes], np.arange(dataset.nodes.size)
    total = int(dataset.attrs.get("n_nodes_total", int(dataset.nodes.max()) + 1))
    lookup = {int(a): j for j, a in enumerate(dataset.nodes)}
    picked = []
    for a in nodes:
        node = int(a) + total if int(a) < 0 else int(a)
        if node not in lookup:
            raise bad("--nodes", a, f"a recorded node (the data record {_show([int(x) for x in dataset.nodes])})")
        if node in picked:
            raise bad("--nodes", a, "each node once")
        picked.append(node)
    return picked, np.array([lookup[a] for a in picked], dtype=np.int64)


# -------------------------------------------------------------------------------------------- model
@lru_cache(maxsize=4)
def _base(text: str, source: str) -> Scenario:
    """The scenario of ``text`` (parsed once per process, also on a Dask worker)."""
    return parse_scenario(text, source)


@dataclass(frozen=True, eq=False)
class ScenarioModel:
    """The calibration's simulator (picklable, for Dask workers): ``model(values)`` builds the
    scenario of ``text`` with ``keys`` set to ``values``, runs it from t = 0 for ``stop`` samples
    ``dt`` [s] apart with ``substeps`` solver steps each, saving ``nodes``, and returns their
    positions over samples ``first`` .. ``stop - 1`` divided by ``length`` [m], flattened
    ((stop - first) * len(nodes) * 3,)."""

    text: str
    source: str
    keys: tuple
    dt: float
    first: int
    stop: int
    substeps: int
    nodes: tuple
    length: float

    def positions(self, values) -> np.ndarray:
        """Positions (stop - first, len(nodes), 3) [m] of the recorded nodes over the span."""
        base = _base(self.text, self.source)
        trial = base.with_values(dict(zip(self.keys, (float(v) for v in values))))
        config = RunConfig(dt=self.dt, n_samples=self.stop, substeps=self.substeps, save_nodes=self.nodes,
                           safety=base.config.safety, integrator=base.config.integrator)
        traj = Simulator(trial.setup).run(config)
        return np.asarray(traj.positions[self.first:], dtype=np.float64)

    def __call__(self, values) -> np.ndarray:
        return (self.positions(values) / self.length).ravel()


# ------------------------------------------------------------------------------------------- result
def position_errors(predicted: np.ndarray, measured: np.ndarray, length: float) -> dict:
    """Distances |predicted - measured| per sample and node of (S, N, 3) [m] arrays: their rms and
    max over the span, in m and in % of ``length``."""
    d = np.linalg.norm(predicted - measured, axis=-1)
    rms, top = float(np.sqrt(np.mean(d ** 2))), float(np.max(d))
    return {"rms_m": rms, "max_m": top, "rms_percent_of_length": 100 * rms / length,
            "max_percent_of_length": 100 * top / length}


@dataclass(frozen=True, eq=False)
class CalibrationProblem:
    """A calibration checked and ready to run (``prepare``): the ``parameters``, the ``model``, the
    ``span`` with its ``time`` (S,) [s], the fitted ``nodes``, their ``measured`` positions (S, N, 3)
    [m], and the ``fingerprint`` that names its trials in a cache folder."""

    parameters: list
    model: ScenarioModel
    span: Span
    time: np.ndarray
    nodes: tuple
    measured: np.ndarray
    fingerprint: str


@dataclass(frozen=True, eq=False)
class ScenarioCalibration(CalibrationProblem):
    """A finished calibration of a scenario to a dataset: the ``CalibrationProblem`` it solved
    (``parameters``, ``model``, ``span``, ``time``, ``nodes``, ``measured``, ``fingerprint``) with
    its fit.

    Attributes
    ----------
    result : FitResult
        the fit
    start, fitted : (S, N, 3) [m]
        positions of the fitted nodes: the start's and the fit's predictions
    """

    result: FitResult
    start: np.ndarray
    fitted: np.ndarray

    def values(self) -> dict:
        """{key: fitted value}."""
        return self.result.values()

    def errors(self) -> dict:
        """{"start": ..., "fitted": ...}: ``position_errors`` of the start's and the fit's predictions."""
        L = self.model.length
        return {"start": position_errors(self.start, self.measured, L),
                "fitted": position_errors(self.fitted, self.measured, L)}

    def to_dict(self) -> dict:
        """JSON-ready report (docs/calibration-format.md) without the input and output paths."""
        r = self.result
        names = list(r.names)
        return {
            "softrnn_version": __version__,
            "parameters": {p.name: {"start": p.start, "fitted": float(f), "std_error": float(e), "lower": p.lower,
                                    "upper": p.upper, "log_scale": p.log}
                           for p, f, e in zip(self.parameters, r.fitted, r.std_error)},
            "correlation": {a: {b: float(r.correlation[i, j]) for j, b in enumerate(names)}
                            for i, a in enumerate(names)},
            "not_identifiable": list(r.not_identifiable),
            "error": self.errors(),
            "span": self.span.to_dict(self.time),
            "nodes": list(self.nodes), "dt_s": self.model.dt, "substeps": self.model.substeps,
            "length_m": self.model.length, "measurements": r.measurements,
            "trials": r.trials, "failed_trials": r.failed_trials, "cached_trials": r.cached_trials,
            "evaluations": r.evaluations, "seconds": r.seconds, "converged": r.success, "message": r.message,
            "history": [{"trial": t, "rms_percent_of_length": 100 * rms, "values": v} for t, rms, v in r.history],
        }


def prepare(scenario: Scenario, dataset, keys, *, span: str = "train", nodes=None,
            data: str = "DATA") -> CalibrationProblem:
    """Check everything about fitting the dotted ``keys`` of ``scenario`` to the positions of
    ``dataset`` (a ``softrnn.io.Dataset`` of the same rod, named ``data`` in errors) over ``span``
    (``resolve_span``) for the recorded ``nodes`` (None: all), before any long work; one-line
    ``SoftrnnInputError`` for anything wrong (a magnetic scenario is refused: the fit runs the plain
    rod simulator)."""
    if getattr(scenario, "magnetic", None) is not None:
        raise bad("scenario", scenario.name, "a plain rod scenario: softrnn calibrate does not fit magnetic "
                                             "scenarios (the manipulator's rod and loads are set in [magnetic])")
    parameters = parameters_of(scenario, keys)
    names = [p.name for p in parameters]
    check_dataset(scenario, dataset, data, names)
    dt = float(dataset.dt)
    sp = resolve_span(span, dataset.time, dt)
    picked, cols = _nodes(dataset, nodes)
    length = float(scenario.setup.rod.length)
    model = ScenarioModel(text=scenario.text, source=scenario.source, keys=tuple(names), dt=dt, first=sp.first,
                          stop=sp.stop, substeps=fixed_substeps(scenario, parameters, dt), nodes=tuple(picked),
                          length=length)
    measured = np.asarray(dataset.positions[sp.first:sp.stop][:, cols], dtype=np.float64)   # (S, N, 3) m
    fingerprint = hashlib.sha256(b"".join([
        scenario.text.encode(), repr((scenario.source, names, [(p.start, p.lower, p.upper) for p in parameters],
                                      dt, sp.first, sp.stop, model.substeps, picked, length)).encode(),
        np.ascontiguousarray(measured).tobytes()])).hexdigest()
    return CalibrationProblem(parameters=parameters, model=model, span=sp,
                              time=np.asarray(dataset.time[sp.first:sp.stop], dtype=np.float64), nodes=tuple(picked),
                              measured=measured, fingerprint=fingerprint)


def run(problem: CalibrationProblem, *, evaluator=None, options: FitOptions | None = None, progress=None,
        cache_dir=None) -> ScenarioCalibration:
    """Fit a prepared problem (``softrnn.fitting.fit``): evaluator : where the simulations run
    (None: this process); options : ``FitOptions``; progress : ``progress(trials, budget, info)``;
    cache_dir : a folder keeping every trial, to resume an interrupted calibration."""
    L = problem.model.length
    result = fit(problem.model, (problem.measured / L).ravel(), problem.parameters, evaluator=evaluator,
                 options=options, progress=progress, cache_dir=cache_dir, fingerprint=problem.fingerprint)
    shape = problem.measured.shape
    return ScenarioCalibration(**vars(problem), result=result, start=result.prediction_start.reshape(shape) * L,
                               fitted=result.prediction_fitted.reshape(shape) * L)


def calibrate_scenario(scenario: Scenario, dataset, keys, *, span: str = "train", nodes=None, data: str = "DATA",
                       evaluator=None, options: FitOptions | None = None, progress=None,
                       cache_dir=None) -> ScenarioCalibration:
    """``prepare`` and ``run`` in one call: the dotted ``keys`` of ``scenario`` fitted to ``dataset``."""
    problem = prepare(scenario, dataset, keys, span=span, nodes=nodes, data=data)
    return run(problem, evaluator=evaluator, options=options, progress=progress, cache_dir=cache_dir)


# ------------------------------------------------------------------------------------ fitted file
def fitted_text(text: str, values: dict, header: str) -> str:
    """The scenario ``text`` with each dotted key of ``values`` set to its value, comments and layout
    kept (``softrnn.scenarios.calibrate.edited_text``), below the comment line ``header`` (which
    starts with ``HEADER``; an earlier calibration's header line is replaced)."""
    lines = edited_text(text, {key: float(value) for key, value in values.items()}).splitlines(keepends=True)
    while lines and lines[0].startswith(HEADER):
        lines.pop(0)
    return header.rstrip("\n") + "\n" + "".join(lines)
