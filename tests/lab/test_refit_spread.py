"""A model's error scale from its refits (``softrnn.lab.uncertainty.RefitSpread``): the jackknife spread
of the model refitted without each block of its training patterns, with the refits' residual over the rows
each was fitted without."""

import math
from dataclasses import dataclass, replace

import numpy as np
import pytest

from softrnn.lab.families import PersistenceFamily, Physics, StaticPolynomial, stretch_edges
from softrnn.lab.nets import Hybrid, LearnedMap, NetOptions, seeded
from softrnn.lab.recording import Recording
from softrnn.lab.tendon_robot import Calibration
from softrnn.lab.uncertainty import (
    REFIT_FOLDS,
    PhysicsGap,
    RefitSpread,
    WithInterval,
    calibrate,
    pattern_folds,
    with_interval,
)

from helpers import Recalling, tendon_robot_truth


def _line(u, seed, noise=0.5e-3, rows=20, path="line"):
    """Patterns of ``rows`` rows at the command levels ``u`` (P,) [mm] (one input), the tip at (u mm, 0, 0)
    plus marker noise ``noise`` [m] per axis, each pattern labelled."""
    u = np.repeat(np.asarray(u, dtype=float), rows)
    tip = np.column_stack([u * 1e-3, np.zeros((u.size, 2))]) + np.random.default_rng(seed).normal(0, noise, (u.size, 3))
    return Recording(path=path, time=np.arange(u.size) * 0.6, inputs=u[:, None], names=("a",), units=("mm",),
                     tip=tip, labels=tuple(f"level_{k // rows}" for k in range(u.size)))


def _at(u):
    """A session of one row per command of ``u`` [mm], the tip at its true place."""
    u = np.asarray(u, dtype=float)
    return Recording(path="at", time=np.arange(u.size) * 0.6, inputs=u[:, None], names=("a",), units=("mm",),
                     tip=np.column_stack([u * 1e-3, np.zeros((u.size, 2))]))


def test_the_spread_is_the_jackknife_of_the_refits_with_the_residual():
    """The scale is sqrt((K - 1) / K sum_k |p_k - mean p|^2 + r^2), K the refits (each without one of
    ``REFIT_FOLDS`` blocks of patterns), r the median of each refit's error over the block it was fitted
    without."""
    train = _line(np.linspace(-1, 1, 12), 0)
    model = StaticPolynomial(1).fit([train])
    spread = RefitSpread.of(model, [train])
    assert len(spread.refits) == REFIT_FOLDS
    for (on, _), refit in zip(pattern_folds([train], REFIT_FOLDS), spread.refits):
        np.testing.assert_array_equal(refit.W, StaticPolynomial(1).fit(on).W)
    blocks = [block for _, block in pattern_folds([train], REFIT_FOLDS)]
    err = np.concatenate([np.linalg.norm(refit.predict(s) - s.tip, axis=1)
                          for refit, block in zip(spread.refits, blocks) for s in block])
    assert err.size == train.n_rows
    assert spread.residual == pytest.approx(np.median(err), rel=1e-12)
    probe = _at([-3.0, 0.0, 0.4, 3.0])
    p = np.stack([r.predict(probe) for r in spread.refits])
    expected = np.sqrt(0.75 * np.sum((p - p.mean(axis=0)) ** 2, axis=(0, 2)) + spread.residual ** 2)
    np.testing.assert_allclose(spread.error_scale(probe), expected, rtol=1e-12)
    np.testing.assert_array_equal(spread.predict(probe), model.predict(probe))


def test_the_spread_grows_where_the_training_data_end():
    """A line fitted on commands in [-1, 1]: its refits agree near the data and fan out beyond them, so the
    scale grows with the distance from the data and is the residual's size in the middle."""
    spread = RefitSpread.of(StaticPolynomial(1).fit([train := _line(np.linspace(-1, 1, 12), 1)]), [train])
    scale = spread.error_scale(_at([0.0, 4.0, 16.0, 64.0]))
    assert np.all(np.diff(scale) > 0)
    assert scale[0] == pytest.approx(spread.residual, rel=0.05) and scale[-1] > 2.0 * spread.residual


