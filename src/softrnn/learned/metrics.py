"""The Euclidean tip error robotics papers report, shared by every learned model and the lab
benchmark: sqrt(mean_t |p - p_ref|^2), mean_t |p - p_ref| and max_t |p - p_ref| [mm], and as % of a
length (``tip_errors`` -> ``TipErrors``); the same after removing the constant offset between model
and measurement over a session (``aligned_tip_errors``, the metric of opencr-mujoco, arXiv 2606.22397);
and the share of rows inside a stated uncertainty ball (``coverage``)."""

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


def pct_of_length(mm: float, length_m: float | None) -> float | None:
    """``mm`` [mm] as % of ``length_m`` [m] (None without a length)."""
    return None if not length_m else float(mm) / (float(length_m) * 1e3) * 100.0


def euclidean_summary(rmse_mm: float, mean_mm: float, length_m: float | None) -> dict:
    """{rmse_euclidean_mm, mean_euclidean_mm, rmse_euclidean_pct_of_length,
    mean_euclidean_pct_of_length} (the percentages None without a length ``length_m`` [m])."""
    def pct(mm):
        return pct_of_length(mm, length_m)

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

    def pct_of_length(self, mm: float) -> float | None:
        """``mm`` [mm] as % of ``length_m`` (None without a length)."""
        return pct_of_length(mm, self.length_m)

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


def offset(predicted, reference) -> np.ndarray:
    """(3,) the constant offset mean_t (p - p_ref) [m] of ``predicted`` against ``reference`` (T, 3) [m]."""
    return np.mean(np.asarray(predicted, dtype=np.float64) - np.asarray(reference, dtype=np.float64), axis=0)


def aligned_tip_errors(predicted, reference, length_m: float | None = None, groups=None) -> TipErrors:
    """The ``TipErrors`` of ``predicted`` (T, 3) [m] against ``reference`` (T, 3) [m] after removing
    the constant offset over the rows: of p - mean_t (p - p_ref). Give one session at a time (the
    offset is the session's; docs/guide/real-robots.md, "The metrics"). ``groups`` (T,) labels: the
    offset is removed over each run of consecutive rows with the same label instead (a trajectory
    each, as a recording's pattern labels mark them)."""
    predicted = np.asarray(predicted, dtype=np.float64)
    if groups is None:
        return tip_errors(predicted - offset(predicted, reference), reference, length_m)
    labels = np.asarray(groups)
    if labels.shape != predicted.shape[:1]:
        raise ValueError(f"groups of shape {labels.shape} for {predicted.shape[0]} rows")
    starts = np.flatnonzero(np.r_[True, labels[1:] != labels[:-1]])
    shifted = predicted.copy()
    for a, b in zip(starts, [*starts[1:], len(labels)]):
        shifted[a:b] -= offset(predicted[a:b], np.asarray(reference)[a:b])
    return tip_errors(shifted, reference, length_m)


def coverage(predicted, reference, radius) -> float:
    """The share of rows whose true tip lies in the stated ball: mean_t [|p - p_ref| <= r_t], for
    ``predicted`` and ``reference`` (T, 3) [m] and ``radius`` (T,) [m]."""
    err = np.linalg.norm(np.asarray(predicted, dtype=np.float64) - np.asarray(reference, dtype=np.float64), axis=1)
    radius = np.asarray(radius, dtype=np.float64)
    if radius.shape != err.shape:
        raise ValueError(f"radius of shape {radius.shape} for {err.shape[0]} rows")
    return float(np.mean(err <= radius))
