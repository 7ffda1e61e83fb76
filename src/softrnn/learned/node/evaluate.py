"""Evaluation of a node model on a data set: errors per axis and RMSE(t) (paper section 4, Eq. 2).

Two kinds of prediction over the same targets:

* **one step ahead** (``one_step``), as the paper evaluates: every window is taken from the
  reference data (the node's and its neighbours' recorded history) and the model predicts the
  next position; errors never accumulate;
* **free running** (``free_running``): the node's own history comes from the model's previous
  predictions, seeded with the ``history`` reference samples before the first target; its
  neighbours' poses and its wrenches come from the reference data (a whole-manipulator rollout,
  where the neighbours are predicted too, is ``softrnn.learned.node.rollout``).

The span: the test span of the model's chronological split (``data.split``: the samples after the
first ``train_fraction``, windows inside it, so targets start ``history`` samples after the cut),
or with ``generalisation=True`` the whole record (a data set from another scenario that the model
never saw: the horizontal ellipse, new force profiles, the cosine push), targets from sample
``history`` on. A model trained on the whole of a record (validated on another session,
``whole_record``) is always evaluated on the whole record, free running from its start; on its
own training record the report's span says 'training data'.

Per axis (x, y, z) the errors are reported as the paper does: the largest and the mean absolute
error [mm], the largest as a percentage of the rod length, and RMSE(t) = sqrt(((x_p - x_m)^2 +
(y_p - y_m)^2 + (z_p - z_m)^2) / 3) (Eq. 2) per target [mm]. Beside them the Euclidean error of
the position, as robotics papers report a tip error: its RMSE sqrt(mean_t |p - p_ref|^2) (=
sqrt(3) times the RMSE over the axes) and its mean [mm], and as % of the rod length. The models
predict positions only, so no orientation errors (degrees) are reported.

Beside the model, as the house rule asks (a learned model is never reported alone, nor one step
ahead alone), ``evaluate`` runs the baselines of ``softrnn.learned.baselines`` over the same
targets, one step ahead and free running: persistence, constant velocity, and a linear
autoregressive model (``LinearAR``, mode "node") with the model's inputs (its history, its node's
and neighbours' positions, its node's force or wrench; positions only for a model of poses), fitted
on the model's training span of the same data (``data.split``), or for a whole-record
(generalisation) evaluation on the leading ``train_fraction`` of that record, which the model never
saw (the report says so: ``fitted_on``); with ``linear_fit='training data'`` (the command line's
choice, and the default for a model trained on a whole record) on the model's training data,
where its file still exists (``linear_fitted_on`` says which). Then the free-running errors at
horizons of 1, 10, 100 and 1000 samples (``horizon_table``: the largest error at that horizon from
a handful of starts spread over the span) for the model and each baseline, and the plain
statements of where a baseline beats the model (``misses``).

Applying a model to a data set checks that it stores the model's node and neighbours, that the
units, the rod's node count and the sample interval match the model's training data, and that the
record is longer than the history; each problem is a one-line ``SoftrnnInputError``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from functools import partial
from pathlib import Path
from typing import final

import numpy as np

from ...errors import SoftrnnInputError, bad
from ...io.reader import read_dataset
from ...io.record import read_record, scenario_name
from ...paper import paper_results
from .. import baselines as bl
from ..horizons import HORIZONS, HorizonTable, spread_starts, worst_by_horizon
from ..metrics import euclidean_errors, euclidean_summary
from ..spans import check_length
from .data import IRREGULAR_DT_TOLERANCE, actuation_rows, make_windows, node_positions_sha256, regular_times, split
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


def check_compatible(model, dataset, where: str = "the data set", *, sampling: bool = True) -> None:
    """Raise a one-line SoftrnnInputError unless ``model`` can be applied to ``dataset``: it stores
    the model's node and neighbours, has the units, rod node count and sample interval of the
    model's training data (where the model records them; ``sampling=False`` leaves the interval
    out, for a first look at a file's first sample)."""
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
    _check_channels(model, dataset, trained, where)
    total, theirs = _n_nodes_total(dataset.attrs), _n_nodes_total(trained)
    if total is not None and theirs is not None and total != theirs:
        raise SoftrnnInputError(f"{where} is a rod of {total} nodes but the model was trained on one of {theirs}: "
                                f"node {node} is another point of the rod; use data of a rod discretised "
                                f"like the training data")
    if sampling:
        _check_sampling(dataset, trained, where)


def _check_sampling(dataset, trained: dict, where: str) -> None:
    """The recording's sample interval is the model's (within ``DT_TOLERANCE``, or within
    ``IRREGULAR_DT_TOLERANCE`` of the median step where the rows come at irregular intervals)."""
    dt, their_dt = dataset.attrs.get("dt"), trained.get("dt")
    tolerance = DT_TOLERANCE if regular_times(dataset) else IRREGULAR_DT_TOLERANCE
    if isinstance(dt, (int, float)) and isinstance(their_dt, (int, float)) and their_dt > 0 \
            and abs(dt - their_dt) > tolerance * their_dt:
        raise SoftrnnInputError(f"{where} is sampled every {dt:g} s but the model predicts steps of {their_dt:g} s; "
                                f"use data sampled like the training data")


