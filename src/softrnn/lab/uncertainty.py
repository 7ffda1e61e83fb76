"""Per-row uncertainty of a fitted model: a 90 % interval, a ball around each predicted tip, calibrated
on the training sessions' hold-out part (split conformal prediction).

A model that states an interval has ``predict_interval(session) -> (tip (T, 3) [m], radius (T,) [m])``:
``tip`` is ``predict(session)`` and the ball of ``radius`` around it should hold the true tip in 90 % of
the rows. The radius is the model's own scale of its error per row (``error_scale``: an ensemble's
spread; 1 where it has none) times q + b max(0, d - d0), d the distance of the row's standardised inputs
from the nearest training row (``families.InputDistance``, also importable from here: errors grow out of
range). ``calibrate`` fits q, b and d0 on the model fitted without the hold-out rows (two-regime split
conformal): q holds 90 % of the rows near the data that the model did not see, up to the distance d0 that
bounds them, and b, the least growth beyond d0 with which the ball then holds 90 % of the rows beyond
them: the cross-fit's farther half and the hold-out, each. The rows the model did not see come from a
cross-fit (``cross_fit``): where the recordings label their patterns, the model refitted without each
block of patterns in turn (``pattern_folds``: half of the fitting rows, whole patterns recorded beside
each other) and run over it, as over a new session of other patterns; without labels, the model refitted
on every other stretch of its fitting rows and run over the stretches in between, which revisit the same
commands at other times. Either shows the spread between visits, hysteresis and drift, that the rows a
model was fitted on understate; q is never below the quantile on the fitted rows themselves. Without a
fitted b the radius is q (1 + d) (``conformal_q``, q from the hold-out alone). A model without an error
scale of its own can be given one (``RefitSpread``): the jackknife spread of the model refitted without
each block of its training patterns, with their median error over the rows each was fitted without.
``WithInterval`` gives any fitted model such an interval (the physics, the baselines). The benchmark
reports the share of validation rows inside (``coverage_90``)."""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from .families import PHYSICS_GAP, InputDistance, masked, rms_error, stretch_edges, with_physics_gap

COVERAGE = 0.9
"""The share of rows an interval should hold."""


def quantile(values: np.ndarray) -> float:
    """The split-conformal ``COVERAGE`` quantile of ``values`` (n,): the value of rank ceil((n + 1) 0.9);
    inf when there are too few values for the rank."""
    r = np.sort(np.asarray(values, dtype=float).ravel())
    rank = math.ceil((r.size + 1) * COVERAGE)
    return float(r[rank - 1]) if 0 < rank <= r.size else math.inf


def _ratios(model, sessions, scale) -> tuple[np.ndarray, np.ndarray]:
    """(|pred - tip| / scale (n,) [1], d (n,) [standard deviations]) over the rows of ``sessions``; inf
    where the model's prediction is NaN (its run diverged), whatever the scale there (a NaN tip lies in
    no ball, an unbounded one too)."""
    ratios, dist = [], []
    for s in sessions:
        err = np.linalg.norm(model.predict(s) - s.tip, axis=1)
        err[np.isnan(err)] = np.inf                 # a run that diverged is off without bound there
        with np.errstate(invalid="ignore"):         # inf / inf: set below
            ratio = err / np.maximum(scale(s), 1e-300)
        ratio[np.isinf(err)] = np.inf
        ratios.append(ratio)
        dist.append(np.zeros(s.n_rows) if model.reach is None else model.reach(s))
    return np.concatenate(ratios), np.concatenate(dist)


def conformal_q(model, held) -> float:
    """The interval's factor ``q`` [1] of the radius q ``model.interval_scale`` (q (1 + d) times the
    error scale): the ``COVERAGE`` quantile (``quantile``) of |pred - tip| / ``model.interval_scale(s)``
    over the rows of the hold-out sessions ``held``, where ``model`` was fitted without them."""
    return quantile(_ratios(model, held, model.interval_scale)[0])


def stretches(sessions, parity: int) -> list:
    """Every other stretch of rows of each of ``sessions`` (a list of ``Recording``), cut as
    ``families.holdout_split`` cuts a session (``stretch_edges``): the even ones (``parity`` 0) or
    the odd ones (1), each a session of its own."""
    out = []
    for s in sessions:
        edges = stretch_edges(s.n_rows)
        out += [s.rows(a, b) for k, (a, b) in enumerate(zip(edges[:-1], edges[1:])) if k % 2 == parity]
    return out


