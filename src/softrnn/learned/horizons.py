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
* ``HorizonTable``: the resulting table, as the reports write it (``to_dict``).
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import final

import numpy as np

from ..errors import SimulationError

HORIZONS = (1, 10, 100, 1000)
"""Free-running horizons of the reports [predicted samples, or model steps]."""

WHOLE_HORIZONS = tuple(h for h in HORIZONS if h > 1)
"""The horizons of a whole manipulator run free: ``HORIZONS`` less the first (10, 100, 1000), in
model steps for the whole-manipulator model and in samples for the node models composed into a
manipulator."""


DIVERGED_M = 16.0
"""A predicted coordinate beyond this [m] stops a free run as diverged (``RolloutDiverged``); it is
also the largest coordinate a data set file stores (``softrnn.io.schema.POSITION_LIMIT_M``)."""


class RolloutDiverged(SimulationError):
    """A model predicted a non-finite position or one beyond ``DIVERGED_M``; ``node``, ``sample``
    (reference sample index) and ``time`` [s] say where."""

    def __init__(self, message: str, *, node: int, sample: int, time: float):
        super().__init__(message)
        self.node, self.sample, self.time = int(node), int(sample), float(time)


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
    """The largest error of free runs by horizon, over spans and starts.

    Parameters
    ----------
    error : callable(span, start, h) -> float
        The error of one free run from ``start`` in span number ``span``, h samples (or steps) on;
        inf for a run that diverged before.
    spans : sequence of (first, stop)
        For horizon h a span is used where first + h <= stop, from ``n_starts`` starts spread over
        [first, stop - h] (``spread_starts``).
    horizons : sequence of int
        h >= 1, in the order of the result.
    n_starts : int
        Starts per span and horizon.

    Returns
    -------
    dict
        {h: ``HorizonWorst``, or None where no span fits h}.
    """
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


@final
@dataclass(frozen=True)
class HorizonTable:
    """Free-running errors by horizon of a model and its baselines: a node model's table (in
    ``unit``, with the errors in mm and the starts) or the whole-manipulator model's (``unit`` None:
    its rows only, in % of the rod's length)."""

    rows: dict
    """{h: {predictor name: error or 'diverged' or None}, or None where h does not fit the span}."""
    unit: str | None = None
    """'% of length' or 'mm' (a node model's table); None (the whole model's)."""
    n_starts: int | None = None
    """Starts per horizon (a node model's table)."""
    max_abs_mm: dict | None = None
    """{h: {name: error [mm] or 'diverged'} or None} (a node model's table)."""
    starts: dict | None = None
    """{h: [start samples] or None} (a node model's table)."""

    def to_dict(self) -> dict:
        """The reports' JSON: a node model's {'unit', 'n_starts', str(h): row, ..., 'max_abs_mm':
        {str(h): ...}, 'starts': {str(h): ...}}, or the whole model's {str(h): row}."""
        rows = {str(h): row for h, row in self.rows.items()}
        if self.unit is None:
            return rows
        return {"unit": self.unit, "n_starts": self.n_starts, **rows,
                "max_abs_mm": {str(h): v for h, v in self.max_abs_mm.items()},
                "starts": {str(h): v for h, v in self.starts.items()}}
