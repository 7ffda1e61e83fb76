"""Free-running errors of a whole-manipulator model beside persistence, constant velocity and the
linear model on the same inputs, at every node (NumPy only).

Every predictor steps the encoded state (``Encoding``) at the model's step: ``Persistence`` (the
state stays), ``ConstantVelocity`` (the last step repeats), the linear model and the learned model
(``DynamicEngine``). A free run starts from the data's history at a model step and feeds its own
predictions back; the loads are the data's. Errors are measured at **every node** of the rod (the
kept nodes' states decoded and interpolated along the rod, ``Encoding.positions``) against the
data's positions at the model's step times, as the largest distance over the nodes, in % of the
rod's length. A run that leaves the rod's range is *diverged*: its errors are infinite from there
on (reported as ``null`` with ``diverged_at``).
"""

from __future__ import annotations

import numpy as np

from ...errors import bad
from .encoding import Encoding, Trajectory
from .engine import DIVERGED_M

HORIZONS = (10, 100, 1000)
BASELINES = ("persistence", "constant_velocity", "linear")
_STARTS = 4


class Persistence:
    """Next state = current state."""

    history = 2

    def step(self, hist, loads, memory=None):
        """hist (H, M, 6) -> (its last state, None)."""
        return hist[-1].copy(), None


class ConstantVelocity:
    """Next state = current state + the last step's change."""

    history = 2

    def step(self, hist, loads, memory=None):
        """hist (H, M, 6) -> (2 x_t - x_(t-1), None)."""
        return 2 * hist[-1] - hist[-2], None


def free_run(predictor, traj: Trajectory, start: int, stop: int | None = None) -> tuple[np.ndarray, int | None]:
    """Run ``predictor`` free from model step ``start`` (the last history state) to ``stop``
    (exclusive; default: the end): states (stop - start - 1, M, 6) of steps start+1 .. stop-1 and
    the step (1-based) where it diverged, or None. Rows from a divergence on are NaN. The loads are
    the data's, with the trajectory's feedback laws applied to the run's own states
    (``Trajectory.inputs``)."""
    H = int(predictor.history)
    stop = traj.n_steps if stop is None else int(stop)
    if start < H - 1 or start >= stop - 1:
        raise bad("start", start, f"a model step in [{H - 1}, {stop - 2}] (history {H}, {stop} steps)")
    hist = np.array(traj.states[start - H + 1:start + 1], dtype=np.float64)
    out = np.full((stop - start - 1,) + traj.states.shape[1:], np.nan)
    memory = None
    for k in range(stop - start - 1):
        nxt, memory = predictor.step(hist, traj.inputs(hist, start + k), memory)
        if not np.all(np.abs(nxt) < DIVERGED_M):
            return out, k + 1
        out[k] = nxt
        hist[:-1] = hist[1:]
        hist[-1] = nxt
    return out, None


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
    states, diverged = free_run(predictor, traj, start, stop)
    steps = np.arange(start + 1, start + 1 + len(states))
    err = node_errors(encoding, states, truth_positions(dataset, encoding, steps))
    return 100.0 * err / encoding.length, diverged


def _pct(value: float) -> float | None:
    return None if not np.isfinite(value) else float(value)


def _spread(values: list) -> dict:
    """Median and worst of span errors (None = diverged counts as infinite)."""
    v = [np.inf if x is None else x for x in values]
    return {"median_max_pct_of_length": _pct(float(np.median(v))), "worst_max_pct_of_length": _pct(float(np.max(v)))}


def span_error(predictor, encoding, traj, dataset, start: int) -> dict:
    """The largest error over all nodes from ``start`` to the end: {max_pct_of_length, diverged_at}."""
    err, diverged = run_errors(predictor, encoding, traj, dataset, start)
    return {"max_pct_of_length": _pct(err.max()), "diverged_at": diverged, "steps": int(len(err))}


