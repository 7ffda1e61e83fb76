"""A fit from several starts: each start fitted briefly (optionally screened first, the best few of the
screen carried on), the best few refined (``multistart``), for
a residual cheap enough to differentiate by ``least_squares``' own finite differences and a cost
with local minima (e.g. an unknown order or angle of the parts of a model). Resuming from an earlier
fit refines that point alone."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..errors import bad, integer
from .least_squares import solve


@dataclass(frozen=True)
class StartOptions:
    """How ``multistart`` searches: ``quick_evaluations`` per start, ``evaluations`` for the
    refinement of the best ``refine`` starts. With ``screen_keep`` > 0 every start is first screened
    with ``screen_evaluations`` and only the best ``screen_keep`` go on to their quick fit (from where
    the screen ended): many starts for little more than the cost of a few."""

    quick_evaluations: int = 60
    evaluations: int = 400
    refine: int = 2
    screen_evaluations: int = 0
    screen_keep: int = 0

    def __post_init__(self):
        integer("quick_evaluations", self.quick_evaluations)
        integer("evaluations", self.evaluations)
        integer("refine", self.refine)
        integer("screen_evaluations", self.screen_evaluations, low=0)
        integer("screen_keep", self.screen_keep, low=0)
        if self.screen_keep and not self.screen_evaluations:
            raise bad("screen_evaluations", self.screen_evaluations, "at least 1 when screen_keep is set")


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
        score there under ``key`` and, for the refined ones, after refinement under ``"refined_" + key``;
        when screened, the score after the screen under ``"screen_" + key`` (the starts screened out
        have no ``key``)
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
    score wins. With ``options.screen_keep`` the starts are screened first (``StartOptions``). With
    ``resume`` = (record dict, x (n,)) (an earlier fit), the starts are skipped and that point alone
    is refined. ``bounds`` and ``solver`` (``loss``, ``f_scale``,
    ``x_scale``...) go to ``solve``; ``progress(done, total)`` after each fit.
    """
    tried = [] if resume is None else [{**resume[0], "x": np.asarray(resume[1]), key: float("nan")}]
    starts = list(starts) if resume is None else []
    refine = options.refine if resume is None else 1
    screened = bool(options.screen_keep) and len(starts) > options.screen_keep
    quick = min(options.screen_keep, len(starts)) if screened else len(starts)
    total = len(starts) * screened + quick + refine
    done = 0

    def step():
        nonlocal done
        done += 1
        if progress is not None:
            progress(done, total)

    if screened:
        starts = _screen(residual, starts, bounds, options, score, key, tried, step, solver)
    for record, x0 in starts:
        sol = solve(residual, x0, bounds, options.quick_evaluations, **solver)
        entry = record if screened else dict(record)   # a screened start's record is already in tried
        entry.update({"x": sol.x, key: score(sol.fun)})
        if not screened:
            tried.append(entry)
        step()
    best = None
    for entry in sorted((e for e in tried if key in e), key=lambda e: e[key])[:refine]:
        sol = solve(residual, entry["x"], bounds, options.evaluations, **solver)
        entry["refined_" + key] = value = score(sol.fun)
        if best is None or value < best[0]:
            best = (value, sol.x)
        step()
    return MultiStart(x=best[1], score=best[0], tried=tried)


def _screen(residual, starts, bounds, options: StartOptions, score, key: str, tried: list, step, solver) -> list:
    """Fit every start with ``options.screen_evaluations``, record each in ``tried`` (its score under
    ``"screen_" + key``); the best ``options.screen_keep`` as (their record, where the screen ended)."""
    ended = []
    for record, x0 in starts:
        sol = solve(residual, x0, bounds, options.screen_evaluations, **solver)
        entry = {**record, "x": sol.x, "screen_" + key: score(sol.fun)}
        tried.append(entry)
        ended.append((entry, sol.x))
        step()
    return sorted(ended, key=lambda e: e[0]["screen_" + key])[:options.screen_keep]