def _check_channels(model, dataset, trained: dict, where: str) -> None:
    """A model driven by actuation inputs needs each of its channels in ``dataset``, in the unit
    it was trained on (``trained['actuation_units']``, where recorded); one-line errors."""
    spec = model.spec
    if getattr(spec, "drive", "wrench") == "wrench":
        return
    have = dict(getattr(dataset, "actuation_units", None) or {})
    units = trained.get("actuation_units") or {}
    for name in spec.channels:
        if name not in have:
            raise SoftrnnInputError(f"{where} has no actuation channel {name!r}, which the model "
                                    f"({describe_model(model)}) reads (channels: {', '.join(have) or 'none'}); use "
                                    f"a data set that records the model's actuation inputs")
        if name in units and units[name] != have[name]:
            raise SoftrnnInputError(f"{where} records actuation {name!r} in {have[name]!r} but the model was trained "
                                    f"on {units[name]!r}; convert the channel to the model's unit")


def paper_reference(attrs: dict) -> dict | None:
    """The paper's figures to compare with, from the data set's scenario: its ``[paper]`` table
    (``key``, ``role``, from its record), else its name (``softrnn.io.record.scenario_name``,
    ``PAPER_KEYS``). A training scenario compares with the paper's test figures, a generalisation
    scenario with its generalisation figures.
    Returns {key, figures: 'test' | 'generalisation', section, predicted_node, max_abs_mm,
    mean_abs_mm, max_pct_of_length} or None."""
    record = read_record(attrs)
    table = record.paper if record is not None else None
    key = role = None
    if isinstance(table, dict) and isinstance(table.get("key"), str):
        key = table["key"]
        role = "generalisation" if table.get("role") == "generalisation" else "test"
    else:
        name = scenario_name(attrs)
        if name in PAPER_KEYS:
            key, role = PAPER_KEYS[name]
    cases = paper_results()["cases"]
    if key not in cases or role not in cases[key]:
        return None
    figures = cases[key][role]
    return {"key": key, "figures": role, "section": cases[key].get("section"),
            "predicted_node": cases[key].get("predicted_node"),
            "max_abs_mm": list(figures["max_abs_mm"]), "mean_abs_mm": list(figures["mean_abs_mm"]),
            "max_pct_of_length": list(figures["max_pct_of_length"])}


def trained_on(model) -> str | None:
    """The scenario (or file) the model was trained on, as its metadata records it."""
    d = model_dataset_meta(model)
    for key in ("scenario_name", "scenario", "name", "path", "file"):
        if isinstance(d.get(key), str) and d[key]:
            return d[key]
    return None


# --------------------------------------------------------------------------------------- baselines
BASELINES = ("persistence", "constant_velocity", "linear")
"""The baselines reported beside a node model (``evaluate``), in report order: their JSON keys."""

LABELS = {"model": "the model", "persistence": "persistence", "constant_velocity": "constant velocity",
          "linear": "linear AR", "linear_node": "linear AR (node)", "linear_manipulator": "linear AR (manipulator)"}
"""How the reports' text names each predictor."""

HORIZON_STARTS = 5
"""Free-running starts per horizon (``horizon_table``), spread evenly over the span."""


@final
@dataclass(frozen=True, eq=False)
class BaselineEvaluation:
    """One baseline's predictions of a node model's targets, and their errors.

    Attributes
    ----------
    name : str
        A key of ``BASELINES``.
    history : int
        Past samples a prediction reads.
    one_step : Prediction
        Each target from the reference window before it.
    one_step_errors : ErrorMetrics
        The errors of ``one_step``.
    free_running : Prediction or None
        The node's own predictions fed back, its neighbours and wrenches from the reference (None:
        not run, or diverged).
    free_running_errors : ErrorMetrics or None
        The errors of ``free_running`` (None when it is None).
    diverged : dict or None
        {node, sample, time_s} where a free run left ``DIVERGED_M``.
    details : dict
        JSON-ready description (the linear model: ``fitted_on``, ``inputs`` and ``fit``).
    """

    name: str
    history: int
    one_step: Prediction
    one_step_errors: ErrorMetrics
    free_running: Prediction | None
    free_running_errors: ErrorMetrics | None
    diverged: dict | None = None
    details: dict = field(default_factory=dict)

    def to_dict(self) -> dict:
        """{one_step: {...}, free_running: {..., diverged: false} or {diverged: true, node, sample,
        time_s} or None (not run), history, span_samples: [first, last target], ...details}."""
        if self.free_running_errors is not None:
            free = dict(self.free_running_errors.summary(), diverged=False)
        else:
            free = None if self.diverged is None else dict(self.diverged, diverged=True)
        return {"one_step": self.one_step_errors.summary(), "free_running": free, "history": self.history,
                "span_samples": [int(self.one_step.index[0]), int(self.one_step.index[-1])], **self.details}

    to_json = to_dict


