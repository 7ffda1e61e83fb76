"""The 90 % intervals' cross-fit by patterns (``softrnn.lab.uncertainty.pattern_folds``): where the
recordings label their patterns, the model is refitted without each block of patterns in turn and run
over it, as over a new session; and the error scales that make one rule fit every model (constant
velocity's grows along the run with its own first velocity)."""

import math
from dataclasses import dataclass, replace

import numpy as np
import pytest

from softrnn.lab.families import ConstantVelocityFamily, Physics, holdout_split
from softrnn.lab.nets import Hybrid, NetOptions
from softrnn.lab.recording import Recording
from softrnn.lab.tendon_robot import Calibration
from softrnn.lab.uncertainty import (
    CROSS_ROWS,
    InputDistance,
    WithInterval,
    calibrate,
    cross_fit,
    held_sessions,
    pattern_edges,
    pattern_folds,
    quantile,
    with_interval,
)

from helpers import Drifting, tendon_robot_truth


def _labelled(lengths, path="", start=0.0):
    """A recording of patterns of ``lengths`` rows each (labels p0, p1, ...), one input, the tip at 0."""
    labels = tuple(f"p{i}" for i, n in enumerate(lengths) for _ in range(n))
    T = len(labels)
    return Recording(path=path, time=start + np.arange(T) * 0.6, inputs=np.arange(T, dtype=float)[:, None],
                     names=("a",), units=("mm",), tip=np.zeros((T, 3)), labels=labels)


def _times(sessions):
    return sorted(float(t) for s in sessions for t in s.time)


def test_pattern_folds_hold_out_contiguous_blocks_of_whole_patterns():
    """Two sessions of 10 patterns cut into 3 blocks: each block whole patterns recorded beside each other,
    about a third of the rows; the others and the block hold every row once; runs are sessions of their own."""
    sessions = [_labelled([7, 12, 5, 20, 9], "a"), _labelled([11, 3, 16, 8, 13], "b", start=1000.0)]
    np.testing.assert_array_equal(pattern_edges(sessions[0]), [0, 7, 19, 24, 44, 53])
    everything = _times(sessions)
    folds = pattern_folds(sessions, 3)
    assert len(folds) == 3
    for others, block in folds:
        assert _times(others + block) == everything
        assert abs(sum(s.n_rows for s in block) - len(everything) / 3) <= 20
        for s in block + others:                              # whole patterns, each run in order
            assert np.all(np.diff(s.time) == pytest.approx(0.6))
            source = sessions[0] if s.time[0] < 1000.0 else sessions[1]
            first = int(round((s.time[0] - source.time[0]) / 0.6))
            assert first in pattern_edges(source) and first + s.n_rows in pattern_edges(source)
    blocks = [_times(block) for _, block in folds]
    assert blocks[0][-1] < blocks[1][0] and blocks[1][-1] < blocks[2][0]      # contiguous, in order


@dataclass(frozen=True, eq=False)
class _Remembering:
    """A model that gives back the tip of every row it was fitted on (an overfitted network) and elsewhere
    the mean tip of the fitted rows with the nearest command."""

    seen: dict | None = None
    levels: np.ndarray | None = None
    means: np.ndarray | None = None
    name: str = "remembering"

    def fit(self, sessions):
        u, tips = np.concatenate([s.inputs[:, 0] for s in sessions]), np.vstack([s.tip for s in sessions])
        levels = np.unique(u)
        return replace(self, seen={(s.path, t): tip for s in sessions for t, tip in zip(s.time, s.tip)},
                       levels=levels, means=np.array([tips[u == v].mean(axis=0) for v in levels]))

    def predict(self, s):
        nearest = self.means[np.abs(s.inputs[:, :1] - self.levels[None]).argmin(axis=1)]
        return np.array([self.seen.get((s.path, t), m) for t, m in zip(s.time, nearest)])

    def describe(self):
        return {"kind": "remembering"}


