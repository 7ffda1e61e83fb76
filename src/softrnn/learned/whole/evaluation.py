"""Free-running errors of a whole-manipulator model beside persistence, constant velocity and the
linear model on the same inputs, at every node (NumPy only).

Every predictor steps the encoded state (``Encoding``) at the model's step: persistence (the state
stays) and constant velocity (the last step repeats), the baselines of ``softrnn.learned.baselines``
behind ``StateBaseline`` (``state_baselines``), the linear model and the learned model
(``DynamicEngine``). The free run (``baselines.free_run``), the evaluation by horizon
(``horizons.worst_by_horizon``) and the span checks (``softrnn.learned.spans``) are those of the
node models; the error measure is this model's own. A free run starts from the data's history at a
model step and feeds its own predictions back; the loads are the data's. Errors are measured at
**every node** of the rod (the kept nodes' states decoded and interpolated along the rod,
``Encoding.positions``) against the data's positions at the model's step times, as the largest
distance over the nodes, in % of the rod's length. A run that leaves the rod's range is *diverged*:
its errors are infinite from there on (reported as ``null`` with ``diverged_at``). On the test span
and the generalisation data the tip's (last node's) Euclidean error is reported too, as robotics
papers do: its RMSE sqrt(mean |p - p_ref|^2) and mean [mm] and % of the length, free running and one
step ahead (each step from the data's history, ``one_step``).
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import partial
from typing import final

import numpy as np

from ..baselines import ConstantVelocity, Persistence, StateBaseline, free_run
from ..horizons import WHOLE_HORIZON_STARTS, WHOLE_HORIZONS, HorizonTable, RolloutDiverged, horizon_table
from ..metrics import euclidean_summary, tip_errors
from ..spans import check_step_start, start_of_test_span
from .encoding import Encoding, Trajectory
from .engine import DIVERGED_M

HORIZONS = WHOLE_HORIZONS
"""The horizons of ``evaluate_dynamic`` [model steps]: 10, 100, 1000 (``softrnn.learned.horizons``)."""

BASELINES = ("persistence", "constant_velocity", "linear")
"""The baselines reported beside the model, in report order: their JSON keys."""

HORIZON_STARTS = WHOLE_HORIZON_STARTS
"""Free-running starts per trajectory and horizon, spread evenly over each trajectory: 4, the count
of the published reports (``softrnn.learned.horizons.WHOLE_HORIZON_STARTS``), passed explicitly in
place of the shared default ``softrnn.learned.horizons.HORIZON_STARTS``."""


def state_baselines() -> dict[str, StateBaseline]:
    """{'persistence', 'constant_velocity'}: the simple baselines of ``softrnn.learned.baselines``
    stepping the encoded state (history 2)."""
    return {"persistence": StateBaseline(Persistence()), "constant_velocity": StateBaseline(ConstantVelocity())}


def node_errors(encoding: Encoding, states: np.ndarray, truth: np.ndarray) -> np.ndarray:
    """Largest position error over all nodes at each step (K,) [m]: ``states`` (K, M, 6) decoded to
    every node against ``truth`` (K, N, 3) [m]; inf where ``states`` is NaN (diverged)."""
    ok = np.all(np.isfinite(states), axis=(1, 2))
    err = np.full(len(states), np.inf)
    if ok.any():
        p = encoding.positions(states[ok])
        err[ok] = np.linalg.norm(p - truth[ok], axis=-1).max(axis=1)
    return err


def truth_positions(dataset, encoding: Encoding, steps: np.ndarray) -> np.ndarray:
    """The data's positions of every node at model steps ``steps`` (K, N, 3) [m]."""
    k = encoding.stride(float(dataset.dt))
    return np.asarray(dataset.positions[np.asarray(steps) * k], dtype=np.float64)


def run_errors(predictor, encoding: Encoding, traj: Trajectory, dataset, start: int, stop: int | None = None):
    """(errors (K,) [% of L] at steps start+1 .. stop-1, diverged step or None) of one free run."""
    try:
        states, diverged = free_run(predictor, traj, None, start + 1, traj.n_steps if stop is None else stop), None
    except RolloutDiverged as exc:                      # its states: NaN from the divergence on
        states, diverged = exc.states, exc.sample - start
    steps = np.arange(start + 1, start + 1 + len(states))
    err = node_errors(encoding, states, truth_positions(dataset, encoding, steps))
    return 100.0 * err / encoding.length, diverged


def _pct(value: float) -> float | None:
    return None if not np.isfinite(value) else float(value)


def _spread(values: list) -> dict:
    """Median and worst of span errors (None = diverged counts as infinite)."""
    v = [np.inf if x is None else x for x in values]
    return {"median_max_pct_of_length": _pct(float(np.median(v))), "worst_max_pct_of_length": _pct(float(np.max(v)))}