def node_arrays(model, dataset) -> tuple[np.ndarray, np.ndarray | None]:
    """A node model's inputs as baseline arrays (``softrnn.learned.baselines``), float64.

    Parameters
    ----------
    model : NodeModel
        Its ``spec`` (resolved) names the node, the neighbours and the wrench input.
    dataset : Dataset
        Storing the model's node and neighbours (any column order; T samples).

    Returns
    -------
    positions : ndarray (T, K, 3)
        [m] of the model's node (column 0) and its K - 1 neighbours (columns 1.., the model's order).
    wrenches : ndarray (T, K, W) or None
        The model's input II: forces [N] (W = 3, ``spec.wrench == 'force'``), forces then
        torques [N m] (W = 6, ``'wrench'``), then with ``spec.drive`` 'actuation' or 'both' the m
        actuation channels (``spec.channels``, in their units; the same in every column, the linear
        model reads column 0's), or None (no input II).
    """
    node, neighbours = model_inputs(model)
    stored = np.asarray(dataset.nodes)
    cols = [int(np.flatnonzero(stored == a)[0]) for a in (node, *neighbours)]
    positions = np.asarray(dataset.positions)[:, cols].astype(np.float64)
    wrench = str(model.spec.wrench)
    parts = []
    if wrench != "none":
        parts.append(np.asarray(dataset.forces)[:, cols].astype(np.float64))            # (T, K, 3)
    if wrench == "wrench":
        parts.append(np.asarray(dataset.torques)[:, cols].astype(np.float64))           # (T, K, 3)
    act = actuation_rows(dataset, model.spec).astype(np.float64)                        # (T, m)
    if act.shape[1]:
        parts.append(np.broadcast_to(act[:, None], (act.shape[0], len(cols), act.shape[1])))
    return positions, (np.concatenate(parts, axis=-1) if parts else None)


@final
@dataclass(frozen=True, eq=False)
class LinearTraining:
    """The record the linear baseline is fitted on, where it is not the evaluated one: the model's
    training data (``training_record``)."""

    positions: np.ndarray
    """(T, K, 3) [m], ``node_arrays`` of the training record."""
    wrenches: np.ndarray | None
    """(T, K, W) or None, ``node_arrays`` of the training record."""
    stop: int
    """The fit span is samples 0 .. stop - 1 (the model's training span of that record)."""
    what: str
    """The span in words, for the report."""


def training_record(model, dataset, source=None) -> tuple[LinearTraining | None, str]:
    """The model's training data, to fit the linear baseline on, for an evaluation of ``dataset``
    (read from ``source``, a path, or None): (None, 'same') where ``dataset`` is that record itself;
    (``LinearTraining``, '') where the file the model's meta.json names still exists, is
    compatible and holds what was trained on (its sample count, and for a model trained on a
    whole record the node's positions, ``node_positions_sha256``); (None, why not) otherwise."""
    if same_record(model, dataset, source):
        return None, "same"
    sessions = (getattr(model, "meta", None) or {}).get("training_data") or {}
    train = sessions.get("train") or {}
    known = model_dataset_meta(model)
    candidates = [c for c in (train.get("path"), known.get("path")) if isinstance(c, str) and c]
    path = next((Path(c) for c in candidates if Path(c).is_file()), None)
    if path is None:
        return None, ("the model records no training file" if not candidates
                      else f"the training file {candidates[0]} no longer exists")
    try:
        data = load_for_model(model, path, group=known.get("group"))
    except (SoftrnnInputError, OSError) as err:
        return None, f"the training file {path} cannot be read ({' '.join(str(err).split())[:120]})"
    n = int(data.n_samples)
    if isinstance(known.get("n_samples"), int) and known["n_samples"] != n:
        return None, f"the training file {path} has changed ({n} samples, the model trained on {known['n_samples']})"
    digest = train.get("node_positions_sha256")
    if digest and node_positions_sha256(data, model.spec.node) != digest:
        return None, f"the training file {path} has changed since training"
    positions, wrenches = node_arrays(model, data)
    if whole_record(model):
        stop, what = n, f"the model's training data, all of {path.name} (samples 0..{n - 1})"
    else:
        stop = split(n, model.spec)[0].stop
        what = f"the model's training span of its training data {path.name} (samples 0..{stop - 1})"
    return LinearTraining(positions=positions, wrenches=wrenches, stop=stop, what=what), ""