def _patterns(count, seed, path, spread=2e-3, noise=0.2e-3, rows=30):
    """A session of ``count`` labelled patterns of ``rows`` rows, each at one of five command levels and
    off by its own offset (hysteresis, drawn anew per pattern, ``spread`` [m] per axis), plus marker
    noise ``noise`` [m] per axis."""
    rng = np.random.default_rng(seed)
    u = np.repeat(rng.integers(0, 5, count).astype(float), rows)
    offset = np.repeat(rng.normal(0.0, spread, (count, 3)), rows, axis=0)
    tip = np.column_stack([u * 1e-3, np.zeros((u.size, 2))]) + offset + rng.normal(0.0, noise, (u.size, 3))
    return Recording(path=path, time=np.arange(u.size) * 0.6, inputs=u[:, None], names=("a",), units=("mm",),
                     tip=tip, labels=tuple(f"pattern_{k // rows}" for k in range(u.size)))


def test_the_pattern_cross_fit_interval_holds_about_90_percent_of_a_new_session():
    """A model exact on the rows it was fitted on, off by the spread between patterns on any other: the
    quantile over its fitted rows is 0. The cross-fit by patterns runs it over every fitting row with
    that row's block of patterns left out (each row once), and the ball calibrated on it and on the
    hold-out (every row at d = 0: near the data) holds 80-95 % of a new session's rows."""
    train, fresh = _patterns(60, 0, "train"), _patterns(200, 1, "fresh")
    fit_part, held = holdout_split([train])
    family = _Remembering()
    fitted = with_interval(family.fit(fit_part), family.fit(fit_part), fit_part, held, fit_part)
    on_fitted = np.concatenate([np.linalg.norm(fitted.predict(s) - s.tip, axis=1) for s in fit_part])
    assert quantile(on_fitted) == 0.0
    ratio, d = cross_fit(fitted, fit_part)
    assert ratio.size == sum(s.n_rows for s in fit_part) and d.shape == ratio.shape
    model = with_interval(family.fit([train]), family.fit(fit_part), fit_part, held, [train], fitted=True)
    on_held = np.concatenate([np.linalg.norm(family.fit(fit_part).predict(s) - s.tip, axis=1) for s in held])
    assert model.interval_q == max(quantile(ratio), quantile(on_held)) and quantile(ratio) > 2e-3
    tip, radius = model.predict_interval(fresh)
    assert 0.8 <= np.mean(np.linalg.norm(tip - fresh.tip, axis=1) <= radius) <= 0.95


def test_the_hybrid_refits_its_physics_on_the_rows_it_is_refitted_on():
    """The cross-fit refits the hybrid's physics too (from its calibration), so that the rows it holds out
    show the physics' own error there."""
    robot, params = tendon_robot_truth(1)
    physics = Physics(robot, calibration=Calibration(robot, replace(params, marker=7e-3), 0.0, (), 0.0))
    rng = np.random.default_rng(0)
    u = 3.0 * np.sin(0.07 * np.arange(120)[:, None] * (1 + 0.3 * np.arange(3)) + rng.uniform(0, 6, 3)) - 0.5
    rec = Recording(path="", time=np.arange(120) * 0.6, inputs=u, names=("s1", "s2", "s3"), units=("mm",) * 3,
                    tip=np.zeros((120, 3)))
    rec = replace(rec, tip=Physics(robot, calibration=Calibration(robot, params, 0.0, (), 0.0)).predict(rec))
    hybrid = Hybrid(physics, options=NetOptions(members=1, steps=50, hidden=8), gate=1.0).fit([rec])
    refitted = hybrid.refit([rec])
    assert refitted.physics is not hybrid.physics and refitted.physics.calibration.params.marker == pytest.approx(
        5e-3, abs=0.5e-3)                                      # the true marker offset, refitted from 7 mm
    assert isinstance(refitted.reach, InputDistance) and refitted.net is not hybrid.net


def test_constant_velocity_states_an_interval_that_grows_along_the_run():
    """Constant velocity's error grows along the run with its first velocity: its radius grows with the
    rows since the session's start, the faster the larger that velocity."""
    k = np.arange(50.0)
    slow = Recording(path="", time=k * 0.6, inputs=np.zeros((50, 1)), names=("a",), units=("mm",),
                     tip=np.column_stack([k * 1e-3, np.zeros((50, 2))]))
    fast = replace(slow, tip=slow.tip * 5.0)
    family = ConstantVelocityFamily().fit([slow, fast])
    model = with_interval(family, family, [slow], [fast], [slow, fast], fitted=True)
    r_slow, r_fast = model.predict_interval(slow)[1], model.predict_interval(fast)[1]
    assert np.all(np.diff(r_slow) > 0) and np.all(np.diff(r_fast) > 0)
    assert np.all(r_fast[1:] > r_slow[1:])


