"""The Euclidean tip error robotics papers report, shared by every learned model and the lab
benchmark: sqrt(mean_t |p - p_ref|^2), mean_t |p - p_ref| and max_t |p - p_ref| [mm], and as % of a
length (``tip_errors`` -> ``TipErrors``)."""

from __future__ import annotations

from dataclasses import dataclass
from typing import final

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


@final
@dataclass(frozen=True)
class TipErrors:
    """The Euclidean errors of a tip path (``tip_errors``)."""

    rmse_mm: float
    """sqrt(mean_t |p - p_ref|^2) [mm]."""
    mean_mm: float
    """mean_t |p - p_ref| [mm]."""
    max_mm: float
    """max_t |p - p_ref| [mm]."""
    length_m: float | None = None
    """The length [m] of the percentages (None: none)."""

    def summary(self) -> dict:
        """``euclidean_summary``'s keys: the learned models' reports."""
        return euclidean_summary(self.rmse_mm, self.mean_mm, self.length_m)

    def tip_summary(self) -> dict:
        """{tip_rmse_mm, tip_mean_mm, tip_max_mm}: the lab benchmark's keys."""
        return {"tip_rmse_mm": self.rmse_mm, "tip_mean_mm": self.mean_mm, "tip_max_mm": self.max_mm}


def tip_errors(predicted, reference, length_m: float | None = None) -> TipErrors:
    """The ``TipErrors`` of a predicted tip path ``predicted`` (T, 3) [m] against ``reference``
    (T, 3) [m], T >= 1, for percentages of ``length_m`` [m] (None: none)."""
    rmse, mean = euclidean_errors(predicted, reference)
    largest = float(np.max(np.linalg.norm(np.asarray(predicted) - np.asarray(reference), axis=1)) * 1e3)
    return TipErrors(rmse_mm=rmse, mean_mm=mean, max_mm=largest, length_m=length_m)
