"""A node model's predictions of a data set and their errors (paper section 4, Eq. 2): one step
ahead (``one_step``: every window from the reference) and free running (``free_running``: the
node's own history from its predictions, its neighbours and wrenches from the reference), over
the span ``evaluation_span`` chooses; per axis the largest and mean absolute error [mm], the
largest as % of the rod length, RMSE(t) (Eq. 2) and the Euclidean tip error (``ErrorMetrics``).
The report around them: ``softrnn.learned.node.evaluate``."""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ...errors import SoftrnnInputError, bad
from ..metrics import euclidean_errors, euclidean_summary
from ..spans import check_length
from .data import make_windows, split
from .rollout import rollout

UNIT = "mm"
"""Unit of every reported position error (and of RMSE(t))."""


# ------------------------------------------------------------------------------------------ metrics
@dataclass(frozen=True, eq=False)
class ErrorMetrics:
    """Errors of a predicted position series against the reference.

    Attributes
    ----------
    max_abs_mm, mean_abs_mm : ndarray (3,) float64
        Largest and mean |predicted - reference| per axis x, y, z [mm].
    max_pct_of_length : ndarray (3,) float64 or None
        ``max_abs`` as a percentage of the rod length [%] (None when the length is unknown).
    rmse_mm : float
        Root mean square error over every target and axis [mm] (= sqrt(mean_t RMSE(t)^2)).
    rmse_t_mm : ndarray (T,) float64
        RMSE(t) of paper Eq. 2 per target [mm].
    rmse_euclidean_mm : float
        The Euclidean RMSE of the position, sqrt(mean_t |p - p_ref|^2) [mm], as robotics papers
        report a tip error (= sqrt(3) ``rmse_mm``).
    mean_euclidean_mm : float
        The mean Euclidean distance mean_t |p - p_ref| [mm].
    rod_length_m : float or None
        The rod length [m] of the percentages (None: unknown).
    """

    max_abs_mm: np.ndarray
    mean_abs_mm: np.ndarray
    max_pct_of_length: np.ndarray | None
    rmse_mm: float
    rmse_t_mm: np.ndarray
    rmse_euclidean_mm: float = math.nan
    mean_euclidean_mm: float = math.nan
    rod_length_m: float | None = None

    def summary(self) -> dict:
        """JSON-ready figures (lists [x, y, z]; RMSE(t) summarised by its largest value; then the
        Euclidean RMSE and mean error [mm] and, where the rod length is known, as % of it)."""
        pct = None if self.max_pct_of_length is None else [float(v) for v in self.max_pct_of_length]
        return {"max_abs_mm": [float(v) for v in self.max_abs_mm],
                "mean_abs_mm": [float(v) for v in self.mean_abs_mm],
                "max_pct_of_length": pct, "rmse_mm": float(self.rmse_mm),
                "max_rmse_t_mm": float(self.rmse_t_mm.max()) if self.rmse_t_mm.size else 0.0,
                **euclidean_summary(self.rmse_euclidean_mm, self.mean_euclidean_mm, self.rod_length_m)}


def metrics(predicted, reference, rod_length: float | None) -> ErrorMetrics:
    """Errors of ``predicted`` (T, 3) [m] against ``reference`` (T, 3) [m] (T >= 1) for a rod of
    ``rod_length`` [m] (None: no percentages). Computed in float64."""
    p = np.asarray(predicted, dtype=np.float64)
    r = np.asarray(reference, dtype=np.float64)
    if p.ndim != 2 or p.shape[1] != 3 or p.shape[0] < 1:
        raise bad("predicted", f"array of shape {p.shape}", "shape (T, 3) with T >= 1, positions in m")
    if r.shape != p.shape:
        raise bad("reference", f"array of shape {r.shape}", f"shape {p.shape} like predicted")
    if not (np.isfinite(p).all() and np.isfinite(r).all()):
        raise SoftrnnInputError("predicted or reference positions contain NaN or inf; check the model and the data")
    if rod_length is not None and not (isinstance(rod_length, (int, float, np.floating))
                                       and math.isfinite(rod_length) and rod_length > 0):
        raise bad("rod_length", rod_length, "a positive rod length in m, or None")
    err_mm = (p - r) * 1e3                                                   # (T, 3) mm
    abs_mm = np.abs(err_mm)
    max_abs = abs_mm.max(axis=0)
    with np.errstate(under="ignore"):
        sq = err_mm ** 2
        rmse_t = np.sqrt(sq.mean(axis=1))                                    # (T,) Eq. 2
        rmse = float(np.sqrt(sq.mean()))
    pct = None if rod_length is None else max_abs / (float(rod_length) * 1e3) * 100.0
    e_rmse, e_mean = euclidean_errors(p, r)
    return ErrorMetrics(max_abs_mm=max_abs, mean_abs_mm=abs_mm.mean(axis=0), max_pct_of_length=pct,
                        rmse_mm=rmse, rmse_t_mm=rmse_t, rmse_euclidean_mm=e_rmse, mean_euclidean_mm=e_mean,
                        rod_length_m=None if rod_length is None else float(rod_length))