def test_a_model_that_learns_nothing_has_its_residual_as_scale():
    """Persistence fits nothing: its refits agree everywhere, and its scale is its residual on every row:
    the median error of its run over the whole session (each refit runs as the model runs, from the
    session's start, and is scored on its block), not of runs restarted at each block."""
    train = _line(np.linspace(-1, 1, 12), 2)
    model = PersistenceFamily().fit([train])
    spread = RefitSpread.of(model, [train])
    np.testing.assert_array_equal(spread.error_scale(_at(np.linspace(-5, 5, 9))), spread.residual)
    assert spread.residual == pytest.approx(np.median(np.linalg.norm(model.predict(train) - train.tip, axis=1)))
    restarted = np.concatenate([np.linalg.norm(model.predict(s) - s.tip, axis=1)
                                for _, block in pattern_folds([train], REFIT_FOLDS) for s in block])
    assert np.median(restarted) < 0.75 * spread.residual


def test_sessions_without_labels_are_cut_at_their_stretches():
    """Without pattern labels, the blocks are whole stretches of rows (``stretch_edges``), in order."""
    train = replace(_line(np.linspace(-1, 1, 12), 3), labels=())
    edges = stretch_edges(train.n_rows)
    for others, block in pattern_folds([train], REFIT_FOLDS):
        for s in block + others:
            first = int(round(s.time[0] / 0.6))
            assert first in edges and first + s.n_rows in edges
    assert len(RefitSpread.of(StaticPolynomial(1).fit([train]), [train]).refits) == REFIT_FOLDS


def test_blocks_too_small_to_refit_are_left_out():
    """A session of fewer rows than two blocks need: no refit, the residual alone, over the training rows."""
    tiny = _line([0.0, 1.0], 4, rows=10)
    model = StaticPolynomial(1).fit([tiny])
    spread = RefitSpread.of(model, [tiny])
    assert spread.refits == () and np.all(spread.error_scale(tiny) == spread.residual)
    assert spread.residual == pytest.approx(np.sqrt(np.mean(np.sum((model.predict(tiny) - tiny.tip) ** 2, axis=1))))


def test_the_residual_is_the_error_on_rows_the_refits_did_not_see():
    """A model that recalls every row it was fitted on has no error over them; its residual is its
    refits' error over the patterns each did not see, which grows as the model sees fewer rows."""
    train = _line(np.linspace(-1, 1, 16), 7)
    model = Recalling().fit([train])
    assert np.all(model.predict(train) == train.tip)
    spread = RefitSpread.of(model, [train])
    assert spread.residual > 0.5e-3
    fewer = RefitSpread.of(model, [train], folds=2)                 # each refit sees half the rows, not 3/4
    assert fewer.residual > spread.residual


@dataclass(frozen=True, eq=False)
class _FarOff:
    """Exact, except 1 m off at u > 0.9 when fitted without those commands (a linear model's refit that
    drifts far over the block it did not see)."""

    reaches: bool = True
    name: str = "far off"

    def fit(self, sessions):
        return replace(self, reaches=any(np.any(s.inputs[:, 0] > 0.9) for s in sessions))

    def predict(self, s):
        tip = np.column_stack([s.inputs[:, 0] * 1e-3, np.zeros((s.n_rows, 2))])
        tip[:, 1] += np.where(s.inputs[:, 0] > 0.9, 0.0 if self.reaches else 1.0, 0.0)
        return tip

    def describe(self):
        return {"kind": "far off"}


def test_one_refit_far_off_over_a_few_rows_does_not_set_the_scale_of_every_row():
    """One of twelve levels is 1 m off in the refit that did not see it: the residual stays the noise's
    median error (about 0.77 mm), where an RMS would be about 0.29 m; the refits' spread widens the
    scale at that level alone."""
    train = _line(np.linspace(-1, 1, 12), 8)
    spread = RefitSpread.of(_FarOff().fit([train]), [train])
    assert spread.residual < 2e-3
    scale = spread.error_scale(_at([0.0, 1.0]))
    assert scale[0] < 2e-3 and scale[1] > 0.3


