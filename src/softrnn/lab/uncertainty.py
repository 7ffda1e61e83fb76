"""Per-row uncertainty of a fitted model: a 90 % interval, a ball around each predicted tip, calibrated
on the training sessions' hold-out part (split conformal prediction).

A model that states an interval has ``predict_interval(session) -> (tip (T, 3) [m], radius (T,) [m])``:
``tip`` is ``predict(session)`` and the ball of ``radius`` around it should hold the true tip in 90 % of
the rows. The radius is ``q * interval_scale(session)``: the model's own scale of its error per row
(``error_scale``: an ensemble's spread; 1 where it has none) times 1 + d, d the distance of the row's
standardised inputs from the nearest training row (``InputDistance``: errors grow out of range), times
``q``, the 90 % quantile of |error| / scale over the hold-out rows of the same model fitted on the rest
(``conformal_q``). ``WithInterval`` gives any fitted model such an interval (the physics). The
benchmark reports the share of validation rows inside (``coverage_90``).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from scipy.spatial import cKDTree

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


@dataclass(frozen=True, eq=False)
class InputDistance:
    """The distance of a row's inputs from the nearest training row, each input standardised by
    its training mean ``mu`` and deviation ``sd`` (``of(sessions)``)."""

    tree: cKDTree
    mu: np.ndarray
    sd: np.ndarray

    @classmethod
    def of(cls, sessions) -> InputDistance:
        """The distance from the rows of training ``sessions`` (a list of ``Recording``)."""
        u = np.vstack([s.inputs for s in sessions])
        mu, sd = u.mean(axis=0), u.std(axis=0) + 1e-12
        return cls(cKDTree((u - mu) / sd), mu, sd)

    def __call__(self, session) -> np.ndarray:
        """(T,) the distance of each row of ``session`` [standard deviations]."""
        return self.tree.query((session.inputs - self.mu) / self.sd, k=1)[0]


class Intervals:
    """What a family with an interval shares: the fields ``interval_q`` (None until calibrated) and
    ``reach`` (an ``InputDistance`` of its training rows, or None), and ``error_scale(session)``
    (T,) (here 1: a radius of ``interval_q`` m, growing with the distance)."""

    interval_q: float | None
    reach: InputDistance | None

    def error_scale(self, session) -> np.ndarray:
        """(T,) the model's scale of its error per row [m]: 1."""
        return np.ones(session.n_rows)

    def interval_scale(self, session) -> np.ndarray:
        """(T,) ``error_scale`` times 1 + the distance from the training rows (``reach``; 0 without)."""
        d = 0.0 if self.reach is None else self.reach(session)
        return self.error_scale(session) * (1.0 + d)

    def predict_interval(self, session) -> tuple[np.ndarray, np.ndarray]:
        """The tip (T, 3) [m] (``predict``) and the radius (T,) [m] of the ball that holds the true tip
        in 90 % of the rows; a ``ValueError`` before the interval was calibrated (``conformal_q``)."""
        if self.interval_q is None:
            raise ValueError(f"{self.name}: the interval is not calibrated (dataclasses.replace(model, "
                             "interval_q=conformal_q(...)))")
        return self.predict(session), self.interval_q * self.interval_scale(session)


@dataclass(frozen=True, eq=False)
class WithInterval(Intervals):
    """A fitted model (``model``: ``predict``, ``describe``, ``name``) with a 90 % radius ``interval_q``
    [m] (times 1 + the distance from ``reach`` where given): ``with_interval``."""

    model: object
    reach: InputDistance | None = None
    interval_q: float | None = None

    @property
    def name(self) -> str:
        """The model's name."""
        return self.model.name

    def predict(self, session) -> np.ndarray:
        """The model's tip (T, 3) [m]."""
        return self.model.predict(session)

    def describe(self) -> dict:
        """The model's description and the interval's radius [mm] on the training rows."""
        q = self.interval_q
        return {**self.model.describe(), "interval_90_radius_mm": round(q * 1e3, 4) if math.isfinite(q) else None,
                "interval_grows_with_distance": self.reach is not None}


def with_interval(model, held_model, fit_part, held, train=None) -> WithInterval:
    """``model`` (fitted on ``train``) with a 90 % interval calibrated on the hold-out sessions ``held``
    by ``held_model`` (the same family fitted on ``fit_part``): a constant radius when ``train`` is
    None, else growing with the distance from the training rows."""
    reach = (lambda s: None) if train is None else InputDistance.of
    q = conformal_q(WithInterval(held_model, reach(fit_part)), held)
    return WithInterval(model, reach(train), q)