def horizon_errors(predictor, encoding, runs: list, horizons=HORIZONS, n_starts: int = _STARTS) -> dict:
    """Largest error [% of L] over all nodes within ``n`` free steps, the worst over ``runs`` (a list
    of (Trajectory, Dataset)) and over up to ``n_starts`` evenly spaced starts in each; None where
    no trajectory is long enough for ``n`` steps. {str(n): value}."""
    H = int(predictor.history)
    out = {}
    for n in horizons:
        worst, any_run = 0.0, False
        for traj, dataset in runs:
            last = traj.n_steps - 1 - n
            first = max(H - 1, 2)      # every predictor (history 2 or more) can start here
            if last < first:
                continue
            any_run = True
            for s in np.unique(np.linspace(first, last, n_starts).round().astype(int)):
                err, _ = run_errors(predictor, encoding, traj, dataset, int(s), int(s) + n + 1)
                worst = max(worst, float(err.max()))
        out[str(n)] = _pct(worst) if any_run else None
    return out


def first_start(*predictors) -> int:
    """The first model step every predictor can start from (its history fits before it)."""
    return max(int(p.history) for p in predictors) - 1


def compare(engine, linear, encoding, runs: list, horizons=HORIZONS) -> dict:
    """Horizon errors of the model and the three baselines on ``runs``:
    {str(n): {"model", "persistence", "constant_velocity", "linear"}}."""
    preds = {"model": engine, "persistence": Persistence(), "constant_velocity": ConstantVelocity(),
             "linear": linear}
    table = {name: horizon_errors(p, encoding, runs, horizons) for name, p in preds.items()}
    return {str(n): {name: table[name][str(n)] for name in preds} for n in horizons}


def evaluate_dynamic(model, *, test=None, heldout=(), generalisation=None, test_start_fraction: float = 0.6,
                     horizons=HORIZONS) -> dict:
    """The free-running evaluation of a loaded model (``load_dynamic``) beside its baselines; a
    JSON-ready dict.

    Parameters
    ----------
    test : Dataset or None
        The paper trajectory: the model runs free from ``test_start_fraction`` of it to the end
        (its test span; the first part is where it was trained).
    heldout : sequence of Dataset
        Sweep variants the model never saw: each run free from its start, and the horizons.
    generalisation : Dataset or None
        The paper's generalisation scenario, run free from its start.

    Returns
    -------
    dict
        ``model_dt_s``, ``predicted_nodes``, ``nodes``, ``test_span`` and
        ``test_span_max_pct_of_length``, ``heldout`` {variants, per_variant, median/worst},
        ``generalisation`` and ``generalisation_max_pct_of_length``, ``horizons`` (model and
        baselines), with every baseline's span errors beside the model's.
    """
    enc, engine, linear = model.encoding, model.engine, model.linear
    preds = {"model": engine, "persistence": Persistence(), "constant_velocity": ConstantVelocity(), "linear": linear}
    s0 = first_start(*preds.values())
    out = {"model_dt_s": enc.model_dt, "predicted_nodes": enc.n_kept, "nodes": enc.n_nodes,
           "length_m": enc.length, "history": int(engine.history)}
    if test is not None:
        traj = enc.trajectory(test)
        start = max(s0, int(round(test_start_fraction * (traj.n_steps - 1))))
        spans = {name: span_error(p, enc, traj, test, start) for name, p in preds.items()}
        out["test_span"] = {"start_s": float(traj.time[start]), "end_s": float(traj.time[-1]), **spans}
        out["test_span_max_pct_of_length"] = spans["model"]["max_pct_of_length"]
    runs = [(enc.trajectory(d), d) for d in heldout]
    if runs:
        per = {name: [span_error(p, enc, t, d, s0)["max_pct_of_length"] for t, d in runs]
               for name, p in preds.items()}
        out["heldout"] = {"variants": len(runs), **_spread(per["model"]), "per_variant": per["model"],
                          "baselines": {name: _spread(per[name]) for name in BASELINES}}
        out["horizons"] = compare(engine, linear, enc, runs, horizons)
    if generalisation is not None:
        traj = enc.trajectory(generalisation)
        spans = {name: span_error(p, enc, traj, generalisation, s0) for name, p in preds.items()}
        out["generalisation"] = spans
        out["generalisation_max_pct_of_length"] = spans["model"]["max_pct_of_length"]
    return out