def same_record(model, dataset, source=None) -> bool:
    """Whether ``dataset`` (read from ``source``, or None) is the model's training record: for a
    model trained on a whole record, by its node's positions (``node_positions_sha256``); else by
    the file's path, or its name and sample count."""
    sessions = (getattr(model, "meta", None) or {}).get("training_data") or {}
    digest = (sessions.get("train") or {}).get("node_positions_sha256")
    if digest:
        return node_positions_sha256(dataset, model.spec.node) == digest
    known = model_dataset_meta(model)
    if source is None or not isinstance(known.get("path"), str):
        return False
    try:
        if Path(source).resolve() == Path(known["path"]).resolve():
            return True
    except OSError:
        return False
    return Path(source).name == known.get("file") and known.get("n_samples") == int(dataset.n_samples)


def fit_linear(model, positions, wrenches, *, generalisation: bool = False,
               training: LinearTraining | None = None, same: bool = False, fallback: str | None = None) -> tuple:
    """The linear baseline of a node model (``LinearAR``, mode "node", the model's history and
    inputs: ``node_arrays``) and its JSON description.

    Fitted on the model's training span of this data set (``data.split``), or with
    ``generalisation`` (another scenario's record, evaluated whole) on the leading
    ``train_fraction`` of the record: the model never saw that record, the linear model saw the
    first part of the span it is evaluated on (``fitted_on`` says so).

    Parameters
    ----------
    model : NodeModel
        The node model whose history and inputs the baseline takes.
    positions : ndarray (T, K, 3)
        [m], from ``node_arrays``.
    wrenches : ndarray (T, K, W) or None
        [N, N m], from ``node_arrays``.
    generalisation : bool
        Fit on the leading ``train_fraction`` of the record instead of the model's training span.
    training : LinearTraining or None
        Fit on the model's training data instead (``training_record``): ``linear_fitted_on`` is
        then 'training data'.
    same : bool
        The evaluated record is the model's training record (``same_record``).
    fallback : str or None
        Why the training data could not be used (the report says so beside ``fitted_on``).

    Returns
    -------
    (LinearAR or None, dict)
        The model (None: the span is too short to fit, ``skipped`` says why) and {fitted_on:
        {samples: [0, cut], what}, linear_fitted_on: 'training data' | 'evaluated record', inputs,
        fit: ``LinearAR.summary()`` or skipped}.
    """
    spec = model.spec
    T = int(positions.shape[0])
    on = "training data" if same else "evaluated record"
    if training is not None:
        positions, wrenches, cut, what, on = (training.positions, training.wrenches, training.stop, training.what,
                                              "training data")
    elif whole_record(model) and same:          # its own training record: every sample was trained on
        cut, what = T, f"the model's training data, this whole record (samples 0..{T - 1})"
    elif generalisation or whole_record(model):
        cut = int(math.floor(spec.train_fraction * T))
        what = (f"the leading {100 * spec.train_fraction:g} % of this record (samples 0..{cut - 1}), which the "
                f"evaluated span includes; the model never saw this record")
    else:
        cut = split(T, spec)[0].stop
        what = f"the model's training span of this data set (samples 0..{cut - 1})"
    if fallback and on == "evaluated record":
        what += f"; not on the model's training data: {fallback}"
    details = {"fitted_on": {"samples": [0, cut], "what": what}, "linear_fitted_on": on, "inputs": _inputs_text(model)}
    width = None if getattr(spec, "drive", "wrench") == "wrench" or wrenches is None else int(wrenches.shape[-1])
    config = bl.LinearARConfig(history=int(spec.history), mode="node", neighbours=tuple(range(1, positions.shape[1])),
                            wrench_width=width)
    try:
        linear = bl.LinearAR.fit(config, positions, wrenches, 0, cut, modelled=[0])
    except SoftrnnInputError as err:
        return None, dict(details, skipped=str(err))
    return linear, dict(details, fit=linear.summary())


def _inputs_text(model) -> str:
    """The linear model's inputs in words (the node model's, positions only)."""
    spec = model.spec
    node, neighbours = model_inputs(model)
    loads = {"none": "", "force": f" and node {node}'s force", "wrench": f" and node {node}'s force and torque"}
    drive = getattr(spec, "drive", "wrench")
    act = "" if drive == "wrench" else f" and the actuation inputs {', '.join(spec.channels)}"
    return (f"the last {int(spec.history)} positions of node {node}"
            + (f" and its neighbours {', '.join(map(str, neighbours))}" if neighbours else "")
            + loads.get(str(spec.wrench), "") + act
            + (" (positions only, no quaternions)" if spec.inputs == "poses" else ""))


