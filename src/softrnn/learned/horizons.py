"""Prediction horizons and the free-running evaluation by horizon, shared by both kinds of learned
model (NumPy only).

* ``HORIZONS``: the horizons every report uses, in predicted samples (node models) or model steps
  (the whole-manipulator model, ``WHOLE_HORIZONS``);
* ``free_steps``: the free-running loop: every new row predicted from the rows before it, and
  ``DIVERGED_M``, the range it must stay in (``RolloutDiverged`` where a node model's run leaves it);
* ``spread_starts`` and ``worst_by_horizon``: the largest error h samples (or steps) into free
  runs from a few starts spread over each span; the error of one run is a function each kind of
  model passes in (a node model: the error at the horizon; the whole model: the largest error
  over every node within the horizon);
* ``horizon_table`` and ``HorizonTable``: the table of several predictors from the same starts, as
  the reports write it (``to_dict``); ``HORIZON_STARTS``, the starts per span.
"""

from __future__ import annotations

import functools
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass
from typing import final

import numpy as np

from ..errors import SimulationError, bad

HORIZONS = (1, 10, 100, 1000)
"""Free-running horizons of the reports [predicted samples, or model steps]."""

HORIZON_STARTS = 5
"""Free-running starts per span and horizon, spread evenly over the span: the default of every
horizon table (``horizon_table``), the node models' reports included."""

WHOLE_HORIZON_STARTS = 4
"""The starts per trajectory and horizon the whole-manipulator model's published reports were made
with: ``whole.evaluation.evaluate_dynamic`` passes it explicitly, so its figures stay as published
(the common default, ``HORIZON_STARTS``, would move them)."""

WHOLE_HORIZONS = tuple(h for h in HORIZONS if h > 1)
"""The horizons of a whole manipulator run free: ``HORIZONS`` less the first (10, 100, 1000), in
model steps for the whole-manipulator model and in samples for the node models composed into a
manipulator."""


DIVERGED_M = 16.0
"""A predicted coordinate beyond this [m] stops a free run as diverged (``RolloutDiverged``); it is
also the largest coordinate a data set file stores (``softrnn.io.schema.POSITION_LIMIT_M``)."""


class RolloutDiverged(SimulationError):
    """A model predicted a non-finite position or one beyond ``DIVERGED_M``; ``node``, ``sample``
    (reference sample index, or model step) and ``time`` [s] say where; ``states``, where the run
    was ``baselines.free_run``'s, is what it returns had it not diverged, NaN from ``sample`` on."""

    def __init__(self, message: str, *, node: int, sample: int, time: float, states: np.ndarray | None = None):
        super().__init__(message)
        self.node, self.sample, self.time = int(node), int(sample), float(time)
        self.states = states

    def __reduce__(self):
        """Pickled with its keyword arguments (a worker process raises it in the lab benchmark)."""
        return functools.partial(type(self), node=self.node, sample=self.sample, time=self.time,
                                 states=self.states), (str(self),)


def free_steps(step: Callable[[int, np.ndarray], np.ndarray | None], state: np.ndarray, history: int) -> int | None:
    """Run free: fill ``state[history:]`` in place, row k = ``step(k, state[k - history:k])``.

    Parameters
    ----------
    step : callable(k, window) -> ndarray or None
        The next row (the shape of ``state[k]``) from the ``history`` rows before it (a view of
        ``state``: earlier predictions and the seed); None: the run diverged at row k (it may also
        raise).
    state : ndarray (history + L, ...)
        The seed rows, then the rows to predict (overwritten).
    history : int
        Rows a prediction reads.

    Returns
    -------
    int or None
        The row where the run diverged (it and the rows after it are left as they were), or None.
    """
    for k in range(history, state.shape[0]):
        row = step(k, state[k - history:k])
        if row is None:
            return k
        state[k] = row
    return None


def spread_starts(first: int, last: int, n: int) -> list[int]:
    """Up to ``n`` distinct integers spread evenly over [first, last] (rounded half to even), in order."""
    return sorted({int(round(v)) for v in np.linspace(first, last, max(1, int(n)))})


@final
@dataclass(frozen=True)
class HorizonWorst:
    """The worst error at one horizon (``worst_by_horizon``)."""

    error: float
    """The largest error over the spans and starts, in the error function's unit; inf where a run diverged."""
    starts: tuple[tuple[int, ...], ...]
    """The starts used in each span (empty where the horizon does not fit the span)."""