def _levels(levels, seed, rows=15, noise=0.5e-3):
    """A session of one pattern per command level of ``levels`` [mm], ``rows`` rows each, the tip at
    (u mm, 0, 0) plus marker noise ``noise`` [m] per axis."""
    u = np.repeat(np.asarray(levels, dtype=float), rows)
    tip = np.column_stack([u * 1e-3, np.zeros((u.size, 2))]) + np.random.default_rng(seed).normal(0, noise, (u.size, 3))
    return Recording(path=f"levels{seed}", time=np.arange(u.size) * 0.6, inputs=u[:, None], names=("a",),
                     units=("mm",), tip=tip, labels=tuple(f"level_{k // rows}" for k in range(u.size)))


def test_q_comes_from_the_cross_fit_rows_near_the_data_and_the_farther_ones_set_the_growth():
    """Each half of the fitting patterns revisits eight command levels of the other half and has four of
    its own. Run by the model refitted on the other half, the revisits show only the noise (d = 0), the
    own levels the model's growing error. q is the noise's 90 % quantile (0.5 mm x 2.50), not the quantile
    over every cross-fit row (several times wider); the farther rows and the hold-out set the growth. The
    ball holds about 90 % of a fresh session on the training levels (all of it with q over every
    cross-fit row) and at least 90 % of one beyond them."""
    shared = np.linspace(-3.0, 3.0, 8)
    first = np.concatenate([shared, [-6.0, -5.0, 5.0, 6.0]])
    second = np.concatenate([shared[::-1], [-2.6, -1.3, 1.3, 2.6]])
    train = _levels(np.concatenate([first, second]), 0)
    held = _levels([6.8, 7.2, 7.6, 8.0], 1)
    model = WithInterval(Drifting(20e-3).fit([train]), InputDistance.of([train]))
    ratio, d = cross_fit(model, [train])
    assert np.mean(d == 0.0) == pytest.approx(2 / 3)
    out = calibrate(model, [train], [held])
    assert out["interval_q"] == pytest.approx(0.5e-3 * 2.5003, rel=0.15)
    assert quantile(ratio) > 3.0 * out["interval_q"]           # every cross-fit row: the far ones widen q
    assert 0.0 < out["interval_slope"] <= 1.5 * model.model.c
    calibrated = replace(WithInterval(Drifting(20e-3).fit([train, held]), InputDistance.of([train, held])), **out)
    revisit, beyond = _levels(np.tile(np.unique(first), 3), 2), _levels(np.linspace(8.4, 9.6, 40), 3)
    inside = [np.mean(np.linalg.norm(tip - s.tip, axis=1) <= radius)
              for s in (revisit, beyond) for tip, radius in [calibrated.predict_interval(s)]]
    assert 0.85 <= inside[0] <= 0.95 and inside[1] >= 0.9
    wide = replace(calibrated, interval_q=quantile(ratio))         # q over every cross-fit row: too wide
    tip, radius = wide.predict_interval(revisit)
    assert np.mean(np.linalg.norm(tip - revisit.tip, axis=1) <= radius) == 1.0