def pattern_edges(session) -> np.ndarray:
    """(P + 1,) the first row of each of the P patterns of ``session`` (a ``Recording`` with labels):
    each run of consecutive rows with one label; and its rows."""
    labels = np.asarray(session.labels)
    return np.concatenate([[0], np.flatnonzero(labels[1:] != labels[:-1]) + 1, [session.n_rows]])


def _joined(sessions, pieces, keep) -> list:
    """The rows of ``pieces`` ((session index, first row, stop) each, in order) where ``keep`` (P,) bool,
    each run of kept pieces of one session joined into a session of its own."""
    out, run = [], None
    for (i, a, b), k in zip(pieces, keep):
        if k and run is not None and run[0] == i and run[2] == a:
            run = (i, run[1], b)
            continue
        if run is not None:
            out.append(sessions[run[0]].rows(run[1], run[2]))
        run = (i, a, b) if k else None
    return out + ([sessions[run[0]].rows(run[1], run[2])] if run is not None else [])


def _blocks(sessions, folds: int) -> tuple[list, np.ndarray]:
    """(pieces, block): the runs of rows (session index, first row, stop) that ``pattern_folds`` cuts the
    ``sessions`` into, in order, and the block (P,) of each."""
    labelled = all(s.labels for s in sessions)
    cuts = [pattern_edges(s) if labelled else stretch_edges(s.n_rows) for s in sessions]
    pieces = [(i, int(a), int(b)) for i, e in enumerate(cuts) for a, b in zip(e[:-1], e[1:])]
    rows = np.array([b - a for _, a, b in pieces], dtype=float)
    return pieces, np.minimum(((np.cumsum(rows) - rows / 2) * folds / rows.sum()).astype(int), folds - 1)


def pattern_folds(sessions, folds: int | None = None) -> list[tuple[list, list]]:
    """The sessions' patterns (``pattern_edges``), in order, cut into ``folds`` (None: ``CROSS_FOLDS``)
    contiguous blocks of about equal rows at pattern boundaries: [(the other blocks, the block)] per
    block, each a list of ``Recording`` (each run of rows a session of its own). A block holds whole
    patterns, and the patterns recorded beside each other: the others meet it as a new session.
    Sessions without labels are cut at their stretches' edges instead (``stretch_edges``)."""
    folds = CROSS_FOLDS if folds is None else folds
    pieces, block = _blocks(sessions, folds)
    return [(_joined(sessions, pieces, block != j), _joined(sessions, pieces, block == j)) for j in range(folds)]


def block_rows(sessions, folds: int | None = None) -> list[list[np.ndarray]]:
    """The rows of each block of ``pattern_folds(sessions, folds)``, per session: [[(T_i,) bool] per
    block]."""
    folds = CROSS_FOLDS if folds is None else folds
    pieces, block = _blocks(sessions, folds)
    out = [[np.zeros(s.n_rows, dtype=bool) for s in sessions] for _ in range(folds)]
    for (i, a, b), j in zip(pieces, block):
        out[j][i][a:b] = True
    return out


def _cross_splits(fit_part) -> list[tuple[list, list]]:
    """The cross-fit's (refit on, run over) pairs of ``fit_part``: by patterns (``pattern_folds``)
    where every session has labels, else the even stretches and the odd ones (``stretches``)."""
    if fit_part and all(s.labels for s in fit_part):
        return pattern_folds(fit_part)
    return [(stretches(fit_part, 0), stretches(fit_part, 1))]


def refitter(model):
    """How ``model`` is fitted again on other sessions: its ``refit`` (from where it is), else its ``fit``;
    None for a model that has neither."""
    return getattr(model, "refit", None) or getattr(model, "fit", None)


def refit_without(model, refit, on: list, out: list, everything: list):
    """``model`` refitted (``refit``) without the rows of ``out``: on ``on``, the other rows; or, for a model
    that runs through every row in order (``runs_through``: the tendons' creep), on ``everything`` with the
    tips of ``out`` masked (``families.masked``), so that it is fitted without them while its state
    passes through them, as the robot's did."""
    return refit(masked(everything, out)) if getattr(model, "runs_through", False) else refit(on)