def worst_by_horizon(error: Callable[[int, int, int], float], spans: Sequence[tuple[int, int]], horizons,
                     n_starts: int) -> dict[int, HorizonWorst | None]:
    """The largest ``error(span, start, h)`` of free runs (inf: a run that diverged before h) by
    horizon h, over the ``spans`` [(first, stop)] with first + h <= stop, from ``n_starts`` starts
    spread over [first, stop - h] (``spread_starts``): {h: ``HorizonWorst``, or None where no span
    fits h}, in the order of ``horizons``."""
    out: dict[int, HorizonWorst | None] = {}
    for h in horizons:
        worst, used = 0.0, []
        for i, (first, stop) in enumerate(spans):
            starts = spread_starts(first, stop - h, n_starts) if first + h <= stop else []
            for s in starts:
                worst = max(worst, float(error(i, s, h)))
            used.append(tuple(starts))
        out[h] = HorizonWorst(error=worst, starts=tuple(used)) if any(used) else None
    return out


KINDS = ("at", "within")
"""What a ``HorizonTable``'s errors measure: ``"at"``, the largest |predicted - reference| over the
nodes and axes at the horizon [m] (a node model's table); ``"within"``, the largest distance over
every node within the horizon [% of the rod's length] (the whole-manipulator model's)."""


@final
@dataclass(frozen=True)
class HorizonRow:
    """One horizon of a ``HorizonTable``."""

    horizon: int
    """h [samples, or model steps]."""
    worst: Mapping[str, float] | None
    """{predictor: the largest error over the spans and starts, in the table's unit; inf: diverged;
    nan: h fits none of its spans}, or None where h fits no span."""
    starts: tuple[int, ...] | None = None
    """The starts used in the first span (None where h fits no span)."""


@final
@dataclass(frozen=True)
class HorizonTable:
    """Free-running errors by horizon of a model and its baselines (``horizon_table``)."""

    kind: str
    """One of ``KINDS``."""
    names: tuple[str, ...]
    """The predictors, in report order."""
    rows: tuple[HorizonRow, ...]
    """One per horizon, in report order."""
    n_starts: int = HORIZON_STARTS
    """Starts per span and horizon."""
    length_m: float | None = None
    """The rod's length [m] of an ``"at"`` table's percentages (None: the table is in mm)."""

    def __post_init__(self):
        if self.kind not in KINDS:
            raise bad("kind", self.kind, f"one of {', '.join(KINDS)}")

    def to_dict(self) -> dict:
        """The reports' JSON: an ``"at"`` table's {'unit', 'n_starts', str(h): {name: error or
        'diverged'} or None, ..., 'max_abs_mm': {str(h): ...}, 'starts': {str(h): [...] or None}},
        or a ``"within"`` table's {str(h): {name: error [% of length] or None (diverged, or h fits no
        span)}}."""
        if self.kind == "within":
            return {str(r.horizon): {n: None if r.worst is None or not np.isfinite(r.worst[n]) else float(r.worst[n])
                                     for n in self.names} for r in self.rows}
        mm = {str(r.horizon): None if r.worst is None else
              {n: "diverged" if np.isinf(r.worst[n]) else r.worst[n] * 1e3 for n in self.names} for r in self.rows}
        rows = {h: None if row is None else {n: _pct(v, self.length_m) for n, v in row.items()}
                for h, row in mm.items()}
        return {"unit": "% of length" if self.length_m else "mm", "n_starts": int(self.n_starts), **rows,
                "max_abs_mm": mm,
                "starts": {str(r.horizon): None if r.starts is None else list(r.starts) for r in self.rows}}


def _pct(mm, length: float | None):
    """An error [mm] as % of ``length`` [m] (unchanged without a length, or when not a number)."""
    number = isinstance(mm, (int, float, np.floating)) and not isinstance(mm, bool)
    return mm if not length or not number else mm / (float(length) * 1e3) * 100.0


def horizon_table(errors: Mapping[str, Callable[[int, int, int], float]], spans, horizons=HORIZONS,
                  n_starts: int = HORIZON_STARTS, *, kind: str = "at", length_m: float | None = None) -> HorizonTable:
    """The ``HorizonTable`` of several predictors: ``errors`` {name: error(span, start, h)} as
    ``worst_by_horizon`` takes it (inf: diverged), over ``spans`` [(first, stop)] (or {name: spans},
    where the predictors' histories differ), at ``horizons`` (in that order), ``n_starts`` starts per
    span (``spread_starts``)."""
    rows = []
    for h in horizons:
        worst = {name: worst_by_horizon(fn, spans[name] if isinstance(spans, Mapping) else spans, (int(h),),
                                        n_starts)[int(h)] for name, fn in errors.items()}
        fits = [w for w in worst.values() if w is not None]
        if not fits:
            rows.append(HorizonRow(horizon=int(h), worst=None))
        else:          # nan: h fits none of this predictor's spans
            errs = {n: np.nan if w is None else w.error for n, w in worst.items()}
            rows.append(HorizonRow(horizon=int(h), worst=errs, starts=fits[0].starts[0]))
    return HorizonTable(kind=kind, names=tuple(errors), rows=tuple(rows), n_starts=int(n_starts), length_m=length_m)