def test_the_interval_holds_q_up_to_the_knee_and_grows_beyond_it():
    """A model off by 1 mm up to the distance d0 that splits the cross-fit's rows in halves and by 3 mm
    more per standard deviation beyond: the nearer half sets q = 1 mm, held up to d0, and the farther half
    and the hold-out the growth b = 3 mm per standard deviation beyond d0, so the ball is as wide as the
    error at every distance (grown from d = 0 instead, it would be too wide near the data)."""
    knee = []

    def err(d):                     # before the knee is known: none
        return 1e-3 * (1.0 + 3.0 * np.maximum(d - knee[0], 0.0)) if knee else np.zeros_like(d)

    @dataclass(frozen=True, eq=False)
    class Kinked:                   # exact on the rows it was fitted on; d: the row's input
        seen: frozenset = frozenset()
        name: str = "kinked"

        def fit(self, sessions):
            return replace(self, seen=frozenset(t for s in sessions for t in s.time))

        def reach(self, s):
            return s.inputs[:, 0]

        def predict(self, s):
            off = np.array([0.0 if t in self.seen else e for t, e in zip(s.time, err(s.inputs[:, 0]))])
            return s.tip + np.column_stack([off, np.zeros((s.n_rows, 2))])

        def error_scale(self, s):
            return np.ones(s.n_rows)

    def at(d):
        d = np.asarray(d, dtype=float)
        return Recording(path="", time=np.arange(d.size) * 0.6, inputs=d[:, None], names=("d",), units=("mm",),
                         tip=np.zeros((d.size, 3)))
    fit = at(np.random.default_rng(0).permutation(np.linspace(0.0, 2.0, 401)))
    knee.append(float(np.median(cross_fit(Kinked().fit([fit]), [fit])[1])))
    held = replace(at(np.linspace(2.0, 3.0, 50)), time=np.arange(50) * 0.6 + 1e3)
    out = calibrate(Kinked().fit([fit]), [fit], [held])
    assert out["interval_knee"] == knee[0] and 0.8 < knee[0] < 1.2
    assert out["interval_q"] == pytest.approx(1e-3, rel=1e-9) and out["interval_slope"] == pytest.approx(3e-3, rel=1e-6)
    model = replace(WithInterval(Kinked(), Kinked().reach), **out)
    probe = replace(at([0.0, 0.5, knee[0], 2.0, 3.0]), time=np.arange(5) * 0.6 + 2e3)
    np.testing.assert_allclose(model.predict_interval(probe)[1], err(probe.inputs[:, 0]), rtol=1e-6)
    from_zero = replace(model, interval_knee=0.0)
    assert np.all(from_zero.predict_interval(probe)[1][1:3] > 1.3e-3)       # near the data: too wide


@dataclass(frozen=True, eq=False)
class _Seen:
    """A model exact on the rows it was fitted on (by path and time), its distance the one input, its scale
    1 m; a subclass's ``off(session)`` says how far off along x [m] it is on that session's other rows."""
    seen: frozenset = frozenset()
    name: str = "seen"

    def fit(self, sessions):
        return replace(self, seen=frozenset((s.path, t) for s in sessions for t in s.time))

    def reach(self, s):
        return s.inputs[:, 0]

    def predict(self, s):
        off = np.array([0.0 if (s.path, t) in self.seen else self.off(s) for t in s.time])
        return s.tip + np.column_stack([off, np.zeros((s.n_rows, 2))])

    def error_scale(self, s):
        return np.ones(s.n_rows)


def _at(d, path, t0=0.0):
    """A session of rows 0.6 s apart from ``t0`` at the distances ``d`` (the one input), its tip at 0."""
    d = np.asarray(d, dtype=float)
    return Recording(path=path, time=t0 + np.arange(d.size) * 0.6, inputs=d[:, None], names=("d",), units=("mm",),
                     tip=np.zeros((d.size, 3)))


def test_hold_out_rows_near_the_data_raise_q():
    """A hold-out session on the training commands (d <= d0), off by 3 mm where the cross-fit shows 1 mm:
    q holds 90 % of those rows too, as it would a new session's rows there; fewer than ``CROSS_ROWS`` of
    them leave q the cross-fit's, and since no growth reaches a row within d0, the growth holds 90 % of
    the hold-out rows beyond d0 (all of them outside q: unbounded everywhere otherwise)."""
    class Offset(_Seen):            # 1 mm off on rows it did not see; 3 mm on the session "other"
        def off(self, s):
            return 3e-3 if s.path == "other" else 1e-3

    fit = _at(np.random.default_rng(0).permutation(np.linspace(0.0, 2.0, 401)), "fit")
    out = calibrate(Offset().fit([fit]), [fit], [_at(np.zeros(40), "other")])
    assert out["interval_q"] == pytest.approx(3e-3)
    few = calibrate(Offset().fit([fit]), [fit], [_at(np.zeros(CROSS_ROWS - 1), "other")])
    assert few["interval_q"] == pytest.approx(1e-3) and few["interval_slope"] == out["interval_slope"] == 0.0
    beside = calibrate(Offset().fit([fit]), [fit], [_at(np.r_[np.zeros(CROSS_ROWS - 1), np.full(30, 5.0)], "other")])
    assert beside["interval_q"] == pytest.approx(1e-3)         # 3 mm off beyond d0: a finite growth holds them
    assert 0.0 < beside["interval_slope"] < math.inf
    assert beside["interval_slope"] == pytest.approx(2e-3 / (5.0 - beside["interval_knee"]), rel=1e-6)
    flat = _at(np.zeros(401), "fit")                              # every row at d = 0: no row beyond d0 anywhere
    none = calibrate(Offset().fit([flat]), [flat], [_at(np.zeros(CROSS_ROWS - 1), "other")])
    assert none["interval_knee"] == 0.0 and none["interval_slope"] == math.inf