def _baseline_evaluation(name: str, baseline, positions, wrenches, time, first: int, stop: int, *,
                         node: int, length: float | None, free: bool, details: dict):
    """``BaselineEvaluation`` of the targets first..stop-1 (from the baseline's history on), or a
    {skipped: reason} dict when none of them is past its history."""
    s = max(first, int(baseline.history))
    if s >= stop:
        return dict(details, skipped=f"the span's targets {first}..{stop - 1} lie within its history "
                                     f"({baseline.history} samples)")
    index = np.arange(s, stop, dtype=np.int64)
    ref = positions[s:stop, 0]
    one = Prediction(kind="one step", node=node, index=index, time=time[index],
                     predicted=bl.one_step(baseline, positions, wrenches, s, stop)[:, 0], reference=ref)
    run = err = diverged = None
    if free:
        try:
            pred = bl.free_run(baseline, positions, wrenches, s, stop, modelled=[0])[:, 0]
            run = Prediction(kind="free running", node=node, index=index, time=time[index], predicted=pred,
                             reference=ref)
            err = run.metrics(length)
        except RolloutDiverged as exc:
            diverged = {"node": node, "sample": exc.sample, "time_s": float(time[exc.sample])}
    return BaselineEvaluation(name=name, history=int(baseline.history), one_step=one,
                              one_step_errors=one.metrics(length), free_running=run, free_running_errors=err,
                              diverged=diverged, details=details)


def _model_free_run(model, dataset, positions, wrenches, start: int, stop: int) -> np.ndarray:
    """A node model as ``horizon_table``'s predictor: the reference rows start..stop-1 (T', K, 3)
    [m] with column 0, its node, free running from ``start`` (``free_running``; neighbours and
    wrenches from the reference)."""
    out = np.array(positions[start:stop], dtype=np.float64)
    out[:, 0] = free_running(model, dataset, start - int(model.spec.history), stop).predicted
    return out


@final
@dataclass(frozen=True, eq=False)
class BaselineComparison:
    """The result of ``compare_baselines``."""

    baselines: dict
    """{name: ``BaselineEvaluation``, or {skipped: reason, ...} when it cannot be run}, in
    ``BASELINES`` order."""
    horizons: HorizonTable | None = None
    """The ``horizon_table`` of the model and the baselines over the same targets (None: not run free)."""

    def to_dict(self) -> dict:
        """{'baselines': {name: ``BaselineEvaluation.to_dict()`` or {skipped, ...}}, 'horizons':
        ``HorizonTable.to_dict()`` or None}: the blocks of ``Evaluation.to_dict``."""
        return {"baselines": {k: v.to_dict() if isinstance(v, BaselineEvaluation) else dict(v)
                              for k, v in self.baselines.items()},
                "horizons": None if self.horizons is None else self.horizons.to_dict()}


LINEAR_FITS = ("training data", "evaluated record")
"""Where ``evaluate`` may fit the linear baseline (``linear_fit``)."""


def compare_baselines(model, dataset, start: int, stop: int, *, generalisation: bool = False,
                      length: float | None = None, free: bool = True, horizons=None,
                      n_starts: int = HORIZON_STARTS, linear_fit: str | None = None,
                      source=None) -> BaselineComparison:
    """The baselines over the model's targets start+H .. stop-1 (``evaluation_span``).

    Parameters
    ----------
    model : NodeModel
        The node model.
    dataset : Dataset
        Storing the model's node and neighbours (T samples).
    start, stop : int
        The evaluated span [start, stop) (``evaluation_span``).
    generalisation : bool
        A whole-record evaluation: the linear model is fitted on the record's leading part
        (``fit_linear``).
    length : float or None
        Rod length [m] for percentages.
    free : bool
        Also run free (each baseline, and the horizons of the model and the baselines).
    horizons : sequence of int or None
        [samples] (default ``softrnn.learned.horizons.HORIZONS``).
    n_starts : int
        Starts per horizon.
    linear_fit : str or None
        'training data': fit the linear model on the model's training data (``training_record``:
        the file its meta.json names, if it still exists and is unchanged; otherwise on this record
        as below, and the report says why); 'evaluated record': on this record (its training span,
        or for a whole-record evaluation its leading ``train_fraction``); None: 'training data' for
        a model trained on a whole record (``whole_record``), else 'evaluated record'.
    source : str, Path or None
        Where ``dataset`` was read from (tells the model's training record apart, ``same_record``).

    Returns
    -------
    BaselineComparison
        Each baseline's evaluation (or why it was skipped) and, with ``free``, the horizon table.
    """
    horizons = HORIZONS if horizons is None else horizons
    if linear_fit is None:
        linear_fit = "training data" if whole_record(model) else "evaluated record"
    if linear_fit not in LINEAR_FITS:
        raise bad("linear_fit", linear_fit, f"one of {', '.join(map(repr, LINEAR_FITS))} or None")
    positions, wrenches = node_arrays(model, dataset)
    time = np.asarray(dataset.time, dtype=np.float64)
    same = same_record(model, dataset, source)
    training = fallback = None
    if linear_fit == "training data" and not same:
        training, fallback = training_record(model, dataset, source)
    linear, details = fit_linear(model, positions, wrenches, generalisation=generalisation, training=training,
                                 same=same, fallback=fallback or None)
    predictors = {"persistence": bl.Persistence(), "constant_velocity": bl.ConstantVelocity(), "linear": linear}
    first, node = start + int(model.spec.history), int(model.spec.node)
    out = {}
    for name, b in predictors.items():
        info = details if name == "linear" else {}
        out[name] = dict(info) if b is None else _baseline_evaluation(
            name, b, positions, wrenches, time, first, stop, node=node, length=length, free=free, details=info)
    if not free:
        return BaselineComparison(baselines=out)
    ready = {k: b for k, b in predictors.items() if isinstance(out[k], BaselineEvaluation)}
    runs = {"model": partial(_model_free_run, model, dataset)}
    runs.update({k: partial(bl.free_run, b, modelled=[0]) for k, b in ready.items()})
    h_first = max([first] + [int(b.history) for b in ready.values()])
    table = horizon_table(runs, positions, wrenches, h_first, stop, horizons, n_starts=n_starts, nodes=[0],
                          length=length)
    return BaselineComparison(baselines=out, horizons=table)


