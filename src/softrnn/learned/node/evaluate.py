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

from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ...io.record import read_record, scenario_name
from ...paper import paper_results
from ..horizons import HORIZON_STARTS, HorizonTable
from .comparison import (  # noqa: F401  (re-exported: the evaluation's public names)
    BASELINES,
    LABELS,
    LINEAR_FITS,
    BaselineComparison,
    BaselineEvaluation,
    LinearTraining,
    compare_baselines,
    fit_linear,
    horizon_keys,
    horizon_misses,
    horizon_table,
    misses,
    node_arrays,
    training_record,
)
from .compatibility import (  # noqa: F401  (re-exported)
    DT_TOLERANCE,
    check_compatible,
    load_for_model,
    model_dataset_meta,
    rod_length,
    same_record,
    trained_on,
)
from .manipulator import RolloutDiverged, model_inputs
from .predictions import (  # noqa: F401  (re-exported)
    UNIT,
    ErrorMetrics,
    Prediction,
    evaluation_span,
    free_running,
    metrics,
    one_step,
    whole_record,
)

PAPER_KEYS = {
    # scenario name -> (paper case key, paper figures compared): used when the scenario text has no
    # [paper] table
    "ellipse": ("ellipse", "test"), "ellipse-horizontal": ("ellipse", "generalisation"),
    "square": ("square_tip", "test"), "square-circle": ("square_tip", "generalisation"),
    "square-figure8": ("square_tip", "generalisation"), "square-random": ("square_tip", "generalisation"),
    "semicircle": ("semicircle", "test"), "semicircle-cosine": ("semicircle", "generalisation"),
}


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


def evaluate(model, data, *, group: str | None = None, generalisation: bool = False, free: bool = True,
             batch_size: int = 4096, progress=None, model_name: str | None = None, baselines: bool = True,
             horizons=None, horizon_starts: int = HORIZON_STARTS, linear_fit: str | None = None) -> Evaluation:
    """Evaluate the node ``model`` on ``data`` (a path, read with only the model's nodes, trajectory
    ``group`` of a sweep file; or a ``Dataset``) beside the baselines: one step ahead over the test
    span (``generalisation``: the whole record; always for a model trained on a whole record), in
    ``batch_size`` windows per call; with ``free`` also free running (``progress(done, total)``)
    and the errors by ``horizons`` [samples] from ``horizon_starts`` starts; with ``baselines`` the
    baselines beside it (``compare_baselines``, the linear one fitted where ``linear_fit`` says).
    ``model_name`` is recorded in the header. Errors in mm and % of the rod length; see
    docs/guide/models.md."""
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