def cross_fit(model, fit_part) -> tuple[np.ndarray, np.ndarray] | None:
    """(|pred - tip| / scale (n,) [1], d (n,) [standard deviations]) of ``model`` refitted without
    part of ``fit_part`` (its ``refit``, else ``fit``; its distance from the rows it was refitted on)
    over that part (``_cross_splits``): where the sessions have pattern labels, each block of patterns
    in turn (``pattern_folds``: errors on patterns the model did not see, as in a new session), else
    the odd stretches with the model refitted on the even ones (errors where the commands were seen,
    at other times). None where no split has ``CROSS_ROWS`` rows on both sides, or the model cannot be
    refitted."""
    refit = refitter(model)
    splits = [(a, b) for a, b in _cross_splits(fit_part)
              if min(sum(s.n_rows for s in half) for half in (a, b)) >= CROSS_ROWS]
    if refit is None or not splits:
        return None
    parts = []
    for on, over in splits:
        crossed = refit_without(model, refit, on, over, fit_part)
        parts.append(_ratios(crossed, over, crossed.error_scale))
    return np.concatenate([p[0] for p in parts]), np.concatenate([p[1] for p in parts])


CROSS_ROWS = 20
"""The fewest rows each side of a split of the cross-fit (``cross_fit``) needs."""
CROSS_FOLDS = 2
"""The blocks of patterns the cross-fit holds out in turn (``pattern_folds``)."""


def calibrate(model, fit_part, held) -> dict:
    """The interval of ``model`` (fitted on the sessions ``fit_part``, without ``held``), two-regime
    split conformal: {"interval_q": q, "interval_slope": b, "interval_knee": d0} [1, 1 per standard
    deviation, standard deviations] of the radius error_scale (q + b max(0, d - d0)). The rows the model
    did not see are those of ``fit_part`` run by the model refitted without them (``cross_fit``) and the
    hold-out rows. d0 is the median distance d of the cross-fit's rows from the rows the model was
    refitted on (``NEAR_SHARE``); the rows of each part within d0 are near the data, the others beyond.
    q is the ``COVERAGE`` quantile of |pred - tip| / error_scale over the cross-fit's near rows, at least
    that over the rows of ``fit_part`` themselves and that over the near hold-out rows (where there are
    ``CROSS_ROWS`` of them); b the least growth beyond d0 with which the ball holds 90 % of the cross-fit's
    farther rows and 90 % of the hold-out rows: the larger of the two parts' same quantile of the growth
    each row needs to lie inside, max(0, ratio - q) / (d - d0) (inf for a row outside at d <= d0, which no
    growth reaches: a miss). Where such misses are more than a tenth of the hold-out, no growth holds 90 %
    of it; b then holds 90 % of the hold-out rows beyond d0 instead (not an unbounded ball everywhere). So q
    is the error of a new visit as near the data as the nearer half (a pattern the model did not see,
    between patterns it did; a session the model did not see, where its commands are those of the
    others), held up to that distance, and b how it grows beyond, each from the rows of its own regime.
    Where the hold-out is whole sessions of their own (``held_sessions``: two or more training sessions)
    with ``CROSS_ROWS`` rows within d0, those rows and the fitted rows alone set q: the model met a
    session it was not fitted on there, as it meets a validation session, while the cross-fit's model,
    fitted on half the fitting rows in stretches, is weaker than one fitted on whole sessions and would
    widen every ball (the cross-fit still sets d0 and b). Without a cross-fit, d0 = 0. inf where there
    are too few rows. A model without ``reach`` gets b = 0, d0 = 0 and the largest q of the parts."""
    q = quantile(_ratios(model, fit_part, model.error_scale)[0])
    ratio, d = _ratios(model, held, model.error_scale)
    cross = cross_fit(model, fit_part)
    if model.reach is None:                   # no distance: one radius that holds 90 % of every part
        parts = [ratio] if cross is None else [ratio, cross[0]]
        return {"interval_q": max([q] + [quantile(p) for p in parts]), "interval_slope": 0.0, "interval_knee": 0.0}
    beyond, knee = [], 0.0
    if cross is not None:
        knee = float(np.quantile(cross[1], NEAR_SHARE))
        near = cross[1] <= knee
        if not (held_sessions(held) and np.count_nonzero(d <= knee) >= CROSS_ROWS):
            q = max(q, quantile(cross[0][near]))
        beyond.append((cross[0][~near], cross[1][~near]))
    if np.count_nonzero(d <= knee) >= CROSS_ROWS:
        q = max(q, quantile(ratio[d <= knee]))
    def need(r, dist):              # the growth each row needs to lie inside (inf: outside at d <= d0)
        with np.errstate(divide="ignore", invalid="ignore"):
            return np.where(r <= q, 0.0, (r - q) / np.maximum(dist - knee, 0.0))
    held_need = need(ratio, d)
    if cross is not None and quantile(held_need) == math.inf:   # the rows within d0 outside q: a miss each
        held_need = held_need[d > knee]
    needs = [held_need] + [need(r, dist) for r, dist in beyond if r.size]
    slopes = [quantile(n) for n in needs if n.size] or [math.inf]    # no row beyond d0 anywhere: unknown growth
    return {"interval_q": q, "interval_slope": max(slopes), "interval_knee": knee}


