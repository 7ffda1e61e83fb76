"""The comparison of paper section 5: the LSTMs (paper Fig. 11) trained and scored against the static model, Table 1."""

from __future__ import annotations

import itertools
import json
import math
import time
from pathlib import Path

import numpy as np

from ...errors import SoftrnnInputError
from ...figures.saving import save_figure
from ...files import atomic_write_text
from ...learned.horizons import RolloutDiverged
from ...learned.node.data import SampleSpec, pose_rows, wrench_rows
from ...learned.node.engine import NodeStepper
from ...learned.node.evaluate import free_running, one_step
from ...magnetics.camera import tangents_from_rotation_vectors
from ...paper import paper_case
from ...progress import Progress
from ...timing import step_rate
from .config import AXES, FIGURE_FILE, MAGNETS, MODELS_DIR, ORIENTATION_NOTE, TABLE_FILE, ExperimentConfig
from .figure import plot_fig12


def _errors_deg(predicted, measured) -> list:
    """[[max, mean] per axis] of |predicted - measured| [rad -> deg] over rows (K, 3), NaN rows left out."""
    d = np.degrees(np.abs(np.asarray(predicted, float) - np.asarray(measured, float)))     # (K, 3)
    d = d[np.all(np.isfinite(d), axis=1)]
    if d.shape[0] == 0:
        return [[None, None] for _ in AXES]
    return [[float(d[:, c].max()), float(d[:, c].mean())] for c in range(3)]


def _tangent_angles(orientations) -> np.ndarray:
    """(..., 2) [deg]: the tangent's elevation above the horizontal xy-plane (bending in the vertical
    plane, about y) and its heading in the xy-plane from +x (about z)."""
    t = tangents_from_rotation_vectors(orientations)
    return np.degrees(np.stack([np.arcsin(np.clip(t[..., 2], -1, 1)), np.arctan2(t[..., 1], t[..., 0])], -1))


def _angle_errors(predicted, measured) -> dict:
    d = np.abs(_tangent_angles(predicted) - _tangent_angles(measured))
    d = d[np.all(np.isfinite(d), axis=1)]
    if d.shape[0] == 0:
        return {"elevation": [None, None], "heading": [None, None]}
    return {name: [float(d[:, c].max()), float(d[:, c].mean())] for c, name in enumerate(("elevation", "heading"))}


def _stepper_rate(model, dataset, steps: int = 2000) -> float:
    """Batch-1 steps per second of the compiled ``NodeStepper`` fed the data set's rows in turn
    (``softrnn.timing.step_rate``: the median over 5 runs of each run's mean rate)."""
    H = int(model.spec.history)
    rows = pose_rows(dataset, model.spec)
    wr = wrench_rows(dataset, model.spec)
    stepper = NodeStepper(model)
    stepper.reset(rows[:H], wr[:H])
    rows_in_turn = itertools.cycle(range(H, rows.shape[0]))

    def step():
        k = next(rows_in_turn)
        stepper.step(rows[k], wr[k])

    return step_rate(step, steps=steps, warmup=100).median_hz


def _paper_table() -> dict:
    return paper_case("magnetic_experiment")["test_max_mean_abs_deg"]