def span_error(predictor, encoding, traj, dataset, start: int, *, tip: bool = False) -> dict:
    """The largest error over all nodes from ``start`` to the end: {max_pct_of_length, diverged_at,
    steps}; with ``tip`` also the tip's Euclidean errors free running (``tip_summary``: None where the
    run diverged) and one step ahead (``one_step``: each step from the data's history)."""
    try:
        states, diverged = free_run(predictor, traj, None, start + 1, traj.n_steps), None
    except RolloutDiverged as exc:                      # its states: NaN from the divergence on
        states, diverged = exc.states, exc.sample - start
    steps = np.arange(start + 1, start + 1 + len(states))
    truth = truth_positions(dataset, encoding, steps)
    err = 100.0 * node_errors(encoding, states, truth) / encoding.length
    out = {"max_pct_of_length": _pct(err.max()), "diverged_at": diverged, "steps": int(len(err))}
    if tip:
        out.update(tip_summary(encoding, states, truth))
        out["one_step"] = tip_summary(encoding, one_step(predictor, traj, start), truth)
    return out


def one_step(predictor, traj: Trajectory, start: int, stop: int | None = None) -> np.ndarray:
    """One-step-ahead states (stop - start - 1, M, 6) of steps start+1 .. stop-1 (default: to the
    end), each from the data's ``history`` states before it (a memory, if the predictor keeps one,
    carried along); rows of a step that leaves the rod's range are NaN."""
    H = int(predictor.history)
    stop = traj.n_steps if stop is None else int(stop)
    check_step_start(start, H, stop)
    out = np.full((stop - start - 1,) + traj.states.shape[1:], np.nan)
    memory = None
    for i, j in enumerate(range(start, stop - 1)):
        hist = traj.states[j - H + 1:j + 1]
        u = traj.inputs(hist, j)
        nxt, memory = predictor.step(hist, u, memory)
        traj.follow(nxt, hist[-1], u)
        if np.all(np.abs(nxt) < DIVERGED_M):
            out[i] = nxt
    return traj.projected(out)


def tip_summary(encoding: Encoding, states: np.ndarray, truth: np.ndarray) -> dict:
    """The tip's (the rod's last node's) ``softrnn.learned.metrics.tip_errors`` of ``states`` (K, M, 6)
    against ``truth`` (K, N, 3) [m], as ``TipErrors.summary()`` (% of the rod length); every value
    None where a state is NaN (diverged)."""
    if len(states) == 0 or not np.all(np.isfinite(states)):
        return dict.fromkeys(euclidean_summary(0.0, 0.0, None))
    return tip_errors(encoding.positions(states)[:, -1], truth[:, -1], encoding.length).summary()


def _run_worst(predictor, encoding, runs: list, span: int, start: int, n: int) -> float:
    """``worst_by_horizon``'s error of a whole-model run: the largest error [% of L] over every node
    within ``n`` free steps from ``start`` of ``runs[span]`` (inf: diverged)."""
    traj, dataset = runs[span]
    err, _ = run_errors(predictor, encoding, traj, dataset, int(start), int(start) + n + 1)
    return float(err.max())


def first_start(*predictors) -> int:
    """The first model step every predictor can start from (its history fits before it)."""
    return max(int(p.history) for p in predictors) - 1


def step_at(time: np.ndarray, seconds: float) -> int:
    """The last model step of ``time`` (a trajectory's step times [s]) at or before ``seconds``, to
    within 1e-9 of the time scale (-1 before the first step).

    Parameters
    ----------
    time : numpy.ndarray
        The step times (n_steps,), increasing (``Trajectory.time``).
    seconds : float
        A time on the same axis [s].
    """
    eps = 1e-9 * max(1.0, abs(float(time[-1])))
    return int(np.searchsorted(time, float(seconds) + eps, side="right")) - 1


def compare(predictors: dict, encoding, runs: list, horizons=HORIZONS,
            n_starts: int = HORIZON_STARTS) -> HorizonTable:
    """The ``"within"`` ``HorizonTable`` of ``predictors`` ({name: predictor}, e.g. the model and the
    three baselines) on ``runs`` [(Trajectory, Dataset)]: the largest error [% of L] over every node
    within h free steps, the worst over the runs and ``n_starts`` starts in each
    (``softrnn.learned.horizons.horizon_table``); to_dict {str(h): {name: value or None}}."""
    spans = {name: [(max(int(p.history) - 1, 2), traj.n_steps - 1) for traj, _ in runs]   # its history fits
             for name, p in predictors.items()}
    errors = {name: partial(_run_worst, p, encoding, runs) for name, p in predictors.items()}
    return horizon_table(errors, spans, horizons, n_starts, kind="within")