# --------------------------------------------------------------------------------------- predictions
@dataclass(frozen=True, eq=False)
class Prediction:
    """One node's predicted positions against the reference.

    Attributes
    ----------
    kind : str
        ``"one step"`` or ``"free running"``.
    node : int
        The predicted node.
    index : ndarray (T,) int64
        Sample index of each target in the data set.
    time : ndarray (T,) float64
        Its time [s].
    predicted, reference : ndarray (T, 3) float64
        Positions [m]. Free-running predictions went through the rollout's float32 state (the
        data sets' precision, < 1e-7 m at these sizes); one-step ones are the model's float64 output.
    """

    kind: str
    node: int
    index: np.ndarray
    time: np.ndarray
    predicted: np.ndarray
    reference: np.ndarray

    def metrics(self, rod_length: float | None) -> ErrorMetrics:
        """The ``ErrorMetrics`` of ``predicted`` against ``reference`` (``metrics``) for a rod of
        ``rod_length`` [m] (None: no percentages of the length)."""
        return metrics(self.predicted, self.reference, rod_length)


def whole_record(model) -> bool:
    """True for a model trained on the whole of its training record, validated on another
    (``train_node_model(..., validation=...)``): its training record holds no test span."""
    sessions = (getattr(model, "meta", None) or {}).get("training_data")
    return isinstance(sessions, dict) and sessions.get("span") == "whole record"


def evaluation_span(model, n_samples: int, *, generalisation: bool = False) -> tuple[int, int]:
    """Sample span [start, stop) whose windows are evaluated: the test span of the model's split
    (``data.split``), or with ``generalisation`` (and always for a model trained on a whole record,
    ``whole_record``) the whole record. Targets are ``start+H .. stop-1``. Too short a record is a
    one-line SoftrnnInputError."""
    H = int(model.spec.history)
    if generalisation or whole_record(model):
        check_length(n_samples, H, advice="use a longer record")
        return 0, int(n_samples)
    test = split(int(n_samples), model.spec)[1]
    return int(test.start), int(test.stop)


def one_step(model, dataset, start: int | None = None, stop: int | None = None, *,
             batch_size: int = 4096) -> Prediction:
    """One-step-ahead predictions of every window inside samples [start, stop) (default: the test
    span), each from the reference history, ``batch_size`` windows per ``predict`` call."""
    if start is None or stop is None:
        s0, s1 = evaluation_span(model, dataset.n_samples)
        start = s0 if start is None else start
        stop = s1 if stop is None else stop
    w = make_windows(dataset, model.spec, int(start), int(stop))
    if len(w) == 0:
        raise SoftrnnInputError(f"samples {start}..{stop - 1} hold no window of history {model.spec.history}; "
                                f"widen the span")
    parts = [np.asarray(model.predict(w.poses[i:i + batch_size], w.wrenches[i:i + batch_size]), dtype=np.float64)
             for i in range(0, len(w), batch_size)]
    return Prediction(kind="one step", node=int(model.spec.node), index=w.index,
                      time=np.asarray(dataset.time, dtype=np.float64)[w.index],
                      predicted=np.concatenate(parts), reference=w.targets.astype(np.float64))


def free_running(model, dataset, start: int | None = None, stop: int | None = None, *,
                 progress=None) -> Prediction:
    """Free-running predictions of the same targets as ``one_step(model, dataset, start, stop)``:
    the node's history from its own predictions (seeded with the reference samples start ..
    start+H-1), its neighbours and wrenches from the reference."""
    if start is None or stop is None:
        s0, s1 = evaluation_span(model, dataset.n_samples)
        start = s0 if start is None else start
        stop = s1 if stop is None else stop
    H = int(model.spec.history)
    result = rollout(model, dataset, int(start) + H, int(stop), progress=progress)
    node = int(model.spec.node)
    col = int(np.flatnonzero(np.asarray(dataset.nodes) == node)[0])
    index = np.arange(result.start, result.stop, dtype=np.int64)
    return Prediction(kind="free running", node=node, index=index,
                      time=np.asarray(dataset.time, dtype=np.float64)[index],
                      predicted=result.node_positions(node),
                      reference=np.asarray(dataset.positions[index, col], dtype=np.float64))