@dataclass(frozen=True, eq=False)
class _Unstable:
    """A line whose refit on fewer than ``rows`` rows runs away (NaN) beyond u = 1."""

    rows: int = 200
    fitted_on: int = 0
    name: str = "unstable"

    def fit(self, sessions):
        return replace(self, fitted_on=sum(s.n_rows for s in sessions))

    def predict(self, s):
        tip = np.column_stack([s.inputs[:, 0] * 1e-3, np.zeros((s.n_rows, 2))])
        if self.fitted_on < self.rows:
            tip[s.inputs[:, 0] > 1.0] = np.nan
        return tip

    def describe(self):
        return {"kind": "unstable"}


def test_a_refit_that_runs_away_makes_the_scale_unbounded_there():
    train = _line(np.linspace(-1, 1, 12), 5)
    spread = RefitSpread.of(_Unstable().fit([train]), [train])
    scale = spread.error_scale(_at([0.0, 0.5, 2.0]))
    assert np.all(np.isfinite(scale[:2])) and scale[2] == math.inf
    fit_part, held = [train.rows(0, 200)], [train.rows(200, 240)]
    model = with_interval(_Unstable().fit([train]), _Unstable().fit(fit_part), fit_part, held, [train], fitted=True,
                          refits=REFIT_FOLDS)
    radius = model.predict_interval(_at([0.0, 2.0]))[1]
    assert np.isfinite(radius[0]) and radius[1] == math.inf            # the ball is unbounded where a refit runs away


def test_the_refits_give_the_benchmark_s_interval_its_scale():
    """``with_interval(refits=...)``: the model and the held model carry their refits' spread (each refitted on
    its own rows); the radius is that scale times q + b max(0, d - d0), and the description names the scale."""
    train = _line(np.linspace(-1, 1, 12), 6)
    fit_part, held = [train.rows(0, 180)], [train.rows(180, 240)]
    family = StaticPolynomial(1)
    model = with_interval(family.fit([train]), family.fit(fit_part), fit_part, held, [train], fitted=True,
                          refits=REFIT_FOLDS)
    assert isinstance(model, WithInterval) and isinstance(model.model, RefitSpread)
    probe = _at([0.0, 3.0])
    tip, radius = model.predict_interval(probe)
    d = model.reach(probe)
    beyond = np.maximum(d - model.interval_knee, 0.0)
    expected = model.model.error_scale(probe) * (model.interval_q + model.interval_slope * beyond)
    np.testing.assert_allclose(radius, expected)
    described = model.describe()
    assert "jackknife" in described["error_scale"] and described["interval_90_q"] > 0
    assert "interval_90_radius_mm" not in described
    plain = with_interval(family.fit([train]), family.fit(fit_part), fit_part, held, [train], fitted=True)
    assert not isinstance(plain.model, RefitSpread) and plain.describe()["interval_90_radius_mm"] > 0


class _Bent:
    """A physics stand-in for ``_line``'s robot: its tip, bent in y by 5 mm per mm of command beyond 1 mm
    either way (a regime the training rows in [-1, 1] mm never show); NaN at commands beyond 10 mm."""

    def predict(self, session):
        u = session.inputs[:, 0]
        tip = np.column_stack([u * 1e-3, 5e-3 * np.maximum(np.abs(u) - 1.0, 0.0), np.zeros(u.size)])
        tip[np.abs(u) > 10.0] = np.nan
        return tip


