"""Evaluation of a node model on a data set: errors per axis and RMSE(t) (paper section 4, Eq. 2).

Two kinds of prediction over the same targets:

* **one step ahead** (``one_step``), as the paper evaluates: every window is taken from the
  reference data (the node's and its neighbours' recorded history) and the model predicts the
  next position; errors never accumulate;
* **free running** (``free_running``): the node's own history comes from the model's previous
  predictions, seeded with the ``history`` reference samples before the first target; its
  neighbours' poses and its wrenches come from the reference data (a whole-manipulator rollout,
  where the neighbours are predicted too, is ``softrnn.surrogate.rollout``).

The span: the test span of the model's chronological split (``data.split``: the samples after the
first ``train_fraction``, windows inside it, so targets start ``history`` samples after the cut),
or with ``generalisation=True`` the whole record (a data set from another scenario that the model
never saw: the horizontal ellipse, new force profiles, the cosine push), targets from sample
``history`` on.

Per axis (x, y, z) the errors are reported as the paper does: the largest and the mean absolute
error [mm], the largest as a percentage of the rod length, and RMSE(t) = sqrt(((x_p - x_m)^2 +
(y_p - y_m)^2 + (z_p - z_m)^2) / 3) (Eq. 2) per target [mm]. The models predict positions only,
so no orientation errors (degrees) are reported.

Applying a model to a data set checks that it stores the model's node and neighbours, that the
units, the rod's node count and the sample interval match the model's training data, and that the
record is longer than the history; each problem is a one-line ``SoftrnnInputError``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ..errors import SoftrnnInputError, bad
from .manipulator import RolloutDiverged, _stored, describe_model, model_inputs
from .rollout import rollout

UNIT = "mm"
"""Unit of every reported position error (and of RMSE(t))."""

DT_TOLERANCE = 1e-3
"""Largest relative difference between the data set's and the model's sample interval."""

PAPER_KEYS = {
    # scenario name -> (paper case key, paper figures compared): used when the scenario text has no
    # [paper] table
    "ellipse": ("ellipse", "test"), "ellipse-horizontal": ("ellipse", "generalisation"),
    "square": ("square_tip", "test"), "square-circle": ("square_tip", "generalisation"),
    "square-figure8": ("square_tip", "generalisation"), "square-random": ("square_tip", "generalisation"),
    "semicircle": ("semicircle", "test"), "semicircle-cosine": ("semicircle", "generalisation"),
}


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
    """

    max_abs_mm: np.ndarray
    mean_abs_mm: np.ndarray
    max_pct_of_length: np.ndarray | None
    rmse_mm: float
    rmse_t_mm: np.ndarray

    def summary(self) -> dict:
        """JSON-ready figures (lists [x, y, z]; RMSE(t) summarised by its largest value)."""
        pct = None if self.max_pct_of_length is None else [float(v) for v in self.max_pct_of_length]
        return {"max_abs_mm": [float(v) for v in self.max_abs_mm],
                "mean_abs_mm": [float(v) for v in self.mean_abs_mm],
                "max_pct_of_length": pct, "rmse_mm": float(self.rmse_mm),
                "max_rmse_t_mm": float(self.rmse_t_mm.max()) if self.rmse_t_mm.size else 0.0}


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
    return ErrorMetrics(max_abs_mm=max_abs, mean_abs_mm=abs_mm.mean(axis=0), max_pct_of_length=pct,
                        rmse_mm=rmse, rmse_t_mm=rmse_t)


# --------------------------------------------------------------------------------------- predictions
@dataclass(frozen=True, eq=False)
class Prediction:
    """One node's predicted positions against the reference.

    Attributes
    ----------
    kind : str
        ``"one step"`` or ``"free running"``.
    node : int
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
        return metrics(self.predicted, self.reference, rod_length)


def evaluation_span(model, n_samples: int, *, generalisation: bool = False) -> tuple[int, int]:
    """Sample span [start, stop) whose windows are evaluated: the test span of the model's split
    (``data.split``), or with ``generalisation`` the whole record. Targets are ``start+H .. stop-1``.
    Too short a record is a one-line SoftrnnInputError."""
    from .data import split

    H = int(model.spec.history)
    if generalisation:
        if n_samples <= H:
            raise SoftrnnInputError(
                f"the data set has {n_samples} samples but the model's history is {H}: it needs at least "
                f"{H + 1} (the history and one sample to predict); use a longer record")
        return 0, int(n_samples)
    test = split(int(n_samples), model.spec)[1]
    return int(test.start), int(test.stop)


def one_step(model, dataset, start: int | None = None, stop: int | None = None, *,
             batch_size: int = 4096) -> Prediction:
    """One-step-ahead predictions of every window inside samples [start, stop) (default: the test
    span), each from the reference history, ``batch_size`` windows per ``predict`` call."""
    from .data import make_windows

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


# --------------------------------------------------------------------------------------- compatibility
def model_dataset_meta(model) -> dict:
    """The training data set's metadata recorded in the model (``meta['dataset']``, or {})."""
    meta = getattr(model, "meta", None) or {}
    ds = meta.get("dataset") if isinstance(meta, dict) else None
    return ds if isinstance(ds, dict) else {}


