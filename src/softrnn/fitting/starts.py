"""A fit from several starts: each start fitted briefly (optionally screened first, the best few of the
screen carried on), the best few refined (``multistart``), for
a residual cheap enough to differentiate by ``least_squares``' own finite differences and a cost
with local minima (e.g. an unknown order or angle of the parts of a model). Resuming from an earlier
fit refines that point alone. The starts are independent: ``multistart``'s ``spread`` can fit them in
other processes (each start's fit is the same to the bit wherever it runs)."""

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


def here(stage: str, fn, arguments: list) -> list:
    """``multistart``'s default ``spread``: [fn(*args) for args in ``arguments``], in this process."""
    return [fn(*args) for args in arguments]


def fit_each(residual, starts: list, bounds, evaluations: int, score, solver: dict) -> list:
    """[(x (n,) where the fit ended, score(residual there))] of each (record, x0) of ``starts``, fitted
    with ``evaluations``: one piece of ``multistart``'s work (module-level, so a worker can run it)."""
    out = []
    for _, x0 in starts:
        sol = solve(residual, x0, bounds, evaluations, **solver)
        out.append((sol.x, score(sol.fun)))
    return out


def multistart(residual, starts, bounds, *, options: StartOptions, score, key: str = "score", resume=None,
               progress=None, spread=here, pieces: int = 1, **solver) -> MultiStart:
    """Fit ``residual(x)`` -> (m,) from every start, then refine the best.

    ``starts`` is a list of (record dict, x0 (n,)); each is fitted with
    ``options.quick_evaluations`` and scored by ``score(residual at the end)`` (lower is better);
    the best ``options.refine`` are refined with ``options.evaluations`` and the lowest refined
    score wins. With ``options.screen_keep`` the starts are screened first (``StartOptions``). With
    ``resume`` = (record dict, x (n,)) (an earlier fit), the starts are skipped and that point alone
    is refined. ``bounds`` and ``solver`` (``loss``, ``f_scale``,
    ``x_scale``...) go to ``solve``; ``progress(done, total)`` after each fit (spread: after each stage).

    ``spread(stage, fn, arguments)`` -> [fn(*args) for args in arguments] runs each stage's fits
    (``stage``: ``"screen"``, ``"fit"``, ``"refine"``), cut into at most ``pieces`` calls of ``fit_each``
    (every ``pieces``-th start in each): e.g. in a pool's workers, where ``residual`` and ``score``
    must pickle (module-level functions, or instances of module-level classes). The result does not
    depend on ``pieces`` or on where the pieces run.
    """
    tried = [] if resume is None else [{**resume[0], "x": np.asarray(resume[1]), key: float("nan")}]
    starts = list(starts) if resume is None else []
    refine = options.refine if resume is None else 1
    screened = bool(options.screen_keep) and len(starts) > options.screen_keep
    quick = min(options.screen_keep, len(starts)) if screened else len(starts)
    total = len(starts) * screened + quick + refine
    done = 0

    def run(stage: str, entries: list, evaluations: int) -> list:
        """[(x, score)] of each (record, x0) of ``entries``, fitted in ``pieces`` interleaved calls."""
        nonlocal done
        if spread is here:                  # one start at a time, progress after each
            out = []
            for entry in entries:
                out += fit_each(residual, [entry], bounds, evaluations, score, solver)
                done += 1
                if progress is not None:
                    progress(done, total)
            return out
        cut = [list(range(i, len(entries), pieces)) for i in range(min(pieces, len(entries)))]
        results = spread(stage, fit_each, [(residual, [entries[k] for k in c], bounds, evaluations, score, solver)
                                           for c in cut])
        out = [None] * len(entries)
        for c, result in zip(cut, results):
            for k, r in zip(c, result):
                out[k] = r
        done += len(entries)
        if progress is not None:
            progress(done, total)
        return out

    if screened:
        for (record, _), (x, value) in zip(starts, run("screen", starts, options.screen_evaluations)):
            tried.append({**record, "x": x, "screen_" + key: value})
        kept = sorted(tried, key=lambda e: e["screen_" + key])[:options.screen_keep]
        starts = [(entry, entry["x"]) for entry in kept]     # a screened start's record is already in tried
    else:
        starts = [(dict(record), x0) for record, x0 in starts]
        tried.extend(record for record, _ in starts)
    for (entry, _), (x, value) in zip(starts, run("fit", starts, options.quick_evaluations)):
        entry.update({"x": x, key: value})
    best = None
    chosen = sorted((e for e in tried if key in e), key=lambda e: e[key])[:refine]
    for entry, (x, value) in zip(chosen, run("refine", [(e, e["x"]) for e in chosen], options.evaluations)):
        entry["refined_" + key] = value
        if best is None or value < best[0]:
            best = (value, x)
    return MultiStart(x=best[1], score=best[0], tried=tried)