def compare(dataset, static_orientations, config: ExperimentConfig, out_dir, *, progress: Progress | None = None,
            static_info: dict | None = None, figure_title: str = "", calibrated_orientations=None) -> dict:
    """Train the two LSTMs (paper Fig. 11) on the first ``train_fraction`` of ``dataset``
    (``orientation_dataset``), predict the rest one step ahead and free running, and compare with
    the static model's ``static_orientations`` (T, 2, 3) [rad] (None: no static model) and the
    calibrated dynamic model's ``calibrated_orientations`` (T, 2, 3) [rad] (None: none) on the same
    targets. Writes ``out_dir/models/{proximal,distal}``, ``table1.json`` and ``fig12.png``;
    returns the table dict (see ``run_experiment``)."""
    from ...learned.node.train import TrainConfig  # optional extra: learn (PyTorch)

    out = Path(out_dir)
    measured = np.asarray(dataset.positions, dtype=np.float64)                     # (T, 2, 3) rad
    T = measured.shape[0]
    train = TrainConfig(epochs=config.epochs, batch_size=config.batch_size, seed=config.seed, patience=config.epochs,
                        rollout_steps=config.rollout_steps)
    static = None if static_orientations is None else np.asarray(static_orientations, float)
    calibrated = None if calibrated_orientations is None else np.asarray(calibrated_orientations, float)
    result = {"unit": "deg", "axes": list(AXES), "orientation": ORIENTATION_NOTE}
    predictions, rates, train_seconds = {}, {}, 0.0
    for m, name in enumerate(MAGNETS):
        model, seconds = _train_magnet(dataset, m, config, train, out / MODELS_DIR / name, progress)
        train_seconds += seconds
        if progress is not None:
            progress(m, len(MAGNETS), {"stage": "evaluate"})                   # the scoring starts
        result[name], predictions[name] = _score_magnet(model, dataset, measured, m, static, out / MODELS_DIR / name,
                                                        calibrated)
        rates[name] = _stepper_rate(model, dataset)
        if progress is not None:
            progress(m + 1, len(MAGNETS), {"stage": "evaluate"})
    idx = predictions["distal"]["index"]
    motion = np.degrees(np.ptp(measured, axis=0))                                   # (2, 3) range per axis
    bending = AXES[int(np.argmax(motion.max(axis=0)))]
    beats, beats_max = _beats(result, AXES.index(bending)) if static is not None else (None, None)
    result.update({
        "paper": _paper_table(),
        "bending_axis": bending,
        "motion_range_deg": {name: [float(v) for v in motion[m]] for m, name in enumerate(MAGNETS)},
        "lstm_beats_static_on_bending_axis": beats,
        "lstm_beats_static_on_bending_axis_max": beats_max,
        "samples": int(T),
        "train_samples": int(math.floor(config.train_fraction * T)),
        "test_targets": int(idx.size),
        "test_time_s": [float(dataset.time[idx[0]]), float(dataset.time[idx[-1]])],
        "history": config.history,
        "static": static_info,
        "timings": {"training_s": train_seconds,
                    "rnn_steps_per_second": {name: float(rates[name]) for name in MAGNETS}},
    })
    if calibrated is not None:
        result["best_on_bending_axis"] = _best(result, AXES.index(bending))
    fig = plot_fig12(np.asarray(dataset.time), measured, predictions, static, title=figure_title,
                     calibrated=calibrated)

    save_figure(fig, out / FIGURE_FILE)
    result["figure"] = str(out / FIGURE_FILE)
    atomic_write_text(out / TABLE_FILE, json.dumps(result, indent=2, allow_nan=False) + "\n")
    return result


def _train_magnet(dataset, m: int, config: ExperimentConfig, train, model_dir: Path,
                  progress: Progress | None) -> tuple:
    """(model, seconds): magnet ``m``'s LSTM (input I both magnets' orientations, input II its wrench)
    trained with ``train`` (a ``TrainConfig``) and saved to ``model_dir``."""
    from ...learned.node.train import train_node_model  # optional extra: learn (PyTorch)

    name = MAGNETS[m]
    spec = SampleSpec(node=m, neighbours=(1 - m,), history=config.history, inputs="positions", wrench="wrench",
                      train_fraction=config.train_fraction)

    def report(done: int, total: int, info: dict | None = None) -> None:
        progress(done, total, {**(info or {}), "stage": f"train {name}"})

    t0 = time.perf_counter()
    overrides = {"lstm_units": config.lstm_units, "output": config.output}
    model = train_node_model(dataset, spec, overrides, train, model_dir, progress=None if progress is None else report)
    return model, time.perf_counter() - t0