def _rod_length(rod) -> float | None:
    if isinstance(rod, dict):
        value = rod.get("length")
        if isinstance(value, (int, float)) and not isinstance(value, bool) and math.isfinite(value) and value > 0:
            return float(value)
    return None


def _n_nodes_total(d: dict) -> int | None:
    value = d.get("n_nodes_total")
    if value is None and isinstance(d.get("rod"), dict):
        value = d["rod"].get("n_nodes")
    return int(value) if isinstance(value, (int, np.integer)) and not isinstance(value, bool) else None


def rod_length(model, dataset) -> float | None:
    """The rod length [m] for percentages: the data set's (``attrs['rod']['length']``), else the
    model's training data's, else None."""
    trained = model_dataset_meta(model)
    return (_rod_length(dataset.attrs.get("rod")) or _rod_length(trained.get("rod"))
            or _rod_length({"length": trained.get("rod_length_m")}))


def check_compatible(model, dataset, where: str = "the data set") -> None:
    """Raise a one-line SoftrnnInputError unless ``model`` can be applied to ``dataset``: it stores
    the model's node and neighbours, has the units, rod node count and sample interval of the
    model's training data (where the model records them)."""
    node, neighbours = model_inputs(model)
    stored = set(int(a) for a in np.asarray(dataset.nodes))
    for b in (node, *neighbours):
        if b not in stored:
            what = f"node {b}" if b == node else f"node {b} (a neighbour of node {node})"
            raise SoftrnnInputError(f"{where} does not store {what}, which the model ({describe_model(model)}) "
                                    f"needs; stored nodes: {_stored(sorted(stored))}; use a data set that stores "
                                    f"the model's node and its neighbours")
    trained = model_dataset_meta(model)
    units, mine = trained.get("units"), dataset.attrs.get("units")
    if isinstance(units, dict) and isinstance(mine, dict):
        fields = ["positions", "forces", "torques"] + (["quaternions"] if model.spec.inputs == "poses" else [])
        for f in fields:
            if f in units and f in mine and units[f] != mine[f]:
                raise SoftrnnInputError(f"{where} stores {f} in {mine[f]!r} but the model was trained on "
                                        f"{units[f]!r}; convert the data set to the model's units")
    total, theirs = _n_nodes_total(dataset.attrs), _n_nodes_total(trained)
    if total is not None and theirs is not None and total != theirs:
        raise SoftrnnInputError(f"{where} is a rod of {total} nodes but the model was trained on one of {theirs}: "
                                f"node {node} is another point of the rod; use data of a rod discretised "
                                f"like the training data")
    dt, their_dt = dataset.attrs.get("dt"), trained.get("dt")
    if isinstance(dt, (int, float)) and isinstance(their_dt, (int, float)) and their_dt > 0 \
            and abs(dt - their_dt) > DT_TOLERANCE * their_dt:
        raise SoftrnnInputError(f"{where} is sampled every {dt:g} s but the model predicts steps of {their_dt:g} s; "
                                f"use data sampled like the training data")


def paper_reference(attrs: dict) -> dict | None:
    """The paper's figures to compare with, from the data set's scenario: its ``[paper]`` table
    (``key``, ``role``), else its ``scenario_name`` (``PAPER_KEYS``). A training scenario compares
    with the paper's test figures, a generalisation scenario with its generalisation figures.
    Returns {key, figures: 'test' | 'generalisation', section, predicted_node, max_abs_mm,
    mean_abs_mm, max_pct_of_length} or None."""
    from ..paper import paper_results

    table = _scenario_toml(attrs).get("paper")
    key = role = None
    if isinstance(table, dict) and isinstance(table.get("key"), str):
        key = table["key"]
        role = "generalisation" if table.get("role") == "generalisation" else "test"
    else:
        name = attrs.get("scenario_name")
        if isinstance(name, str) and name in PAPER_KEYS:
            key, role = PAPER_KEYS[name]
    cases = paper_results()["cases"]
    if key not in cases or role not in cases[key]:
        return None
    figures = cases[key][role]
    return {"key": key, "figures": role, "section": cases[key].get("section"),
            "predicted_node": cases[key].get("predicted_node"),
            "max_abs_mm": list(figures["max_abs_mm"]), "mean_abs_mm": list(figures["mean_abs_mm"]),
            "max_pct_of_length": list(figures["max_pct_of_length"])}


def _scenario_toml(attrs: dict) -> dict:
    """The data set's scenario text (TOML) as a dict ({} if absent or unreadable)."""
    import tomllib

    text = attrs.get("scenario_text")
    if not isinstance(text, str) or not text.strip():
        return {}
    try:
        return tomllib.loads(text)
    except (tomllib.TOMLDecodeError, ValueError):
        return {}