def test_the_distance_from_the_physics_joins_the_refits_scale():
    """``with_interval(physics=...)``: the refits' scale s of a model without one of its own becomes
    sqrt(s^2 + gap^2), gap its distance from the physics' tip (``PhysicsGap``; the held model's from the
    physics fitted on the fitting part). Where the robot leaves the training rows' regime as the physics
    says (a bend the line's rows never show), the line's refits agree and are wrong together: without
    the physics its ball misses those tips, with it the ball holds them. Refitted, it keeps its physics;
    where the physics' run is not finite, its scale is unbounded."""
    train = _line(np.linspace(-1, 1, 12), 6)
    fit_part, held = [train.rows(0, 180)], [train.rows(180, 240)]
    family, physics = StaticPolynomial(1), _Bent()
    model = with_interval(family.fit([train]), family.fit(fit_part), fit_part, held, [train], fitted=True,
                          refits=REFIT_FOLDS, physics=(physics, physics))
    assert isinstance(model.model, PhysicsGap) and isinstance(model.model.model, RefitSpread)
    probe = _at([0.0, 0.5, 3.0, -4.0, 12.0])
    own = model.model.model.error_scale(probe)
    gap = np.linalg.norm(model.predict(probe) - physics.predict(probe), axis=1)
    np.testing.assert_allclose(model.model.error_scale(probe)[:4], np.sqrt(own ** 2 + gap ** 2)[:4], rtol=1e-12)
    assert model.model.error_scale(probe)[4] == math.inf
    bent = replace(probe.rows(0, 4), tip=physics.predict(probe.rows(0, 4)))
    plain = with_interval(family.fit([train]), family.fit(fit_part), fit_part, held, [train], fitted=True,
                          refits=REFIT_FOLDS)
    for stated, holds in ((model, [True] * 4), (plain, [True, True, False, False])):
        tip, radius = stated.predict_interval(bent)
        assert list(np.linalg.norm(tip - bent.tip, axis=1) <= radius) == holds
    refitted = model.model.refit(fit_part)
    assert isinstance(refitted, PhysicsGap) and refitted.physics is physics
    np.testing.assert_array_equal(refitted.predict(probe), family.fit(fit_part).predict(probe))
    assert "distance from the calibrated physics' tip" in model.describe()["error_scale"]
    # a model without the refits' scale (refits=0) is not given one
    assert not isinstance(with_interval(family.fit([train]), family.fit(fit_part), fit_part, held, [train],
                                        fitted=True, physics=(physics, physics)).model, PhysicsGap)


class _BentCalibrated(_Bent):
    """``_Bent`` as a calibrated physics (``families.calibrated``)."""

    calibration = "calibrated"


def test_the_learned_map_s_scale_holds_its_distance_from_a_calibrated_physics():
    """The learned map's scale s, its training RMS error plus its ensemble's spread, becomes
    sqrt(s^2 + gap^2) with a calibrated physics fitted on its rows (gap its distance from the physics'
    tip), unbounded where the physics' run is not finite; without a calibrated physics it is s. Where the
    robot bends as the physics says beyond the training rows, the map's members agree on a straight line
    and its ball, calibrated on the same hold-out, misses those tips without the physics and holds them
    with it."""
    train = _line(np.linspace(-1, 1, 12), 7)
    fit_part, held = [train.rows(0, 180)], [train.rows(180, 240)]
    nets, physics = NetOptions(members=3, steps=300, hidden=16), _BentCalibrated()
    probe = _at([0.0, 0.5, 3.0, -4.0, 12.0])
    bent = replace(probe.rows(0, 4), tip=physics.predict(probe.rows(0, 4)))
    stated = {}
    for label, phys in (("gap", physics), ("own", None), ("uncalibrated", _Bent())):
        family = LearnedMap(options=nets, physics=phys)
        with seeded("map"):
            model, held_model = family.fit([train]), family.fit(fit_part)
        stated[label] = replace(model, **calibrate(held_model, fit_part, held))
    own = replace(stated["gap"], physics=None).error_scale(probe)
    np.testing.assert_array_equal(stated["uncalibrated"].error_scale(probe), stated["own"].error_scale(probe))
    gap = np.linalg.norm(stated["gap"].predict(probe) - physics.predict(probe), axis=1)
    scale = stated["gap"].error_scale(probe)
    np.testing.assert_allclose(scale[:4], np.sqrt(own ** 2 + gap ** 2)[:4], rtol=1e-12)
    assert scale[4] == math.inf and np.all(np.isfinite(own))
    for label, holds in (("gap", [True] * 4), ("own", [True, True, False, False])):
        tip, radius = stated[label].predict_interval(bent)
        assert list(np.linalg.norm(tip - bent.tip, axis=1) <= radius) == holds, label
    assert "distance from the calibrated physics' tip" in stated["gap"].describe()["error_scale"]
    assert "distance" not in stated["own"].describe()["error_scale"]