def _score_magnet(model, dataset, measured, m: int, static, model_dir: Path, calibrated=None) -> tuple:
    """(Table 1 entry, predictions) of magnet ``m``'s ``model`` on the test span: errors one step
    ahead and free running against ``measured`` (T, 2, 3) [rad], and the ``static`` and
    ``calibrated`` models' (T, 2, 3) [rad] (each None: absent) on the same targets."""
    one = one_step(model, dataset)
    try:
        free_pred = free_running(model, dataset).predicted
    except RolloutDiverged:
        free_pred = None
    idx = one.index
    meas = measured[idx, m]
    entry = {"rnn": _errors_deg(one.predicted, meas),
             "rnn_free_running": None if free_pred is None else _errors_deg(free_pred, meas),
             "cosserat": None, "calibrated": None}
    angles = {"rnn": _angle_errors(one.predicted, meas)}
    if static is not None:
        st = static[idx, m]
        entry["cosserat"] = _errors_deg(st, meas)
        angles["cosserat"] = _angle_errors(st, meas)
        entry["cosserat_samples"] = int(np.all(np.isfinite(st), axis=1).sum())
    if calibrated is not None:
        cal = calibrated[idx, m]
        entry["calibrated"] = _errors_deg(cal, meas)
        angles["calibrated"] = _angle_errors(cal, meas)
    entry["tangent_angles"] = angles
    entry["model"] = str(model_dir)
    entry["epochs_run"] = model.meta.get("epochs_run")
    entry["best_epoch"] = model.meta.get("best_epoch")
    return entry, {"index": idx, "rnn": one.predicted, "free": free_pred}


def _beats(result: dict, axis: int) -> tuple:
    """Per magnet, whether the LSTM's mean (first dict) and max (second) error about ``axis`` is
    lower than the static model's."""
    def lower(name, k):
        r, c = result[name]["rnn"][axis][k], result[name]["cosserat"][axis][k]
        return bool(r is not None and c is not None and r < c)

    return {name: lower(name, 1) for name in MAGNETS}, {name: lower(name, 0) for name in MAGNETS}


def _best(result: dict, axis: int) -> dict:
    """Per magnet and statistic ("max", "mean"), the model with the lowest error about ``axis``
    among the LSTM one step ahead ("rnn"), the LSTM free running ("rnn_free_running"), the static
    ("cosserat") and the calibrated dynamic model ("calibrated")."""
    out = {}
    for name in MAGNETS:
        out[name] = {}
        for k, stat in enumerate(("max", "mean")):
            scores = {model: result[name][model][axis][k] for model in
                      ("rnn", "rnn_free_running", "cosserat", "calibrated")
                      if result[name].get(model) is not None and result[name][model][axis][k] is not None}
            out[name][stat] = min(scores, key=scores.get) if scores else None
    return out


def format_table(result: dict) -> list[str]:
    """Table 1 beside the paper's as text lines: per magnet and model, (max, mean) [deg] about x, y, z."""
    def cell(v):
        return "-" if v is None or v[0] is None else f"({v[0]:.2f}, {v[1]:.2f})"

    lines = [f"{'':34}{'x-axis':>18}{'y-axis':>18}{'z-axis':>18}"]
    for name in ("distal", "proximal"):
        lines.append(f"{name} magnet")
        rows = [("LSTM (one step ahead)", result[name]["rnn"]),
                ("LSTM (free running)", result[name].get("rnn_free_running")),
                ("static Cosserat model", result[name].get("cosserat")),
                ("calibrated dynamic Cosserat", result[name].get("calibrated")),
                ("paper: RNN-based model", result["paper"][name]["rnn"]),
                ("paper: Cosserat rod model", result["paper"][name]["cosserat"])]
        for label, table in rows:
            cells = ["-"] * 3 if table is None else [cell(v) for v in table]
            lines.append(f"  {label:32}" + "".join(f"{c:>18}" for c in cells))
    return lines


def check_result_shape(result: dict) -> None:
    """Raise ``SoftrnnInputError`` unless ``result`` has the documented Table 1 shape (tests, reproduce)."""
    for name in MAGNETS:
        for model in ("rnn", "cosserat", "calibrated"):
            table = result.get(name, {}).get(model)
            if table is None and model != "rnn":
                continue
            ok = isinstance(table, list) and len(table) == 3 and all(
                isinstance(v, list) and len(v) == 2 and all(isinstance(x, float) for x in v) for v in table)
            if not ok:
                raise SoftrnnInputError(f"result[{name!r}][{model!r}]={table!r} is invalid: expected [[max, mean] "
                                        f"per axis x, y, z] in degrees")
