"""A fit from several starts: each start fitted briefly, the best few refined (``multistart``), for
a residual cheap enough to differentiate by ``least_squares``' own finite differences and a cost
with local minima (e.g. an unknown order or angle of the parts of a model). Resuming from an earlier
fit refines that point alone."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..errors import integer
from .least_squares import solve


@dataclass(frozen=True)
class StartOptions:
    """How ``multistart`` searches: ``quick_evaluations`` per start, ``evaluations`` for the
    refinement of the best ``refine`` starts."""

    quick_evaluations: int = 60
    evaluations: int = 400
    refine: int = 2

    def __post_init__(self):
        integer("quick_evaluations", self.quick_evaluations)
        integer("evaluations", self.evaluations)
        integer("refine", self.refine)


@dataclass(frozen=True)
class MultiStart:
    """A finished multi-start fit.

    Attributes
    ----------
    x : (n,)
        the best point found
    score : float
        its score (``multistart``'s ``score`` of its residual)
    tried : list of dict
        one record per start: the caller's fields, ``x`` (n,) where its quick fit ended, the
        score there under ``key`` and, for the refined ones, after refinement under ``"refined_" + key``
    """

    x: np.ndarray
    score: float
    tried: list


def multistart(residual, starts, bounds, *, options: StartOptions, score, key: str = "score", resume=None,
               progress=None, **solver) -> MultiStart:
    """Fit ``residual(x)`` -> (m,) from every start, then refine the best.

    ``starts`` is a list of (record dict, x0 (n,)); each is fitted with
    ``options.quick_evaluations`` and scored by ``score(residual at the end)`` (lower is better);
    the best ``options.refine`` are refined with ``options.evaluations`` and the lowest refined
    score wins. With ``resume`` = (record dict, x (n,)) (an earlier fit), the starts are skipped
    and that point alone is refined. ``bounds`` and ``solver`` (``loss``, ``f_scale``,
    ``x_scale``...) go to ``solve``; ``progress(done, total)`` after each fit.
    """
    tried = [] if resume is None else [{**resume[0], "x": np.asarray(resume[1]), key: float("nan")}]
    starts = list(starts) if resume is None else []
    refine = options.refine if resume is None else 1
    total = len(starts) + refine
    for k, (record, x0) in enumerate(starts):
        sol = solve(residual, x0, bounds, options.quick_evaluations, **solver)
        tried.append({**record, "x": sol.x, key: score(sol.fun)})
        if progress is not None:
            progress(k + 1, total)
    best = None
    for k, entry in enumerate(sorted(tried, key=lambda e: e[key])[:refine]):
        sol = solve(residual, entry["x"], bounds, options.evaluations, **solver)
        entry["refined_" + key] = value = score(sol.fun)
        if best is None or value < best[0]:
            best = (value, sol.x)
        if progress is not None:
            progress(len(starts) + k + 1, total)
    return MultiStart(x=best[1], score=best[0], tried=tried)