def _tendon_session(rows: int, seed: int) -> tuple:
    """(a physics to refit from, its marker off by 3 mm; a session of ``rows`` rows of three tendons' sines,
    patterns of 20 rows, the tip the true physics' plus 0.2 mm of noise per axis)."""
    robot, params = tendon_robot_truth(1)
    truth = Physics(robot, calibration=Calibration(robot, params, 0.0, (), 0.0))
    start = Physics(robot, calibration=Calibration(robot, replace(params, marker=7e-3), 0.0, (), 0.0))
    k = np.arange(rows)
    u = 3.0 * np.sin(0.07 * k[:, None] * (1 + 0.3 * np.arange(3)) + np.array([0.0, 2.0, 4.0])) - 0.5
    rec = Recording(path="", time=k * 0.6, inputs=u, names=("s1", "s2", "s3"), units=("mm",) * 3,
                    tip=np.zeros((rows, 3)), labels=tuple(f"p{i // 20}" for i in k))
    return start, replace(rec, tip=truth.predict(rec) + np.random.default_rng(seed).normal(0, 0.2e-3, (rows, 3)))


def test_the_hybrid_s_scale_is_its_physics_refit_spread_plus_its_ensemble_s_where_the_residual_acts():
    """Out of range (gate off) the hybrid is its physics, and so is its scale: the physics' ``RefitSpread``
    over the hybrid's training sessions; on the training rows the ensemble's spread adds to it."""
    start, rec = _tendon_session(160, 0)
    hybrid = Hybrid(start.refit([rec]), options=NetOptions(members=2, steps=50, hidden=8), gate=0.5).fit([rec])
    physics = RefitSpread.of(hybrid.physics, [rec])
    far = replace(rec, inputs=rec.inputs + 20.0)
    assert np.all(hybrid.weights(far) < 1e-12)
    np.testing.assert_allclose(hybrid.error_scale(far), physics.error_scale(far), rtol=1e-12)
    near = hybrid.error_scale(rec)
    assert np.all(near >= physics.error_scale(rec)) and np.any(near > physics.error_scale(rec))
    assert "refit spread" in hybrid.describe()["error_scale"]


def test_a_physics_refit_is_made_once_per_process_and_carried_to_another():
    """``Physics.refit`` keeps its refits (``families.REFITS``) by the robot, options, start and rows: the
    same rows give the same refit without fitting again; other rows (a tip masked) another refit; a refit
    made afresh equals the kept one to the bit (a fit is deterministic); and a process that takes another's
    refits (``shared_refits``, ``remember_refits``) uses them as its own."""
    from softrnn.lab import families

    start, rec = _tendon_session(80, 1)
    families.REFITS.clear()
    first = start.refit([rec])
    assert start.refit([rec]) is first and len(families.REFITS) == 1
    masked = replace(rec, tip=np.where(np.arange(80)[:, None] < 40, rec.tip, np.nan))
    other = start.refit([masked])
    assert other is not first and not np.array_equal(other.calibration.params.base, first.calibration.params.base)
    kept = families.shared_refits()
    families.REFITS.clear()
    again = start.refit([rec])
    assert again is not first
    for name in ("angles", "offsets", "compliance", "rotation", "base"):
        np.testing.assert_array_equal(getattr(again.calibration.params, name), getattr(first.calibration.params, name))
    families.REFITS.clear()
    families.remember_refits(kept)
    assert start.refit([rec]) is kept[start.refit_key([rec])] and start.refit([masked]) is other
    families.REFITS.clear()