def _error_at(fn, positions, wrenches, stop: int, nodes, span: int, start: int, h: int) -> float:
    """``worst_by_horizon``'s error of a node predictor: the largest |predicted - reference| [m]
    over ``nodes`` and axes at sample start + h - 1 (``baselines.horizon_errors``); inf: diverged."""
    res = bl.horizon_errors(fn, positions, wrenches, [start], (h,), stop=stop, nodes=nodes)[h]
    return np.inf if res["diverged"] else res["max_abs_m"]


def horizon_table(runs: dict, positions, wrenches, first: int, stop: int, horizons=None, *,
                  n_starts: int = HORIZON_STARTS, nodes=None, length: float | None = None) -> HorizonTable:
    """Free-running errors by horizon of several predictors, from the same starts.

    Parameters
    ----------
    runs : dict of str -> callable
        Free-running predictors ``pred_fn(positions, wrenches, start, stop) -> (stop - start, N, 3)``
        [m] seeded from the reference before ``start`` (``pred_fn`` of
        ``baselines.horizon_errors``), by report name; each may raise ``RolloutDiverged``.
    positions : ndarray (T, N, 3)
        Reference [m].
    wrenches : ndarray (T, N, W) or None
        Passed to the predictors.
    first, stop : int
        The span: for horizon h the starts (first predicted samples) are ``n_starts`` samples
        spread over [first, stop - h] (``horizons.spread_starts``); ``first`` >= every predictor's
        history.
    horizons : sequence of int or None
        [samples] (default ``horizons.HORIZONS``: 1, 10, 100, 1000); one that does not fit the
        span (first + h > stop) is reported as None.
    n_starts : int
        Starts per horizon.
    nodes : sequence of int or None
        Columns the errors are taken over (the predicted ones; default every column).
    length : float or None
        Rod length [m] for percentages (None: the table is in mm).

    Returns
    -------
    HorizonTable
        Its ``to_dict()``: {'unit': '% of length' (or 'mm'), str(h): {name: the largest
        |predicted - reference| over the nodes, axes and starts at sample start + h - 1, in unit,
        or 'diverged' (a run left ``DIVERGED_M`` before h)} or None (does not fit), 'max_abs_mm':
        the same in mm, 'starts': {str(h): [start samples] or None}, 'n_starts': n_starts}.
    """
    rows, mm_table, starts_table = {}, {}, {}
    for h in sorted({int(h) for h in (HORIZONS if horizons is None else horizons)}):
        if first + h > stop:
            rows[h] = mm_table[h] = starts_table[h] = None
            continue
        mm = {}
        for name, fn in runs.items():
            worst = worst_by_horizon(partial(_error_at, fn, positions, wrenches, stop, nodes), [(first, stop)], (h,),
                                     n_starts)[h]
            mm[name] = "diverged" if np.isinf(worst.error) else worst.error * 1e3
        mm_table[h], starts_table[h] = mm, spread_starts(first, stop - h, n_starts)
        rows[h] = {k: _pct(v, length) for k, v in mm.items()}
    return HorizonTable(rows=rows, unit="% of length" if length else "mm", n_starts=int(n_starts),
                        max_abs_mm=mm_table, starts=starts_table)


def _pct(mm, length: float | None):
    """An error [mm] as % of ``length`` [m] (unchanged without a length, or when not a number)."""
    return mm if not length or not _number(mm) else mm / (float(length) * 1e3) * 100.0


def _number(value) -> bool:
    return isinstance(value, (int, float, np.floating)) and not isinstance(value, bool)


def horizon_keys(table: dict | None) -> list[str]:
    """The horizon entries of a ``horizon_table``'s ``to_dict()`` (``'1'``, ``'10'``, ...; ``'test_span'`` where a
    report adds the whole span), in order."""
    if not table:
        return []
    keys = sorted((k for k in table if k.isdigit()), key=int)
    return keys + (["test_span"] if "test_span" in table else [])