def test_a_held_session_near_the_data_sets_q_where_the_cross_fit_s_weaker_model_would_widen_it():
    """A model that errs by 1 mm on a session it was not fitted on, fitted on every fitting row, and by
    3 mm where it was fitted on half of them (the cross-fit's refits): where the hold-out is a session of
    its own (``held_sessions``) with ``CROSS_ROWS`` rows or more near the data, q holds 90 % of those rows
    and the fitted rows (1 mm), as the final model meets a validation session; where the hold-out is
    stretches of the fitting session itself (``Recording.stretch``), or too few of its rows lie near the data, the
    cross-fit's rows set q (3 mm)."""
    class Weaker(_Seen):            # 0 on rows it saw; 1 mm elsewhere fitted on 401 rows, 3 mm on fewer
        def off(self, s):
            return 1e-3 if len(self.seen) >= 401 else 3e-3

    fit = _at(np.random.default_rng(0).permutation(np.linspace(0.0, 2.0, 401)), "fit")
    near = np.zeros(40)
    stretch = replace(_at(near, "fit", 1e3), stretch=True)
    assert held_sessions([_at(near, "other")]) and not held_sessions([stretch])
    session = calibrate(Weaker().fit([fit]), [fit], [_at(near, "other")])
    assert session["interval_q"] == pytest.approx(1e-3)
    stretches = calibrate(Weaker().fit([fit]), [fit], [stretch])
    assert stretches["interval_q"] == pytest.approx(3e-3)
    few = calibrate(Weaker().fit([fit]), [fit], [_at(np.zeros(CROSS_ROWS - 1), "other")])
    assert few["interval_q"] == pytest.approx(3e-3)
    # the cross-fit still sets d0 and the growth: the same in both
    assert session["interval_knee"] == stretches["interval_knee"] > 0.0


def test_the_split_says_whether_it_holds_out_whole_sessions():
    """A session cut to fewer rows is a stretch (``Recording.rows``, ``Recording.stretch``), so that
    ``held_sessions`` tells a held session from a held stretch by the recordings themselves, not by their
    files: two sessions built in memory (no path) hold out a whole session, one session read twice from one
    file too; a sole session's held stretches are stretches, as are the rows kept to fit, and so is a
    session's fold of patterns held out of its other folds."""
    rng = np.random.default_rng(3)
    first, second = (_at(rng.uniform(0.0, 2.0, 120), "", t0) for t0 in (0.0, 1e3))
    fit_part, held = holdout_split([first, second])
    assert held_sessions(held) and len(held) == 1 and not held[0].stretch
    assert held_sessions(holdout_split([_at(first.inputs[:, 0], "same.csv"), _at(second.inputs[:, 0], "same.csv")])[1])
    fit_part, held = holdout_split([first])
    assert not held_sessions(held) and all(p.stretch for p in fit_part + held)
    assert sum(p.n_rows for p in fit_part + held) == first.n_rows
    assert not held_sessions([])
    assert not first.rows(0, first.n_rows).stretch and first.rows(0, 50).rows(0, 50).stretch
    pieces = [first.rows(0, 40), first.rows(40, 80), first.rows(80, 120)]
    assert not held_sessions(holdout_split(pieces)[1])
