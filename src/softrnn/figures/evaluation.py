"""Figures of a node model's evaluation: the prediction per axis (like paper Fig. 3D), RMSE(t)
(Fig. 3E) and its table, as ``softrnn evaluate --figures`` and ``softrnn reproduce`` write them."""

from pathlib import Path

import numpy as np

from ..files import atomic_write_text
from . import plots
from .saving import save_figure

FIGURE_FILES = ("prediction.png", "rmse.png", "rmse_t.csv")   # what write_figures writes


def write_figures(ev, folder) -> list:
    """prediction.png (per axis, like Fig. 3D), rmse.png (RMSE(t), like Fig. 3E) and rmse_t.csv in
    ``folder``; returns the paths."""
    folder = Path(folder)
    r = ev.info
    what = r["span"] if r["span"] in ("whole record", "training data") else "test span"
    title = f"{r.get('scenario_name') or 'data'}: node {r['node']}, {what}"
    preds = {"one step": ev.one_step.predicted}
    rmse = {"one step": ev.one_step_errors.rmse_t_mm}
    if ev.free_running is not None:
        preds["free running"] = ev.free_running.predicted
        rmse["free running"] = ev.free_running_errors.rmse_t_mm
    for key, series in ev.rmse_series().items():      # the baselines, free running over the same targets
        if key.endswith("_free_running_mm") and key != "free_running_mm":
            rmse[key[: -len("_free_running_mm")].replace("_", " ") + " (free running)"] = series
    out = []
    fig = plots.prediction_vs_reference(ev.one_step.time, ev.one_step.reference, preds, title)
    save_figure(fig, folder / "prediction.png")
    out.append(folder / "prediction.png")
    fig = plots.rmse_over_time(ev.one_step.time, rmse, f"{title}: RMSE(t), Eq. 2")
    save_figure(fig, folder / "rmse.png")
    out.append(folder / "rmse.png")
    series = ev.rmse_series()
    names = [k for k in ("time_s", "one_step_mm", "free_running_mm") if k in series]
    table = np.column_stack([series[k] for k in names])
    lines = [",".join(names)] + [",".join(f"{v:.9g}" for v in row) for row in table]
    atomic_write_text(folder / "rmse_t.csv", "\n".join(lines) + "\n")
    out.append(folder / "rmse_t.csv")
    return out