def _beats(where: str, what: str, unit: str, model, others: dict) -> list[str]:
    """One sentence naming the ``others`` ({name: value}) that beat the ``model``'s value (smaller,
    or a number where the model's is 'diverged'), with the figures; [] when none does."""
    won = [(LABELS.get(k, k), v) for k, v in others.items()
           if _number(v) and (model == "diverged" or (_number(model) and v < model))]
    if not won:
        return []
    names = won[0][0] if len(won) == 1 else ", ".join(n for n, _ in won[:-1]) + f" and {won[-1][0]}"
    verb = "beats" if len(won) == 1 else "beat"
    figures = ", ".join(f"{v:.3g}" for _, v in won)
    if model == "diverged":
        return [f"{names} {verb} the model {where}: the model diverged, {what} {figures} {unit}"]
    return [f"{names} {verb} the model {where} ({what} {figures} vs the model's {model:.3g} {unit})"]


def horizon_misses(table: dict | None) -> list[str]:
    """Where a baseline beats the model in a ``horizon_table`` (its ``to_dict()``: 'persistence beats
    the model at 10 steps (...)'), one sentence each."""
    out = []
    for key in horizon_keys(table):
        row = table[key]
        if not row:
            continue
        where = "over the whole test span" if key == "test_span" else f"at {key} step{'s' if key != '1' else ''}"
        out += _beats(where, "largest error", table.get("unit", ""), row.get("model"),
                      {k: v for k, v in row.items() if k != "model"})
    return out


def misses(report: dict) -> list[str]:
    """Where a baseline beats the model, in plain sentences, from an ``Evaluation.to_dict()``
    report: the RMSE one step ahead and free running [mm], and each horizon ([% of length])."""
    base = {k: v for k, v in (report.get("baselines") or {}).items() if "one_step" in v}
    out = _beats("one step ahead", "RMSE", "mm", report["one_step"]["rmse_mm"],
                 {k: v["one_step"]["rmse_mm"] for k, v in base.items()})
    fr = report.get("free_running")
    if fr is not None:
        free = {k: v["free_running"].get("rmse_mm") for k, v in base.items() if v.get("free_running")}
        out += _beats("free running", "RMSE", "mm", "diverged" if fr["diverged"] else fr["rmse_mm"], free)
    return out + horizon_misses(report.get("horizons"))


# --------------------------------------------------------------------------------------- evaluate
@dataclass(frozen=True, eq=False)
class Evaluation:
    """The result of ``evaluate``: a JSON-ready header, the predictions and their errors, the
    baselines' (``compare_baselines``) and the errors by horizon."""

    info: dict
    one_step: Prediction
    one_step_errors: ErrorMetrics
    free_running: Prediction | None
    free_running_errors: ErrorMetrics | None
    paper: dict | None
    diverged: dict | None = None
    baselines: dict | None = None
    horizons: HorizonTable | None = None

    def to_dict(self) -> dict:
        """{...info, one_step: {...}, free_running: {...}, {diverged: true, node, sample, time_s} or
        None (not run), paper: {...} or None, baselines: {name: {one_step, free_running, ...}} or
        None (not run), horizons: ``horizon_table`` or None, misses: [sentences]}; RMSE(t) series
        are not included (``rmse_series``). The ``evaluate`` command's JSON."""
        out = dict(self.info)
        out["one_step"] = self.one_step_errors.summary()
        if self.free_running_errors is not None:
            out["free_running"] = dict(self.free_running_errors.summary(), diverged=False, neighbours="reference",
                                       seed_samples=int(self.info["history"]))
        else:
            out["free_running"] = None if self.diverged is None else dict(self.diverged, diverged=True)
        out["paper"] = self.paper
        compared = BaselineComparison(baselines=self.baselines or {}, horizons=self.horizons).to_dict()
        out["baselines"] = None if self.baselines is None else compared["baselines"]
        out["horizons"] = compared["horizons"]
        out["misses"] = misses(out)
        return out

    to_json = to_dict

    def rmse_series(self) -> dict:
        """{'time_s': (T,), 'one_step_mm': (T,), 'free_running_mm': (T,) or absent, and
        '<baseline>_free_running_mm' (T,) for each baseline run free over the same targets}."""
        out = {"time_s": self.one_step.time, "one_step_mm": self.one_step_errors.rmse_t_mm}
        if self.free_running_errors is not None:
            out["free_running_mm"] = self.free_running_errors.rmse_t_mm
        for name, b in (self.baselines or {}).items():
            if isinstance(b, BaselineEvaluation) and b.free_running_errors is not None \
                    and np.array_equal(b.free_running.index, self.one_step.index):
                out[f"{name}_free_running_mm"] = b.free_running_errors.rmse_t_mm
        return out


def load_for_model(model, path, *, group: str | None = None):
    """Read from ``path`` only what ``model`` needs (its node and neighbours, every sample),
    after checking compatibility on the file's metadata. Errors are one line."""
    head = read_dataset(path, group=group, stop=1)           # stored nodes and attrs
    check_compatible(model, head, where=str(path), sampling=False)
    node, neighbours = model_inputs(model)
    data = read_dataset(path, nodes=[node, *neighbours], group=group)
    check_compatible(model, data, where=str(path))
    return data


