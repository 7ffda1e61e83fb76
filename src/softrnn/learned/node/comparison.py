"""A node model beside the baselines (``softrnn.learned.baselines``) over the same targets: one
step ahead and free running, persistence, constant velocity and the linear model with the node
model's inputs (``fit_linear``), the errors by horizon (``horizon_table``) and the plain statements
of where a baseline beats the model (``misses``)."""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from functools import partial
from pathlib import Path
from typing import final

import numpy as np

from ...errors import SoftrnnInputError, bad
from .. import baselines as bl
from ..horizons import HORIZON_STARTS, HORIZONS, HorizonTable
from ..horizons import horizon_table as _table
from .compatibility import load_for_model, model_dataset_meta, same_record
from .data import actuation_rows, node_positions_sha256, split
from .manipulator import RolloutDiverged, model_inputs
from .predictions import ErrorMetrics, Prediction, free_running, whole_record

BASELINES = ("persistence", "constant_velocity", "linear")
"""The baselines reported beside a node model (``evaluate``), in report order: their JSON keys."""

LABELS = {"model": "the model", "persistence": "persistence", "constant_velocity": "constant velocity",
          "linear": "linear AR", "linear_node": "linear AR (node)", "linear_manipulator": "linear AR (manipulator)"}
"""How the reports' text names each predictor."""


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


def fit_linear(model, positions, wrenches, *, generalisation: bool = False,
               training: LinearTraining | None = None, same: bool = False, fallback: str | None = None) -> tuple:
    """The linear baseline of a node model (``LinearAR``, mode "node", the model's history and
    inputs: ``positions`` (T, K, 3) [m] and ``wrenches`` (T, K, W) or None of ``node_arrays``) and its
    JSON description: (LinearAR, or None where the span is too short to fit, and {fitted_on:
    {samples, what}, linear_fitted_on, inputs, fit or skipped}). Fitted on the model's training span
    of this record (``data.split``); with ``generalisation`` (or a model trained on a whole record)
    on the record's leading ``train_fraction``; with ``training`` (``training_record``) on the
    model's training data. ``same``: this record is the model's training record (``same_record``);
    ``fallback``: why the training data could not be used (see docs/guide/models.md)."""
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
    """Persistence, constant velocity and the linear model (``fit_linear``) over the model's
    targets start+H .. stop-1 of ``dataset`` (``evaluation_span``), one step ahead and, with
    ``free``, free running with the ``horizon_table`` (``horizons`` [samples], ``n_starts`` starts)
    of the model and the baselines; errors as % of ``length`` [m] where given. ``linear_fit``:
    'training data' (the model's training file, ``training_record``, where it still exists and is
    unchanged), 'evaluated record', or None ('training data' for a model trained on a whole
    record); ``source`` is where ``dataset`` was read from (``same_record``). See
    docs/guide/models.md."""
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
    """The ``"at"`` ``HorizonTable`` of free-running predictors ``runs`` {name: pred_fn(positions,
    wrenches, start, stop) -> (stop - start, N, 3) [m]} (``baselines.horizon_errors``' ``pred_fn``)
    on ``positions`` (T, N, 3) [m] and ``wrenches`` (T, N, W) or None: at each horizon h [samples]
    (default ``HORIZONS``; sorted) the largest |predicted - reference| over ``nodes`` (default every
    column), axes and ``n_starts`` starts spread over [first, stop - h]; in % of ``length`` [m] (None:
    mm). A horizon that does not fit the span is None."""
    hs = sorted({int(h) for h in (HORIZONS if horizons is None else horizons)})
    errors = {name: partial(_error_at, fn, positions, wrenches, stop, nodes) for name, fn in runs.items()}
    return _table(errors, [(first, stop)], hs, n_starts, kind="at", length_m=length)


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