def held_sessions(held) -> bool:
    """Whether the hold-out ``held`` (a list of ``Recording``) is whole sessions of their own: none of it a
    stretch of rows cut out of a session (``Recording.stretch``; ``families.holdout_split`` holds out a
    session where there are two or more, and stretches of the one session otherwise)."""
    return bool(held) and not any(h.stretch for h in held)


NEAR_SHARE = 0.5
"""The share of the cross-fit's rows, the nearest to the rows the model was refitted on, that set the
interval's q and the distance d0 up to which it holds (``calibrate``); the rest, with the hold-out rows,
set its growth b beyond d0."""


class _Wrapper:
    """What a wrapper of a fitted ``model`` passes on from it: its name, its tip and whether it runs through
    every row in order (``refit_without``)."""

    model: object

    @property
    def name(self) -> str:
        """The model's name."""
        return self.model.name

    @property
    def runs_through(self) -> bool:
        """Whether the model runs through every row in order (``refit_without``)."""
        return getattr(self.model, "runs_through", False)

    def predict(self, session) -> np.ndarray:
        """The model's tip (T, 3) [m]."""
        return self.model.predict(session)


REFIT_FOLDS = 4
"""The blocks of patterns (of stretches, without labels) that ``RefitSpread`` refits its model without,
one at a time."""


@dataclass(frozen=True, eq=False)
class RefitSpread(_Wrapper):
    """A fitted model (``model``: ``predict``, ``describe``, ``name``, ``refit`` or ``fit``) whose scale of
    its error per row (``error_scale``) is the jackknife spread of its predictions over ``refits``, the
    model refitted without each block of its training rows in turn (``pattern_folds``: whole patterns
    recorded beside each other), combined with ``residual`` [m], the median of the refits' errors over
    the rows each was fitted without (``block_rows``; each refit run over every training session, as the
    model runs, and scored there; the rows where its run is finite; the model's RMS error over its
    training rows where there is none): sqrt(s_J^2 + residual^2), s_J^2 = (K - 1) / K sum_k |p_k - mean
    p|^2 over the K refits. Where the rows of one block are what sets a parameter, the refit without it
    moves the parameter, and the refits disagree where that parameter matters: combinations of commands
    that no block shows alone. The residual is the error on patterns a model did not see, at the amount
    of data it was fitted on: a model fitted on fewer rows errs more on new ones than over its own, and
    its scale says so, so that the ratio of error to scale that ``calibrate`` measures on a model
    refitted on part of the rows holds for the model fitted on all of them. The median, not the RMS: a
    refit that drifts far over its block (a linear model near instability) would set the scale of every
    row. A row where a refit's run is not finite gets an unbounded scale (``of``)."""

    model: object
    refits: tuple
    residual: float
    folds: int = REFIT_FOLDS

    @classmethod
    def of(cls, model, sessions, folds: int = REFIT_FOLDS) -> RefitSpread:
        """``model`` (fitted on ``sessions``) with its refits on ``folds`` blocks of them (``pattern_folds``;
        a block or its complement of fewer than ``CROSS_ROWS`` rows is left out) and its residual."""
        refit = refitter(model)
        cuts = zip(pattern_folds(sessions, folds), block_rows(sessions, folds))
        pairs = [(on, out, block) for (on, out), block in cuts
                 if min(sum(s.n_rows for s in part) for part in (on, out)) >= CROSS_ROWS]
        refits = tuple(refit_without(model, refit, on, out, sessions) for on, out, _ in pairs)
        # each refit run over every session, as the model runs, and scored on the rows of its block
        err = np.concatenate([np.zeros(0)] + [np.linalg.norm(r.predict(s) - s.tip, axis=1)[block[i]]
                                              for r, (_, _, block) in zip(refits, pairs)
                                              for i, s in enumerate(sessions)])
        err = err[np.isfinite(err)]
        residual = float(np.median(err)) if err.size else rms_error(model, sessions)
        return cls(model, refits, residual, folds)

    def error_scale(self, session) -> np.ndarray:
        """(T,) sqrt(s_J^2 + residual^2) [m] (see the class); the residual alone with fewer than two refits."""
        K = len(self.refits)
        spread = np.zeros(session.n_rows)
        if K >= 2:
            p = np.stack([r.predict(session) for r in self.refits])            # (K, T, 3)
            with np.errstate(invalid="ignore"):
                spread = (K - 1) / K * np.sum((p - p.mean(axis=0)) ** 2, axis=(0, 2))
            spread[~np.isfinite(spread)] = math.inf
        return np.sqrt(spread + self.residual ** 2)

    def refit(self, sessions) -> RefitSpread:
        """The model refitted on ``sessions`` (its ``refit``, else ``fit``), with refits of its own."""
        return RefitSpread.of(refitter(self.model)(sessions), sessions, self.folds)

    def describe(self) -> dict:
        """The model's description and its error scale's: the refits and the residual [mm]."""
        return {**self.model.describe(), "error_scale": f"jackknife spread of {len(self.refits)} refits, each "
                "without a block of the training patterns, with the refits' median error over the rows each was "
                "fitted without",
                "error_scale_residual_mm": _finite(self.residual, scale=1e3)}


