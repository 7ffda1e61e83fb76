"""The Euclidean tip error robotics papers report, shared by every learned model and the lab
benchmark: sqrt(mean_t |p - p_ref|^2) and mean_t |p - p_ref| [mm], and both as % of a length."""

from __future__ import annotations

import numpy as np


def euclidean_errors(predicted, reference) -> tuple[float, float]:
    """(Euclidean RMSE sqrt(mean_t |p - p_ref|^2), mean Euclidean error mean_t |p - p_ref|) [mm] of
    ``predicted`` against ``reference`` (..., 3) [m], over every row, in float64."""
    err_mm = (np.asarray(predicted, dtype=np.float64) - np.asarray(reference, dtype=np.float64)) * 1e3
    with np.errstate(under="ignore"):
        sq = (err_mm ** 2).sum(axis=-1)
        return float(np.sqrt(sq.mean())), float(np.sqrt(sq).mean())


def euclidean_summary(rmse_mm: float, mean_mm: float, length_m: float | None) -> dict:
    """{rmse_euclidean_mm, mean_euclidean_mm, rmse_euclidean_pct_of_length,
    mean_euclidean_pct_of_length} (the percentages None without a length ``length_m`` [m])."""
    def pct(mm):
        return None if not length_m else float(mm) / (float(length_m) * 1e3) * 100.0

    return {"rmse_euclidean_mm": float(rmse_mm), "mean_euclidean_mm": float(mean_mm),
            "rmse_euclidean_pct_of_length": pct(rmse_mm), "mean_euclidean_pct_of_length": pct(mean_mm)}