def trained_on(model) -> str | None:
    """The scenario (or file) the model was trained on, as its metadata records it."""
    d = model_dataset_meta(model)
    for key in ("scenario_name", "scenario", "name", "path", "file"):
        if isinstance(d.get(key), str) and d[key]:
            return d[key]
    return None


# --------------------------------------------------------------------------------------- evaluate
@dataclass(frozen=True, eq=False)
class Evaluation:
    """The result of ``evaluate``: a JSON-ready header, the predictions and their errors."""

    info: dict
    one_step: Prediction
    one_step_errors: ErrorMetrics
    free_running: Prediction | None
    free_running_errors: ErrorMetrics | None
    paper: dict | None
    diverged: dict | None = None

    def to_json(self) -> dict:
        """{...info, one_step: {...}, free_running: {...}, {diverged: true, node, sample, time_s} or
        None (not run), paper: {...} or None}; RMSE(t) series are not included (``rmse_series``)."""
        out = dict(self.info)
        out["one_step"] = self.one_step_errors.summary()
        if self.free_running_errors is not None:
            out["free_running"] = dict(self.free_running_errors.summary(), diverged=False, neighbours="reference",
                                       seed_samples=int(self.info["history"]))
        else:
            out["free_running"] = None if self.diverged is None else dict(self.diverged, diverged=True)
        out["paper"] = self.paper
        return out

    def rmse_series(self) -> dict:
        """{'time_s': (T,), 'one_step_mm': (T,), 'free_running_mm': (T,) or absent} (same targets)."""
        out = {"time_s": self.one_step.time, "one_step_mm": self.one_step_errors.rmse_t_mm}
        if self.free_running_errors is not None:
            out["free_running_mm"] = self.free_running_errors.rmse_t_mm
        return out


def load_for_model(model, path, *, group: str | None = None):
    """Read from ``path`` only what ``model`` needs (its node and neighbours, every sample),
    after checking compatibility on the file's metadata. Errors are one line."""
    from ..io.dataset import read_dataset

    head = read_dataset(path, group=group, stop=1)           # stored nodes and attrs
    check_compatible(model, head, where=str(path))
    node, neighbours = model_inputs(model)
    return read_dataset(path, nodes=[node, *neighbours], group=group)


def evaluate(model, data, *, group: str | None = None, generalisation: bool = False, free: bool = True,
             batch_size: int = 4096, progress=None, model_name: str | None = None) -> Evaluation:
    """Evaluate ``model`` on ``data`` (a path or a ``Dataset``).

    Parameters
    ----------
    model : NodeModel
    data : str, Path or Dataset
        The reference (read with only the model's nodes when a path).
    group : str or None
        Trajectory of a sweep file.
    generalisation : bool
        Evaluate on the whole record (a scenario the model never saw) instead of the test span.
    free : bool
        Also run the free-running prediction over the same targets (a run that diverges, see
        ``rollout.RolloutDiverged``, is reported as such in ``Evaluation.diverged``).
    batch_size : int
        Windows per ``predict`` call of the one-step evaluation.
    progress : callable(done, total) or None
        Progress of the free-running prediction.
    model_name : str or None
        Recorded as ``model`` in the header (e.g. the model folder).
    """
    if isinstance(data, (str, Path)):
        dataset = load_for_model(model, data, group=group)
        source = str(data)
    else:
        dataset = data
        check_compatible(model, dataset)
        source = None
    start, stop = evaluation_span(model, dataset.n_samples, generalisation=generalisation)
    one = one_step(model, dataset, start, stop, batch_size=batch_size)
    length = rod_length(model, dataset)
    one_err = one.metrics(length)
    run = err = diverged = None
    if free:
        try:
            run = free_running(model, dataset, start, stop, progress=progress)
            err = run.metrics(length)
        except RolloutDiverged as exc:
            diverged = {"node": exc.node, "sample": exc.sample, "time_s": exc.time}
    node, neighbours = model_inputs(model)
    spec = model.spec
    name = dataset.attrs.get("scenario_name")
    info = {
        "model": model_name, "data": source, "group": group,
        "scenario_name": name if isinstance(name, str) and name else None,
        "trained_on": trained_on(model),
        "node": node, "neighbours": list(neighbours), "history": int(spec.history), "inputs": spec.inputs,
        "wrench": spec.wrench, "length_m": length, "unit": UNIT,
        "span": "whole record" if generalisation else "test",
        "span_samples": [int(one.index[0]), int(one.index[-1])],
        "span_s": [float(one.time[0]), float(one.time[-1])], "n_targets": int(one.index.size),
    }
    return Evaluation(info=info, one_step=one, one_step_errors=one_err, free_running=run,
                      free_running_errors=err, paper=paper_reference(dataset.attrs), diverged=diverged)