@dataclass(frozen=True, eq=False)
class PhysicsGap(_Wrapper):
    """A fitted model with an error scale (``model``: a ``RefitSpread``) whose scale also holds its distance
    from a calibrated ``physics``' tip (fitted on the same rows): sqrt(s^2 + |tip - physics' tip|^2), s the
    model's own scale. Where a model leaves the regime its rows show (a polynomial's cross terms or an ARX
    model's coefficients that no training row sets, which its refits share and get wrong together), the
    physics, fitted on the same rows with the robot's form, tells it apart; where the two agree, the model's
    own scale is the measure. A row where either run is not finite gets an unbounded scale."""

    model: object
    physics: object

    def error_scale(self, session) -> np.ndarray:
        """(T,) sqrt(own^2 + gap^2) [m] (see the class)."""
        return with_physics_gap(self.model.error_scale(session), self.model.predict(session), self.physics, session)

    def refit(self, sessions) -> PhysicsGap:
        """The model refitted on ``sessions`` (``cross_fit``), the physics kept."""
        return PhysicsGap(refitter(self.model)(sessions), self.physics)

    def describe(self) -> dict:
        """The model's description, its scale's with the distance from the physics."""
        out = self.model.describe()
        return out | {"error_scale": out.get("error_scale", "1") + ", and " + PHYSICS_GAP}


class Intervals:
    """What a family with an interval shares: the fields ``interval_q`` (None until calibrated),
    ``interval_slope`` (None: the radius grows as q (1 + d)), ``interval_knee`` (the distance d0 beyond
    which it grows by the slope: q + b max(0, d - d0)) and ``reach`` (an ``InputDistance`` of its
    training rows, or None), and ``error_scale(session)`` (T,) (here 1: a radius of ``interval_q`` m,
    growing with the distance)."""

    interval_q: float | None
    interval_slope: float | None
    interval_knee: float
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
        in 90 % of the rows; a ``ValueError`` before the interval was calibrated (``calibrate``)."""
        if self.interval_q is None:
            raise ValueError(f"{self.name}: the interval is not calibrated (dataclasses.replace(model, "
                             "**calibrate(...)))")
        if self.interval_slope is None:
            return self.predict(session), self.interval_q * self.interval_scale(session)
        beyond = 0.0 if self.reach is None else np.maximum(self.reach(session) - self.interval_knee, 0.0)
        with np.errstate(invalid="ignore"):          # an unbounded slope within the knee adds nothing
            growth = np.where(beyond > 0, self.interval_slope * beyond, 0.0)
        scale = self.error_scale(session)
        with np.errstate(invalid="ignore"):          # an unbounded scale is an unbounded radius, even at q = 0
            return self.predict(session), np.where(np.isinf(scale), math.inf, scale * (self.interval_q + growth))

    def interval_description(self) -> dict:
        """The interval's q, slope b and knee d0, JSON-ready (None where unbounded)."""
        return {"interval_90_q": _finite(self.interval_q), "interval_90_slope": _finite(self.interval_slope),
                "interval_90_knee": _finite(self.interval_knee)}


