"""Per-row uncertainty of a fitted model: a 90 % interval, a ball around each predicted tip, calibrated
on the training sessions' hold-out part (split conformal prediction).

A model that states an interval has ``predict_interval(session) -> (tip (T, 3) [m], radius (T,) [m])``:
``tip`` is ``predict(session)`` and the ball of ``radius`` around it should hold the true tip in 90 % of
the rows. The radius is ``q * interval_scale(session)``: the model's own scale of its error per row (an
ensemble's spread, the distance from the training data; 1 where it has none) times ``q``, the 90 %
quantile of |error| / scale over the hold-out rows of the same model fitted on the rest (``conformal_q``).
``ConstantInterval`` gives any model a constant radius (the physics: the 90 % quantile of its hold-out
errors). The benchmark reports the share of validation rows inside (``coverage_90``).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

COVERAGE = 0.9
"""The share of rows an interval should hold."""


def conformal_q(model, held) -> float:
    """The interval's factor ``q`` [1]: the ``COVERAGE`` quantile (split-conformal, rank ceil((n + 1) 0.9))
    of |pred - tip| / ``model.interval_scale(s)`` over the rows of the hold-out sessions ``held``, where
    ``model`` was fitted without them. inf when there are too few rows for the rank."""
    ratios = []
    for s in held:
        err = np.linalg.norm(model.predict(s) - s.tip, axis=1)
        ratios.append(err / np.maximum(model.interval_scale(s), 1e-300))
    r = np.sort(np.concatenate(ratios))
    rank = math.ceil((r.size + 1) * COVERAGE)
    return float(r[rank - 1]) if 0 < rank <= r.size else math.inf


class Intervals:
    """What a family with an interval shares: ``interval_q`` (a field; None until calibrated) and
    ``interval_scale(session)`` (T,) [m] (here 1 m: a constant radius)."""

    interval_q: float | None

    def interval_scale(self, session) -> np.ndarray:
        """(T,) the model's scale of its error per row [m]: 1 (a constant radius of ``interval_q`` m)."""
        return np.ones(session.n_rows)

    def predict_interval(self, session) -> tuple[np.ndarray, np.ndarray]:
        """The tip (T, 3) [m] (``predict``) and the radius (T,) [m] of the ball that holds the true tip
        in 90 % of the rows; a ``ValueError`` before the interval was calibrated (``conformal_q``)."""
        if self.interval_q is None:
            raise ValueError(f"{self.name}: the interval is not calibrated (dataclasses.replace(model, "
                             "interval_q=conformal_q(...)))")
        return self.predict(session), self.interval_q * self.interval_scale(session)


@dataclass(frozen=True, eq=False)
class ConstantInterval(Intervals):
    """A fitted model (``model``: ``predict``, ``describe``, ``name``) with a constant 90 % radius
    ``interval_q`` [m], e.g. the 90 % quantile of its hold-out errors (``constant_interval``)."""

    model: object
    interval_q: float | None = None

    @property
    def name(self) -> str:
        """The model's name."""
        return self.model.name

    def predict(self, session) -> np.ndarray:
        """The model's tip (T, 3) [m]."""
        return self.model.predict(session)

    def describe(self) -> dict:
        """The model's description and the interval's radius [mm]."""
        return {**self.model.describe(), "interval_90_radius_mm": round(self.interval_q * 1e3, 4)}


def constant_interval(model, held_model, held) -> ConstantInterval:
    """``model`` with a constant 90 % radius: the conformal quantile of the errors of ``held_model``
    (the same family fitted without the hold-out sessions ``held``) on ``held``."""
    return ConstantInterval(model, conformal_q(ConstantInterval(held_model), held))