@final
@dataclass(frozen=True)
class DynamicEvaluation:
    """The result of ``evaluate_dynamic``; ``to_dict()`` is the JSON report."""

    model_dt_s: float
    """The model's step [s]."""
    predicted_nodes: int
    """The nodes the model steps."""
    nodes: int
    """The rod's nodes."""
    length_m: float
    """The rod's length [m]."""
    history: int
    """The model's history [model steps]."""
    test_span: dict | None
    """{start_s, end_s, name: span errors} on the test trajectory (None: no test trajectory)."""
    heldout: dict | None
    """{variants, median/worst_max_pct_of_length, per_variant, baselines} (None: no held-out data)."""
    horizons: HorizonTable | None
    """The model's and the baselines' errors by horizon on the held-out data."""
    generalisation: dict | None
    """{name: span errors} on the generalisation scenario (None: not given)."""

    def to_dict(self) -> dict:
        """``model_dt_s``, ``predicted_nodes``, ``nodes``, ``length_m``, ``history``, then where
        evaluated ``test_span`` and ``test_span_max_pct_of_length``, ``heldout`` and ``horizons``,
        ``generalisation`` and ``generalisation_max_pct_of_length``."""
        out = {"model_dt_s": self.model_dt_s, "predicted_nodes": self.predicted_nodes, "nodes": self.nodes,
               "length_m": self.length_m, "history": self.history}
        if self.test_span is not None:
            out["test_span"] = self.test_span
            out["test_span_max_pct_of_length"] = self.test_span["model"]["max_pct_of_length"]
        if self.heldout is not None:
            out["heldout"] = self.heldout
            out["horizons"] = self.horizons.to_dict()
        if self.generalisation is not None:
            out["generalisation"] = self.generalisation
            out["generalisation_max_pct_of_length"] = self.generalisation["model"]["max_pct_of_length"]
        return out


def evaluate_dynamic(model, *, test=None, heldout=(), generalisation=None, test_start_fraction: float = 0.6,
                     horizons=HORIZONS, test_start_time: float | None = None,
                     horizon_starts: int = HORIZON_STARTS) -> DynamicEvaluation:
    """The free-running evaluation of a loaded model (``load_dynamic``) beside its baselines
    (docs/guide/dynamic.md): ``test`` (a Dataset or None) run free from ``test_start_fraction`` of it
    (or from the model step at ``test_start_time`` [s], ``step_at``) to its end; each of ``heldout``
    (Datasets the model never saw) run free from its start, and the ``horizons`` [model steps] table
    over them with ``horizon_starts`` starts per trajectory (``compare``); ``generalisation`` (a Dataset
    or None) run free from its start. Every baseline beside the model; on the test span and the
    generalisation data the tip's Euclidean errors too (``tip_summary``), free running and one step
    ahead. Returns a ``DynamicEvaluation`` (``to_dict()``: the JSON report)."""
    enc, engine, linear = model.encoding, model.engine, model.linear
    preds = {"model": engine, **state_baselines(), "linear": linear}
    s0 = first_start(*preds.values())
    test_span = held = table = general = None
    if test is not None:
        traj = enc.trajectory(test)
        start = start_of_test_span(s0, traj.n_steps, test_start_fraction) if test_start_time is None else \
            max(s0, step_at(traj.time, test_start_time))
        spans = {name: span_error(p, enc, traj, test, start, tip=True) for name, p in preds.items()}
        test_span = {"start_s": float(traj.time[start]), "end_s": float(traj.time[-1]), "tip_node": enc.n_nodes - 1,
                     **spans}
    runs = [(enc.trajectory(d), d) for d in heldout]
    if runs:
        per = {name: [span_error(p, enc, t, d, s0)["max_pct_of_length"] for t, d in runs]
               for name, p in preds.items()}
        held = {"variants": len(runs), **_spread(per["model"]), "per_variant": per["model"],
                "baselines": {name: _spread(per[name]) for name in BASELINES}}
        table = compare(preds, enc, runs, horizons, horizon_starts)
    if generalisation is not None:
        traj = enc.trajectory(generalisation)
        general = {"tip_node": enc.n_nodes - 1,
                   **{name: span_error(p, enc, traj, generalisation, s0, tip=True) for name, p in preds.items()}}
    return DynamicEvaluation(model_dt_s=enc.model_dt, predicted_nodes=enc.n_predicted, nodes=enc.n_nodes,
                             length_m=enc.length, history=int(engine.history), test_span=test_span, heldout=held,
                             horizons=table, generalisation=general)