def _finite(value, digits: int = 4, scale: float = 1.0):
    """``value`` times ``scale``, rounded to ``digits``; None where it is None or not finite."""
    return None if value is None or not math.isfinite(value) else round(value * scale, digits)


@dataclass(frozen=True, eq=False)
class WithInterval(_Wrapper, Intervals):
    """A fitted model (``model``: ``predict``, ``describe``, ``name``, optionally ``error_scale``) with a
    90 % radius: ``interval_q`` [m] (times the model's error scale where it has one), growing with the
    distance d from ``reach`` where given, by ``interval_slope`` d [m] (None: times 1 + d):
    ``with_interval``."""

    model: object
    reach: InputDistance | None = None
    interval_q: float | None = None
    interval_slope: float | None = None
    interval_knee: float = 0.0

    def refit(self, sessions) -> WithInterval:
        """The model refitted on ``sessions`` (its ``refit``, else ``fit``), its distance from them where
        it has one, not calibrated (``cross_fit``)."""
        return WithInterval(refitter(self.model)(sessions), None if self.reach is None else InputDistance.of(sessions))

    def error_scale(self, session) -> np.ndarray:
        """(T,) the model's own scale of its error per row (``model.error_scale``; 1 where it has none)."""
        own = getattr(self.model, "error_scale", None)
        return np.ones(session.n_rows) if own is None else own(session)

    def physics_weights(self, session) -> np.ndarray | None:
        """(T,) the weight of the model's learned part over its physics per row (``model.physics_weights``),
        or None: the model does not follow a physics (``lab benchmark`` then states its own ball alone)."""
        own = getattr(self.model, "physics_weights", None)
        return None if own is None else own(session)

    def describe(self) -> dict:
        """The model's description and the interval: its radius [mm] on the training rows, its growth
        [mm per standard deviation of the distance] and the distance beyond which it grows [standard
        deviations]; for a model with its own error scale, q, b and d0 (``interval_description``) of the
        radius error_scale (q + b max(0, d - d0)) instead."""
        out = {**self.model.describe(), "interval_grows_with_distance": self.reach is not None}
        if getattr(self.model, "error_scale", None) is not None:     # the radius is q + b (d - d0) times its scale
            return out | self.interval_description()
        out["interval_90_radius_mm"] = _finite(self.interval_q, scale=1e3)
        if self.interval_slope is not None:
            out["interval_90_growth_mm"] = _finite(self.interval_slope, scale=1e3)
            out["interval_90_knee"] = _finite(self.interval_knee)
        return out


def with_interval(model, held_model, fit_part, held, train=None, fitted: bool = False,
                  refits: int = 0, physics: tuple | None = None) -> WithInterval:
    """``model`` (fitted on ``train``) with a 90 % interval calibrated on the hold-out sessions ``held``
    by ``held_model`` (the same family fitted on ``fit_part``): a constant radius when ``train`` is
    None, else growing with the distance from the training rows, as q (1 + d) with q from the hold-out
    alone (``conformal_q``), or ``fitted``: as q + b max(0, d - d0) with q, b and d0 from both parts
    (``calibrate``).
    ``refits`` > 0 (with ``train``): a model without an error scale of its own gets the spread of that
    many refits (``RefitSpread``; the held model's refits on ``fit_part``), and with ``physics`` (the
    calibrated physics fitted on ``fit_part`` and on ``train``) its distance from the physics' tip too
    (``PhysicsGap``)."""
    reach = (lambda s: None) if train is None else InputDistance.of
    if refits and train is not None and getattr(model, "error_scale", None) is None:
        model, held_model = RefitSpread.of(model, train, refits), RefitSpread.of(held_model, fit_part, refits)
        if physics is not None:
            model, held_model = PhysicsGap(model, physics[1]), PhysicsGap(held_model, physics[0])
    held_model = WithInterval(held_model, reach(fit_part))
    if fitted:
        return WithInterval(model, reach(train), **calibrate(held_model, fit_part, held))
    return WithInterval(model, reach(train), conformal_q(held_model, held))