def evaluate(model, data, *, group: str | None = None, generalisation: bool = False, free: bool = True,
             batch_size: int = 4096, progress=None, model_name: str | None = None, baselines: bool = True,
             horizons=None, horizon_starts: int = HORIZON_STARTS, linear_fit: str | None = None) -> Evaluation:
    """Evaluate ``model`` on ``data`` (a path or a ``Dataset``), beside the baselines.

    Parameters
    ----------
    model : NodeModel
        The node model.
    data : str, Path or Dataset
        The reference (read with only the model's nodes when a path).
    group : str or None
        Trajectory of a sweep file.
    generalisation : bool
        Evaluate on the whole record (a scenario the model never saw) instead of the test span.
    free : bool
        Also run the free-running prediction over the same targets (a run that diverges, see
        ``RolloutDiverged``, is reported as such in ``Evaluation.diverged``), the
        baselines' free runs and the errors by horizon.
    batch_size : int
        Windows per ``predict`` call of the one-step evaluation.
    progress : callable(done, total) or None
        Progress of the free-running prediction.
    model_name : str or None
        Recorded as ``model`` in the header (e.g. the model folder).
    baselines : bool
        Also evaluate persistence, constant velocity and the linear model over the same targets
        (``compare_baselines``); False only to save time where they are reported elsewhere.
    horizons : sequence of int or None
        Free-running horizons [samples] (default ``softrnn.learned.horizons.HORIZONS``: 1, 10, 100, 1000); those
        longer than the span are reported as None.
    horizon_starts : int
        Starts per horizon, spread over the span.
    linear_fit : str or None
        Where the linear baseline is fitted (``compare_baselines``): 'training data' (the model's
        training file, where it still exists), 'evaluated record', or None (the training data for a
        model trained on a whole record, else the evaluated record). The report's
        ``linear_fitted_on`` says where it was.

    Notes
    -----
    A model trained on a whole record (``whole_record``) is always evaluated on the whole record,
    free running from its start; on its own training record the report's ``span`` says
    "training data".
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
    run = err = diverged = None
    if free:
        try:
            run = free_running(model, dataset, start, stop, progress=progress)
            err = run.metrics(length)
        except RolloutDiverged as exc:
            diverged = {"node": exc.node, "sample": exc.sample, "time_s": exc.time}
    compared = None
    if baselines:
        compared = compare_baselines(model, dataset, start, stop, generalisation=generalisation, length=length,
                                     free=free, horizons=horizons, n_starts=horizon_starts, linear_fit=linear_fit,
                                     source=source)
    info = dict(_header(model, dataset, one, generalisation, source), model=model_name, data=source, group=group,
                length_m=length)
    if compared is not None:
        linear = compared.baselines.get("linear")
        details = linear.details if isinstance(linear, BaselineEvaluation) else (linear or {})
        info["linear_fitted_on"] = details.get("linear_fitted_on")
    return Evaluation(info=info, one_step=one, one_step_errors=one.metrics(length), free_running=run,
                      free_running_errors=err, paper=paper_reference(dataset.attrs), diverged=diverged,
                      baselines=None if compared is None else compared.baselines,
                      horizons=None if compared is None else compared.horizons)


def _drive(spec) -> dict:
    """{drive, channels} of a model driven by actuation inputs; {} for the default wrench drive
    (whose reports stay as they were)."""
    if getattr(spec, "drive", "wrench") == "wrench":
        return {}
    return {"drive": spec.drive, "channels": list(spec.channels)}


def _span_name(model, dataset, generalisation: bool, source) -> str:
    """'test' (the test span of the model's training record), 'whole record', or 'training data'
    (a model trained on a whole record, evaluated on that record)."""
    if whole_record(model):
        return "training data" if same_record(model, dataset, source) else "whole record"
    return "whole record" if generalisation else "test"


def _header(model, dataset, one: Prediction, generalisation: bool, source=None) -> dict:
    """The report's header: the model's inputs, the scenarios and the evaluated span."""
    node, neighbours = model_inputs(model)
    spec = model.spec
    name = dataset.attrs.get("scenario_name")
    return {
        "model": None, "data": None, "group": None,
        "scenario_name": name if isinstance(name, str) and name else None,
        "trained_on": trained_on(model),
        "node": node, "neighbours": list(neighbours), "history": int(spec.history), "inputs": spec.inputs,
        "wrench": spec.wrench, **_drive(spec), "length_m": None, "unit": UNIT,
        "span": _span_name(model, dataset, generalisation, source),
        "span_samples": [int(one.index[0]), int(one.index[-1])],
        "span_s": [float(one.time[0]), float(one.time[-1])], "n_targets": int(one.index.size),
    }
